"""Planner layer: from the desired tip motion to joint velocities.

Parts (tasks, weights, limits) compose into planners, in the spirit of mink and pink; the
registry `PLANNERS` names the papers' methods.
"""

from __future__ import annotations

from twin.planners.allocation import AllocationPlanner, reachable_range
from twin.planners.differential import DifferentialPlanner
from twin.planners.limits import SlewPriority, VelocityLimit
from twin.planners.linalg import weighted_pinv
from twin.planners.parameters import PlannerParameters
from twin.planners.platform import PlatformPlanner, advance_target
from twin.planners.platform_model import PlatformModel
from twin.planners.protocols import (
    Limit,
    Planner,
    SecondaryTask,
    TargetTask,
    Task,
    VelocityScaler,
    VelocityShaper,
    Weight,
)
from twin.planners.qp import QPPlanner
from twin.planners.registry import HYBRID_RATE_LIMITS, PLANNERS, PlannerSpec, get_planner
from twin.planners.target import PlannerOutput, TipTarget
from twin.planners.tasks import JointPostureTask, PlatformYawTask, TipPoseTask
from twin.planners.weights import BetaSplit, JointLimitWeights, ProductWeights

__all__ = [
    "HYBRID_RATE_LIMITS",
    "PLANNERS",
    "AllocationPlanner",
    "BetaSplit",
    "DifferentialPlanner",
    "JointLimitWeights",
    "JointPostureTask",
    "Limit",
    "Planner",
    "PlannerOutput",
    "PlannerParameters",
    "PlannerSpec",
    "PlatformModel",
    "PlatformPlanner",
    "PlatformYawTask",
    "ProductWeights",
    "QPPlanner",
    "SecondaryTask",
    "SlewPriority",
    "TargetTask",
    "Task",
    "TipPoseTask",
    "TipTarget",
    "VelocityLimit",
    "VelocityScaler",
    "VelocityShaper",
    "Weight",
    "advance_target",
    "get_planner",
    "reachable_range",
    "weighted_pinv",
]

r"""Velocity-level planners of seed 000: PI, WPI and MTMP are one solve with different parts.

    ξ̇ = J_W⁺ (ẋ_d + k_e e) + λ (I − J_W⁺ J) Σ J_a⁺ (ζ̇_a + k_a e_a)      seed 000 eq (34)

then Algorithm 1 (`SlewPriority`) and a rate limit. PI is `weights=None` (eq (26)), WPI adds
`BetaSplit` (eqs (27)-(32)), MTMP adds `JointLimitWeights` with k_c (eqs (35)-(37)), the q2
posture task (eqs (39)-(40)) and Algorithm 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from twin.planners.limits import SlewPriority, VelocityLimit
from twin.planners.linalg import weighted_pinv
from twin.planners.target import PlannerOutput, TipTarget
from twin.planners.tasks import JointPostureTask, TipPoseTask


@dataclass
class DifferentialPlanner:
    """A composed velocity-level planner for the hybrid system.

    Attributes:
        tip: primary task (gain k_e).
        weights: callable xi → diag(W⁻¹) (..., 9), or None for the plain pseudo-inverse.
        secondary: null-space tasks.
        secondary_weight: λ of eq (34).
        slew_priority: Algorithm 1, or None.
        velocity_limit: rate limit applied last, or None.
        epsilon, damping_max: damped least squares (see `weighted_pinv`).
    """

    tip: TipPoseTask
    weights: Any = None
    secondary: tuple[JointPostureTask, ...] = ()
    secondary_weight: float = 1.0
    slew_priority: SlewPriority | None = None
    velocity_limit: VelocityLimit | None = None
    epsilon: float = 0.01
    damping_max: float = 0.05

    def reset(self, xi: np.ndarray, target: TipTarget) -> None:
        """Velocity-level planners keep no state between steps."""
        del xi, target  # Unused.

    def step(self, xi: np.ndarray, target: TipTarget, dt: float) -> PlannerOutput:
        """Joint velocities (..., 9) for the state xi (..., 9) and the desired tip motion."""
        del dt  # Unused: the solve is instantaneous; integration is the simulation's.
        J = self.tip.jacobian(xi)
        demand, error = self.tip.demand(xi, target)
        w = np.ones(xi.shape) if self.weights is None else self.weights(xi)
        J_pinv, damping = weighted_pinv(J, w, epsilon=self.epsilon, damping_max=self.damping_max)
        primary = (J_pinv @ demand[..., None])[..., 0]
        null_motion = np.zeros_like(primary)
        if self.secondary:
            projector = np.eye(xi.shape[-1]) - J_pinv @ J  # (I − J_W⁺ J), eq (33)
            wanted = sum(
                (np.swapaxes(task.jacobian(xi), -1, -2) @ task.demand(xi)[..., None])[..., 0]
                for task in self.secondary
            )  # J_a⁺ = J_aᵀ for a one-joint selector row
            null_motion = self.secondary_weight * (projector @ wanted[..., None])[..., 0]
        v = primary + null_motion
        if self.slew_priority is not None:
            v = self.slew_priority(xi, v)
        scale = np.ones(xi.shape[:-1])
        if self.velocity_limit is not None:
            v, scale = self.velocity_limit(v)
        norm = np.linalg.norm(v, axis=-1)
        return PlannerOutput(
            velocity=v,
            diagnostics={
                "weights": w,
                "task_error": error,
                "null_space_share": np.linalg.norm(null_motion, axis=-1) / np.maximum(norm, 1e-12),
                "damping": damping,
                "velocity_scale": scale,
            },
        )

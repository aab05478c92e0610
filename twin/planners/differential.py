r"""Velocity-level planners of seed 000: PI, WPI and MTMP are one solve with different parts.

    ξ̇ = J_W⁺ (ẋ_d + k_e e) + λ (I − J_W⁺ J) Σ J_a⁺ (ζ̇_a + k_a e_a)      seed 000 eq (34)

then Algorithm 1 (`SlewPriority`) and a rate limit, written once on one lane in
`twin.planners.differential_step` (`differential_velocity`), which the engine's runner and
`DifferentialPlanner.step` both run. PI is `weights=None` (eq (26)), WPI adds
`BetaSplit` (eqs (27)-(32)), MTMP adds `JointLimitWeights` with k_c (eqs (35)-(37)), the q2
posture task (eqs (39)-(40)) and Algorithm 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from twin.planners.differential_step import differential_step
from twin.planners.families import DIFFERENTIAL_PARAMETERS
from twin.planners.limits import SlewPriority, VelocityLimit
from twin.planners.parameters import (
    KIND_DIFFERENTIAL,
    pack_part,
    parameter_record,
    parameter_row,
    refuse,
)
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

    #: the kernel family it packs for (`twin.planners.families.FAMILY_DIAGNOSTICS`)
    family: ClassVar[str] = "differential"

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
        """Joint velocities (..., 9) for the state xi (..., 9) and the desired tip motion, by
        the engine's own step (`twin.planners.differential_step.differential_step`: this
        planner packed, its lane step run over the batch).

        Returns:
            velocity (..., 9) and the diagnostics `weights` diag(W⁻¹) (..., 9), `task_error`
            (..., 6) [m, rad], `null_space_share`, `damping` λ, `velocity_scale` (...).

        Raises:
            TwinError: xi not (..., 9) or not finite; a part without `pack`, or one the
                compiled kernel cannot run (`pack`).
        """
        return differential_step(self, xi, target, dt)

    def pack(self, hold: bool) -> np.ndarray:
        """The planner as its lane's parameter row (`DIFFERENTIAL_PARAMETERS`): each part
        writes its own fields (`pack`), this its solve's.

        Args:
            hold: the lane holds its joint limits (`Scenario.joint_limits == "hold"`).

        Raises:
            TwinError: a part without `pack`, or one it refuses, or knobs outside the kernel's
                domain (ε ≤ 0, a negative or non-finite weight: where numpy would give inf or
                NaN, plain Python would raise).
        """
        row = parameter_row(KIND_DIFFERENTIAL, hold)
        record = parameter_record(row, DIFFERENTIAL_PARAMETERS)
        record["split"], record["scale"], record["posture_index"] = 1.0, 1.0, -1.0
        pack_part(self.tip, record, "primary task")
        if self.weights is not None:
            pack_part(self.weights, record, "weight")
        weights = np.r_[record["split"], record["scale"]]
        if not np.all(np.isfinite(weights) & (weights >= 0)):
            raise refuse(f"weights {weights.tolist()!r:.120} (finite and ≥ 0 only)")
        for task in self.secondary:
            pack_part(task, record, "secondary task")
        for limit in (self.slew_priority, self.velocity_limit):
            if limit is not None:
                pack_part(limit, record, "limit")
        if not self.epsilon > 0:
            raise refuse(f"epsilon = {self.epsilon!r} (must be > 0)")
        record["damping"], record["epsilon"] = self.damping_max, self.epsilon
        record["secondary"] = self.secondary_weight
        return row

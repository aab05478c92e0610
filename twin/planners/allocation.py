r"""Position-level planners of seed 004: conventional methods 1, 2 and dynamic weight allocation.

Each step splits the compensating motion C(t) = ᴮT_E,d(t) · ᴮT_E(0)⁻¹ (what the base motion
asks of the tip, seed 000 §5.1) between the Stewart platform and the gangway, then solves the
gangway's analytic inverse (seed 004 eqs (7)-(8)) for the tip position:

- `conv1`: the platform takes all of C, the gangway stays put.
- `conv2`: the platform takes C's rotation, the gangway the position.
- `dwa`:   the platform takes C's roll and pitch and a share [λ_p w_i]³ of each position axis,
  with λ_p the manipulability ratio and w_i the workspace-range ratio of the previous step;
  the slew joint takes the yaw (SPEC.md, seed 004 §3.2).

The result is returned as the velocity that reaches the new state in one dt, so the
simulation integrates every planner the same way.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twin.mechanisms.hybrid import HybridBoardingSystem
from twin.planners.target import PlannerOutput, TipTarget
from twin.spatial import (
    invert_transform,
    matrix_to_rpy,
    pose_error,
    pose_to_transform,
    rpy_to_matrix,
    se3_log,
    so3_exp,
    transform_to_pose,
)


def reachable_range(mechanism: HybridBoardingSystem, pose: np.ndarray) -> np.ndarray:
    r"""Δx_p, Δy_p, Δz_p (..., 3) [m]: for each position axis, the length of the interval of
    offsets s around the pose (other five coordinates held) whose six legs stay inside their
    limits — seed 004 §3.1 c's "space search", solved in closed form.

    Moving the platform by s along axis k changes leg i to |v_i + s e_k|² = s² + 2 b s + c with
    b = v_i,k and c = |v_i|², so l_max bounds s to −b ± sqrt(b² − c + l_max²) and l_min cuts out
    −b ± sqrt(b² − c + l_min²), which lies wholly on one side of s = 0 when the pose is
    feasible. Zero if the pose itself is outside.
    """
    stewart = mechanism.stewart
    state = stewart.legs(pose)
    b = state.vectors  # (..., 6, 3): leg i's component along axis k
    c = state.lengths[..., None] ** 2
    reach = np.sqrt(np.maximum(b**2 - c + stewart.leg_max**2, 0.0))
    upper, lower = -b + reach, -b - reach
    hole = b**2 - c + stewart.leg_min**2
    half = np.sqrt(np.maximum(hole, 0.0))
    has_hole = hole > 0
    upper = np.where(has_hole & (-b > 0), np.minimum(upper, -b - half), upper)
    lower = np.where(has_hole & (-b <= 0), np.maximum(lower, -b + half), lower)
    span = np.min(upper, axis=-2) - np.max(lower, axis=-2)
    inside = stewart.within_limits(state.lengths)
    return np.where(inside[..., None], np.maximum(span, 0.0), 0.0)


@dataclass
class AllocationPlanner:
    """conv1 / conv2 / dwa on the hybrid system (seed 004).

    Attributes:
        mechanism: the hybrid system.
        method: "conv1", "conv2" or "dwa".
    """

    mechanism: HybridBoardingSystem
    method: str = "dwa"
    _T_P0: np.ndarray = field(init=False, repr=False, default=None)
    _T_E0_inv: np.ndarray = field(init=False, repr=False, default=None)
    _q0: np.ndarray = field(init=False, repr=False, default=None)
    _share: np.ndarray = field(init=False, repr=False, default=None)
    _mid: tuple[float, np.ndarray] = field(init=False, repr=False, default=None)

    def reset(self, xi: np.ndarray, target: TipTarget) -> None:
        """Remember the start: platform and tip pose, gangway joints, DWA's mid-pose values."""
        self._T_P0 = pose_to_transform(xi[..., :6])
        self._T_E0_inv = invert_transform(self.mechanism.end_effector(xi))
        self._q0 = xi[..., 6:].copy()
        mid = self.mechanism.working_state[:6]
        self._mid = (
            float(self.mechanism.stewart.manipulability(mid)),
            reachable_range(self.mechanism, mid),
        )
        self._share = self.shares(xi[..., :6])

    def shares(self, pose: np.ndarray) -> np.ndarray:
        """[λ_p w_i]³ per position axis (..., 3), clipped to [0, 1] (docs/planners.md)."""
        manip_mid, range_mid = self._mid
        lam = self.mechanism.stewart.manipulability(pose) / manip_mid
        w = reachable_range(self.mechanism, pose) / range_mid
        return np.clip(lam[..., None] * w, 0.0, 1.0) ** 3

    def step(self, xi: np.ndarray, target: TipTarget, dt: float) -> PlannerOutput:
        """The state that holds the tip at the predicted target one dt ahead, as a velocity.

        Seed 004 plans on a predicted trajectory (its §1: short-term wave-motion prediction);
        we predict one step with the target twist, T_d(t + dt) ≈ [exp(ω dt) R_d, p_d + v dt].
        """
        ahead = np.array(target.transform)
        ahead[..., :3, :3] = so3_exp(target.twist[..., 3:] * dt) @ target.transform[..., :3, :3]
        ahead[..., :3, 3] += target.twist[..., :3] * dt
        C = ahead @ self._T_E0_inv  # compensating motion in B
        T_full = C @ self._T_P0  # the platform pose that alone would hold the tip (conv1)
        p0 = self._T_P0[..., :3, 3]
        if self.method == "conv1":
            T_P = T_full
        else:
            T_P = np.array(T_full)
            if self.method == "conv2":
                T_P[..., :3, 3] = p0
            else:
                rpy = matrix_to_rpy(T_full[..., :3, :3])
                rpy[..., 2] = matrix_to_rpy(self._T_P0[..., :3, :3])[..., 2]  # slew takes yaw
                T_P[..., :3, :3] = rpy_to_matrix(rpy)
                T_P[..., :3, 3] = p0 + self._share * (T_full[..., :3, 3] - p0)
        if self.method == "conv1":
            q = self._q0
        else:
            tip_in_P = invert_transform(T_P) @ ahead
            q = self.mechanism.gangway.inverse(tip_in_P[..., :3, 3], check=False)
        new = np.concatenate([transform_to_pose(T_P), q], -1)
        diagnostics = {
            "task_error": pose_error(ahead, self.mechanism.end_effector(new)),
            "position_share": np.broadcast_to(
                self._share if self.method == "dwa" else float(self.method == "conv1"),
                (*xi.shape[:-1], 3),
            ).copy(),
        }
        if self.method == "dwa":
            self._share = self.shares(new[..., :6])  # used at the next step: t − 1 in seed 004
        twist = se3_log(invert_transform(pose_to_transform(xi[..., :6])) @ T_P) / dt
        velocity = np.concatenate([twist, (q - xi[..., 6:]) / dt], -1)
        return PlannerOutput(velocity=velocity, diagnostics=diagnostics)

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
simulation integrates every planner the same way. The step is written once, on one lane, in
`twin.planners.allocation_step` (`allocation_velocity`), which the engine's runner and
`AllocationPlanner.step` both run.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, NamedTuple

import numpy as np

from twin.mechanisms.hybrid import HybridBoardingSystem
from twin.planners.allocation_step import REACHABLE_RANGE, allocation_step
from twin.planners.families import ALLOCATION_METHODS, ALLOCATION_PARAMETERS
from twin.planners.parameters import (
    KIND_ALLOCATION,
    ROW_SIZE,
    parameter_row,
    refuse,
)
from twin.planners.target import PlannerOutput, TipTarget
from twin.spatial import invert_transform, matrix_to_rpy, pose_to_transform


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
    limits = [float(stewart.leg_min), float(stewart.leg_max)]
    return REACHABLE_RANGE([state.vectors, state.lengths], limits, [(3,)])[0]  # the lane's



class AllocationStart(NamedTuple):
    """What an `AllocationPlanner` remembers at `reset` (leading batch axes as its state's).

    Attributes:
        T_P0: (..., 4, 4) ᴮT_P at the start.
        T_E0_inv: (..., 4, 4) (ᴮT_E)⁻¹ at the start.
        q0: (..., 3) gangway joints at the start [rad, rad, m].
        manip_mid, range_mid: manipulability [-] and reachable range (3,) [m] at the
            mid-pose, DWA's normalisers (seed 004).
    """

    T_P0: np.ndarray
    T_E0_inv: np.ndarray
    q0: np.ndarray
    manip_mid: float
    range_mid: np.ndarray


@dataclass
class AllocationPlanner:
    """conv1 / conv2 / dwa on the hybrid system (seed 004).

    Attributes:
        mechanism: the hybrid system.
        method: "conv1", "conv2" or "dwa".
    """

    #: the kernel family it packs for (`twin.planners.families.FAMILY_DIAGNOSTICS`)
    family: ClassVar[str] = "allocation"

    mechanism: HybridBoardingSystem
    method: str = "dwa"
    # set by `reset`; None before it
    _start: AllocationStart | None = field(init=False, repr=False, default=None)
    _share: np.ndarray = field(init=False, repr=False, default_factory=lambda: np.ones(3))

    def reset(self, xi: np.ndarray, target: TipTarget) -> None:
        """Remember the start: platform and tip pose, gangway joints, DWA's mid-pose values."""
        mid = self.mechanism.working_state[:6]
        self._start = AllocationStart(
            T_P0=pose_to_transform(xi[..., :6]),
            T_E0_inv=invert_transform(self.mechanism.end_effector(xi)),
            q0=xi[..., 6:].copy(),
            manip_mid=float(self.mechanism.stewart.manipulability(mid)),
            range_mid=reachable_range(self.mechanism, mid),
        )
        self._share = self.shares(xi[..., :6])

    @property
    def start(self) -> AllocationStart:
        """What `reset` remembered.

        Raises:
            TwinError: the planner was not reset.
        """
        if self._start is None:
            raise refuse("an AllocationPlanner that is not reset")
        return self._start

    def pack(self, hold: bool) -> tuple[np.ndarray, np.ndarray]:
        """The planner after its `reset` as its lane's parameter row
        (`ALLOCATION_PARAMETERS`) and DWA's position shares for the next step (3,).

        Args:
            hold: the lane holds its joint limits (`Scenario.joint_limits == "hold"`).

        Raises:
            TwinError: not reset (for one lane), or an unknown method.
        """
        if self._start is None or np.shape(self._start.T_P0) != (4, 4):
            raise refuse("an AllocationPlanner that is not reset for one lane")
        return self.rows(hold), np.array(self._share, dtype=float)

    def rows(self, hold: bool) -> np.ndarray:
        """The planner after its `reset` as parameter rows (..., ROW_SIZE), one per lane of
        the state it was reset on (`ALLOCATION_PARAMETERS`, written by name); `pack` is one.

        Raises:
            TwinError: not reset, or an unknown method.
        """
        start = self.start
        if self.method not in ALLOCATION_METHODS:
            raise refuse(f"the method {self.method!r}; allowed: {list(ALLOCATION_METHODS)}")
        lanes = np.shape(start.T_P0)[:-2]
        rows = np.empty((*lanes, ROW_SIZE))
        rows[...] = parameter_row(KIND_ALLOCATION, hold)
        record = rows.view(ALLOCATION_PARAMETERS)[..., 0]  # (...) records, each a row by name
        record["method"] = ALLOCATION_METHODS[self.method]
        record["manip_mid"], record["range_mid"] = start.manip_mid, start.range_mid
        record["T_P0"] = start.T_P0[..., :3, :].reshape(*lanes, 12)
        record["T_E0_inv"] = start.T_E0_inv[..., :3, :].reshape(*lanes, 12)
        record["yaw0"] = matrix_to_rpy(start.T_P0[..., :3, :3])[..., 2]
        record["q0"] = start.q0
        return rows

    def shares(self, pose: np.ndarray) -> np.ndarray:
        """[λ_p w_i]³ per position axis (..., 3), clipped to [0, 1] (docs/planners.md)."""
        start = self.start
        lam = self.mechanism.stewart.manipulability(pose) / start.manip_mid
        w = reachable_range(self.mechanism, pose) / start.range_mid
        return np.clip(lam[..., None] * w, 0.0, 1.0) ** 3

    def step(self, xi: np.ndarray, target: TipTarget, dt: float) -> PlannerOutput:
        """The state that holds the tip at the predicted target one dt ahead, as a velocity,
        by the engine's own step (`twin.planners.allocation_step.allocation_step`: this
        planner's rows and DWA's shares, its lane step run over the batch); DWA keeps the
        shares of the state reached for the next step.

        Seed 004 plans on a predicted trajectory (its §1: short-term wave-motion prediction);
        we predict one step with the target twist, T_d(t + dt) ≈ [exp(ω dt) R_d, p_d + v dt].

        Returns:
            velocity (..., 9) [m/s, rad/s] and the diagnostics `task_error` (..., 6) [m, rad]
            (the predicted target against the tip of the state reached) and `position_share`
            (..., 3) [-] (the shares used: dwa's, 1 for conv1, 0 for conv2).

        Raises:
            TwinError: not reset, an unknown method, xi not (..., 9) or not finite, or a
                target that is not finite.
        """
        rows = self.rows(False)
        velocity, diagnostics, following = allocation_step(
            self.mechanism, rows, self._share, xi, target, dt
        )
        if self.method == "dwa":
            self._share = following  # used at the next step: t − 1 in seed 004
        return PlannerOutput(velocity=velocity, diagnostics=diagnostics)

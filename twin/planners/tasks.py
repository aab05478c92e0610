r"""Tasks: a residual, its Jacobian and a gain, in seed 000's sign convention.

Each task asks for a velocity ẋ_demand = ẋ_d + k e with e = x_d − x (seed 000 eq (34)) and
exposes the Jacobian J with ẋ = J q̇. Tasks only read the state; they hold their target.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.batch import LaneBatch
from twin.compiled import register_inline
from twin.mechanisms.gangway import gangway_jacobian_lane
from twin.mechanisms.hybrid import HybridBoardingSystem, tip_transform
from twin.planners.gains import proportional_gain
from twin.planners.lane_rows import N_TARGET, TARGET
from twin.planners.parameters import as_records, refuse
from twin.planners.target import TipTarget
from twin.spatial import rpy_to_matrix_lane, so3_exp_lane, so3_log_lane
from twin.validation import as_array


@dataclass(frozen=True)
class TipPoseTask:
    r"""Primary task: the gangway tip follows ᴮT_E,d (seed 000 eqs (25), (34)).

    Error e = [ᴮp_d − ᴮp; log(R_d Rᵀ)] in B (SPEC erratum 6), Jacobian J_task (eq (24)).

    Attributes:
        mechanism: the hybrid system.
        gain: k_e [1/s], the closed-loop deviation coefficient (0: open loop, eq (33)).
    """

    mechanism: HybridBoardingSystem
    gain: float = 25.0

    def error(self, xi: np.ndarray, target: TipTarget) -> np.ndarray:
        """e (..., 6) [m, rad], by `tip_error_lane` lane by lane (within `tip_task_lane`: one
        compiled loop serves the error, the demand and the Jacobian).

        Raises:
            TwinError: NaN or inf gangway joints (as `HybridBoardingSystem.end_effector`).
        """
        return self.demand(xi, target)[1]

    def jacobian(self, xi: np.ndarray) -> np.ndarray:
        """J_task (..., 6, 9) = diag(ᴮR_P, ᴮR_P) K, K by `tip_task_lane` lane by lane.

        Raises:
            TwinError: xi not (..., 9) or not finite (as `HybridBoardingSystem.task_jacobian`).
        """
        xi = as_array(xi, "xi", (9,))
        return TIP_TASK([xi, HELD_ROW], [0.0, *self._gangway()], [(6,), (6,), (6, 9)])[2]

    def demand(
        self, xi: np.ndarray, target: TipTarget, dt: float = 0.0
    ) -> tuple[np.ndarray, np.ndarray]:
        """(ẋ_d + k e, e), each (..., 6), by `tip_task_lane` lane by lane: k the gain k_e
        sampled over a control period dt [s] as the planners' steps apply it,
        (1 − e^(−k_e dt))/dt (`proportional_gain`); dt ≤ 0 (the default): k_e itself.

        Raises:
            TwinError: NaN or inf gangway joints (as `error`).
        """
        xi = self._checked(xi, "q")
        rows = target_rows(target)
        gain = proportional_gain(float(self.gain), float(dt))
        demand, e, _ = TIP_TASK([xi, rows], [gain, *self._gangway()],
                                [(6,), (6,), (6, 9)])  # fmt: skip
        return demand, e

    def _gangway(self) -> list[float]:
        """[d1, a1] [m], the gangway's, as the lanes take them."""
        gangway = self.mechanism.gangway
        return [float(gangway.d1), float(gangway.a1)]

    @staticmethod
    def _checked(xi: np.ndarray, name: str) -> np.ndarray:
        """xi as floats, its gangway joints checked finite (`Gangway.forward` checked them)."""
        xi = np.asarray(xi, dtype=float)
        as_array(xi[..., 6:], name, (3,))
        return xi

    def pack(self, record: np.void) -> None:
        """Write k_e into a differential parameter record's `gain`
        (`twin.planners.families.DIFFERENTIAL_PARAMETERS`).

        Raises:
            TwinError: the mechanism is not a `HybridBoardingSystem`.
        """
        if not isinstance(self.mechanism, HybridBoardingSystem):
            raise refuse(f"the primary task {self!r:.80}: only a tip task on the hybrid system")
        record["gain"] = self.gain


@dataclass(frozen=True)
class JointPostureTask:
    r"""Secondary task: hold one joint at a set value, seed 000 eqs (39)-(40).

    J_a = e_iᵀ (selects joint `index`; eq (39), SPEC erratum 5: q2 is the 8th of nine),
    ζ̇_a = 0 + k_a (ζ_a − q_i) with ζ_a = q̃_i, the joint's value when compensation starts.

    Attributes:
        index: which virtual joint (7 = q2).
        setpoint: q̃_i [rad | m].
        gain: k_a [1/s].
        n: number of joints.
    """

    index: int
    setpoint: float
    gain: float = 1.0
    n: int = 9

    def jacobian(self, xi: np.ndarray) -> np.ndarray:
        """J_a (..., 1, n)."""
        J = np.zeros((*xi.shape[:-1], 1, self.n))
        J[..., 0, self.index] = 1.0
        return J

    def demand(self, xi: np.ndarray) -> np.ndarray:
        """(..., 1) [rad/s | m/s]."""
        return self.gain * (self.setpoint - xi[..., self.index : self.index + 1])

    def pack(self, record: np.void) -> None:
        """Write the joint, k_a and q̃ into a differential parameter record's `posture_*`.

        Raises:
            TwinError: the record has a posture task already (one at most), or the joint is
                not one of the nine.
        """
        if record["posture_index"] >= 0:
            raise refuse("more than one secondary task (one posture task at most)")
        if self.n != 9 or not 0 <= self.index < 9:
            raise refuse(f"the secondary task {self!r:.80}")
        record["posture_index"] = self.index
        record["posture_gain"], record["posture_set"] = self.gain, self.setpoint


@dataclass(frozen=True)
class PlatformYawTask:
    r"""Seed 000 Algorithm 1 as a task term (the `qp` planner): the platform keeps its yaw and
    the slew joint turns the tip about P's z axis instead.

    Algorithm 1 (`twin.planners.limits.SlewPriority`) hands the sum of the platform's body yaw
    rate ω_pz and the slew rate q̇1 to q̇1, leaving the platform ω_pz,hold = −yaw_hold·tan(φ)·ω_py
    (with yaw_hold = 1 the rate at which its Euler yaw stays put, docs/decisions.md "MTMP's
    yaw"). As a residual: J_y v = ω_pz + yaw_hold·tan(φ)·ω_py, wanted 0; the slew joint's limits
    and rate are the QP's hard limits, so Algorithm 1's σ bands are not needed.

    Attributes:
        yaw_hold: [-] as `SlewPriority.yaw_hold`.
        n: number of joints.
    """

    yaw_hold: float = 1.0
    n: int = 9

    def jacobian(self, xi: np.ndarray) -> np.ndarray:
        """J_y (..., 1, n): ω_pz (column 5) plus yaw_hold·tan(roll) ω_py (column 4)."""
        J = np.zeros((*xi.shape[:-1], 1, self.n))
        J[..., 0, 4] = self.yaw_hold * np.tan(xi[..., 3])
        J[..., 0, 5] = 1.0
        return J

    def demand(self, xi: np.ndarray) -> np.ndarray:
        """(..., 1) [rad/s]: zero."""
        return np.zeros((*xi.shape[:-1], 1))

    def pack(self, record: np.void) -> None:
        """Write the yaw term into a qp parameter record's `yaw` (1: on) and `yaw_hold`
        (`twin.planners.families.QP_PARAMETERS`).

        Raises:
            TwinError: a record without a yaw term (a family other than qp), a yaw term there
                already, not nine joints, or yaw_hold not finite.
        """
        if "yaw" not in (record.dtype.names or ()):
            raise refuse(f"the secondary task {self!r:.80} (a term of the qp planner only)")
        if record["yaw"] > 0.0:
            raise refuse("more than one PlatformYawTask")
        if self.n != 9 or not np.isfinite(self.yaw_hold):
            raise refuse(f"the secondary task {self!r:.80}")
        record["yaw"], record["yaw_hold"] = 1.0, self.yaw_hold


# ---------------------------------------------------------------------------------------------
# The tip task on one lane, as the engine's kernels compose it (floats and small arrays,
# compiled by numba, `twin.compiled`; plain Python without numba)
# ---------------------------------------------------------------------------------------------



@register_inline
def tip_error_lane(
    x: np.ndarray,
    R: np.ndarray,
    target: np.ndarray,
    d1: float,
    a1: float,
    frames: np.ndarray,
    M: np.ndarray,
    error_out: np.ndarray,
) -> None:
    """The tip of one lane and its pose error against the target: what the tip task plans on
    (`tip_task_lane`) and what a run records (`twin.sim.kernels.records`), computed once.

    Args:
        x: (9,) xi [m, rad]; R: (3, 3) its ᴮR_P (`rpy_to_matrix_lane`).
        target: (N_TARGET,) the target row (`TARGET`; ᴮR_d and ᴮp_d read).
        d1, a1: [m] the gangway's (`gangway_tip_lane`).
        frames: (2, 4, 4) written: ᴾT_E and ᴮT_E (`tip_transform`).
        M: (3, 3) written: R_d R_Eᵀ.
        error_out: (6,) written: e = [p_d − p_E; log(R_d R_Eᵀ)] [m, rad] in B (seed 000
            eq (34), SPEC erratum 6).
    """
    E = frames[1]
    tip_transform(x, R, d1, a1, frames[0], E)
    for i in range(3):
        for j in range(3):
            M[i, j] = (
                target[3 * i] * E[j, 0] + target[3 * i + 1] * E[j, 1] + target[3 * i + 2] * E[j, 2]
            )
    so3_log_lane(M, error_out[3:])
    for i in range(3):
        error_out[i] = target[9 + i] - E[i, 3]


@register_inline
def tip_task_lane(
    x: np.ndarray,
    R: np.ndarray,
    target: np.ndarray,
    gain: float,
    d1: float,
    a1: float,
    frames: np.ndarray,
    M: np.ndarray,
    K: np.ndarray,
    demand: np.ndarray,
    error: np.ndarray,
) -> None:
    """The tip task of one lane (`TipPoseTask`): the task Jacobian in P,
    K = [[I, −[ᴾp_E]×, J_s,p], [0, I, J_s,ω]] (seed 000 eq (24) with D = diag(ᴮR_P, ᴮR_P)
    factored out; J_s eq (11), `gangway_jacobian_lane`) into K (6, 9), and the demand
    ẋ_d + k_e e in B (eq (34); e = [p_d − p; log(R_d Rᵀ)], SPEC erratum 6) into demand (6,).

    Args:
        x: (9,) xi [m, rad]; R: (3, 3) its ᴮR_P (`rpy_to_matrix_lane`).
        target: (N_TARGET,) the target row (`TARGET`); gain: k_e [1/s].
        d1, a1: [m] the gangway's (`gangway_tip_lane`).
        frames: (2, 4, 4) written: ᴾT_E and ᴮT_E (`tip_transform`).
        M: (3, 3) written: R_d R_Eᵀ.
        error: (6,) written: e (`tip_error_lane`), kept for what is recorded.
    """
    G = frames[0]
    tip_error_lane(x, R, target, d1, a1, frames, M, error)
    for i in range(6):
        demand[i] = target[12 + i] + gain * error[i]
    for a in range(6):
        for j in range(9):
            K[a, j] = 1.0 if a == j else 0.0
    gx, gy, gz = G[0, 3], G[1, 3], G[2, 3]
    K[0, 4], K[0, 5], K[1, 3], K[1, 5], K[2, 3], K[2, 4] = gz, -gy, -gz, gx, gy, -gx
    gangway_jacobian_lane(G, x[8], a1, K, 6)


@register_inline
def advance_target_lane(
    R_d: np.ndarray, p_d: np.ndarray, twist: np.ndarray, dt: float, E: np.ndarray,
    R_out: np.ndarray, p_out: np.ndarray,
) -> None:  # fmt: skip
    """A target (R_d (9,) row-major, p_d (3,) [m], twist (6,) [m/s, rad/s]: a `TARGET` row's
    parts) moved by its twist, held constant over dt [s]: exp(ω dt) R_d into R_out (3, 3)
    (`so3_exp_lane`; Ṙ_d = [ω]× R_d, ω in B), p_d + ṗ_d dt into p_out (3,) [m]. The one-step
    prediction of seed 004 §1 and the `ik` law's next sample (`twin.planners.platform.
    advance_target`); E (≥ 3, ≥ 3) scratch."""
    so3_exp_lane(twist[3] * dt, twist[4] * dt, twist[5] * dt, E)
    for j in range(3):
        d0, d1, d2 = R_d[j], R_d[3 + j], R_d[6 + j]
        for i in range(3):
            R_out[i, j] = E[i, 0] * d0 + E[i, 1] * d1 + E[i, 2] * d2
        p_out[j] = p_d[j] + twist[j] * dt


def target_rows(target: TipTarget) -> np.ndarray:
    """The target as lane rows (..., N_TARGET) (`TARGET`): ᴮR_d row-major, ᴮp_d [m], the
    twist."""
    transform = np.asarray(target.transform, dtype=float)
    twist = np.asarray(target.twist, dtype=float)
    shape = np.broadcast_shapes(transform.shape[:-2], twist.shape[:-1])
    rows = np.empty((*shape, N_TARGET))
    named = as_records(rows, TARGET)  # by name
    named["R_d"] = transform[..., :3, :3].reshape(*transform.shape[:-2], 9)
    named["p_d"] = transform[..., :3, 3]
    named["twist"] = twist
    return rows


#: a target row for what does not read the target (the Jacobian): ᴮR_d = I, the rest 0
HELD_ROW = np.r_[np.eye(3).ravel(), np.zeros(9)]


def _tip_task_batch(
    x: np.ndarray,
    target: np.ndarray,
    gain: float,
    d1: float,
    a1: float,
    demand: np.ndarray,
    error: np.ndarray,
    J: np.ndarray,
) -> None:
    """`tip_task_lane` over states x (N, 9) and target rows (N, 18) into demand (N, 6), error
    (N, 6) and J_task = diag(ᴮR_P, ᴮR_P) K (N, 6, 9) in B (seed 000 eq (24): the lane leaves D
    factored out)."""
    R, M, frames, K = np.empty((3, 3)), np.empty((3, 3)), np.empty((2, 4, 4)), np.empty((6, 9))
    for k in range(x.shape[0]):
        rpy_to_matrix_lane(x[k, 3], x[k, 4], x[k, 5], R)
        tip_task_lane(x[k], R, target[k], gain, d1, a1, frames, M, K, demand[k], error[k])
        for half in (0, 3):
            for i in range(3):
                for j in range(9):
                    J[k, half + i, j] = (
                        R[i, 0] * K[half, j] + R[i, 1] * K[half + 1, j] + R[i, 2] * K[half + 2, j]
                    )


#: the lane over a batch: what `TipPoseTask` calls
TIP_TASK = LaneBatch(_tip_task_batch, cores=(1, 1))

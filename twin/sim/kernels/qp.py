r"""The `qp` planner in the engine: a family of the hybrid runner like the others, its step
assembled, solved, guarded and integrated inside the compiled lane (issue 29 item 7).

`twin.planners.qp.QPPlanner` states the step (tasks, limits, `solve_levels`); this module
writes the same matrices for one lane from floats and small arrays (`qp_problem_lane`, the
shared primitives of `twin.sim.kernels.hybrid`), tested equal to the planner object's to 1e-9
(tests/sim/kernels/test_qp_kernel.py), and solves them with the object's own default solver,
`twin.planners.qp.solve_levels_lane` (Goldfarb-Idnani, `twin.planners.active_set`): one
statement of the math and no library call, so `qp_velocity` is the planner step of a
`KIND_QP` lane in `twin.sim.kernels.hybrid_runner.hybrid_lane`, whose guard (`limit_scale_lane`
in `hold` mode) and integration every hybrid family shares. Its scratch is allocated once per
lane (`qp_lane_work`).

The matrices (one lane; the layout `QPProblem` keeps):

- H (9, 9), f (9,): w_o K_oᵀK_o, −w_o K_oᵀ ᴾb_o (the orientation rows in P, as the
  differential kernel solves in P: J = D K with D = diag(ᴮR_P, ᴮR_P) orthogonal, so
  J_oᵀJ_o = K_oᵀK_o), the posture term on q2 and the yaw term (w_s), μ diag(1 / w_β);
- A (N_QP_ROWS, 9): the position rows J_p = ᴮR_P K_p (3), the leg rows (6), the Table 6 rows
  (9) (`twin.planners.qp`: `LegStrokeLimit`, `JointLimit`);
- lower, upper (9 + N_QP_ROWS,): the rate box (9), b_p twice (the position is an equality),
  the velocity-damper bounds (15).

prm rows from `P_FAMILY` on (packed by `pack_qp`): `P_QP_GAIN` k_e [1/s]; `P_QP_ORIENTATION`
w_o; `P_QP_POSITION` the position weight of level 1; `P_QP_SECONDARY` w_s; `P_QP_DAMPING` μ;
`P_QP_SPLIT` (9) the β split w_j; `P_QP_POSTURE_INDEX` (−1: none), `P_QP_POSTURE_GAIN` [1/s],
`P_QP_POSTURE_SET`; `P_QP_YAW` (1: the yaw term on) and `P_QP_YAW_HOLD`; `P_QP_LEG_GAIN`,
`P_QP_LEG_MARGIN` [m]; `P_QP_JOINT_GAIN`, `P_QP_JOINT_MARGIN` [m | rad]; `P_QP_RATE` (9)
[m/s, rad/s]; `P_QP_SOLVER` (index into `twin.planners.qp.SOLVERS`: 0, the compiled solver, the one
the engine runs).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from twin.compiled import register_borrowing, register_inline, register_jitable
from twin.planners.qp import N_POSITION, levels_work, solve_levels_lane
from twin.sim.kernels.hybrid import (
    hybrid_constants,
    hybrid_tip_task,
    tip_task_lane,
)
from twin.sim.kernels.layout import (
    C_BASE_HINGES,
    C_LEG_MAX,
    C_LEG_MIN,
    C_LOWER,
    C_PLATFORM_HINGES,
    C_UPPER,
    D_QP_ACTIVE,
    D_QP_LEVEL,
    FAULT_INFEASIBLE,
    KIND_QP,
    N_PARAMETERS,
    P_FAMILY,
    P_HOLD,
    P_KIND,
)
from twin.spatial import rpy_to_matrix_lane

if TYPE_CHECKING:
    from twin.planners.qp import QPPlanner

#: prm rows of the qp family (module doc)
P_QP_GAIN = P_FAMILY
P_QP_ORIENTATION = P_FAMILY + 1
P_QP_POSITION = P_FAMILY + 2
P_QP_SECONDARY = P_FAMILY + 3
P_QP_DAMPING = P_FAMILY + 4
P_QP_SPLIT = P_FAMILY + 5
P_QP_POSTURE_INDEX = P_FAMILY + 14
P_QP_POSTURE_GAIN = P_FAMILY + 15
P_QP_POSTURE_SET = P_FAMILY + 16
P_QP_YAW = P_FAMILY + 17
P_QP_YAW_HOLD = P_FAMILY + 18
P_QP_LEG_GAIN = P_FAMILY + 19
P_QP_LEG_MARGIN = P_FAMILY + 20
P_QP_JOINT_GAIN = P_FAMILY + 21
P_QP_JOINT_MARGIN = P_FAMILY + 22
P_QP_RATE = P_FAMILY + 23
P_QP_SOLVER = P_FAMILY + 32
P_QP_END = P_FAMILY + 33  # first row not used by this family

#: rows of A: the position (3), the legs (6), Table 6 (9)
N_QP_ROWS = 18
#: smallest β split weight of the regularisation (`twin.planners.qp.MIN_SPLIT`)
MIN_SPLIT = 1e-6
#: relative tolerance of a limit row or rate bound counted active (`count_active`)
ACTIVE_TOL = 1e-9


def pack_qp(planner: QPPlanner, hold: bool) -> np.ndarray:
    """A `QPPlanner` as its lane's `prm` row (N_PARAMETERS,).

    Raises:
        TwinError: a planner this kernel does not assemble: a tip task other than `TipPoseTask`
            on the hybrid system; limits other than one `LegStrokeLimit` on that system and one
            `JointLimit` on its Table 6 limits, in that order; secondary tasks other than at
            most one `JointPostureTask` then at most one `PlatformYawTask`; knobs where the
            kernel would divide by zero or take NaN (a rate limit ≤ 0, a gain outside (0, 1],
            a negative weight).
    """
    from twin.errors import TwinError
    from twin.planners.qp import SOLVERS, JointLimit, LegStrokeLimit, QPPlanner
    from twin.planners.tasks import JointPostureTask, PlatformYawTask

    def refuse(what: str) -> TwinError:
        return TwinError(f"planner: the qp kernel cannot run {what}")

    if not isinstance(planner, QPPlanner):
        raise refuse(f"a {type(planner).__name__} as a QPPlanner")
    tip = hybrid_tip_task(planner, refuse)
    mechanism = tip.mechanism
    prm = np.zeros(N_PARAMETERS)
    prm[P_KIND], prm[P_HOLD] = KIND_QP, 1.0 if hold else 0.0
    prm[P_QP_GAIN] = tip.gain
    prm[P_QP_ORIENTATION] = planner.orientation_weight
    prm[P_QP_POSITION] = planner.position_weight
    prm[P_QP_SECONDARY] = planner.secondary_weight
    prm[P_QP_DAMPING] = planner.damping
    split = np.ones(9) if planner.split is None else planner.split(np.zeros(9))
    prm[P_QP_SPLIT : P_QP_SPLIT + 9] = split
    weights = np.r_[prm[P_QP_ORIENTATION : P_QP_SPLIT + 9]]
    if not np.all(np.isfinite(weights) & (weights >= 0)):
        raise refuse(f"weights {weights.tolist()!r:.120} (finite and ≥ 0 only)")
    prm[P_QP_POSTURE_INDEX] = -1.0
    kinds = [type(task) for task in planner.secondary]
    if kinds not in ([], [JointPostureTask], [PlatformYawTask],
                     [JointPostureTask, PlatformYawTask]):  # fmt: skip
        raise refuse(f"the secondary tasks {planner.secondary!r:.120}")
    for task in planner.secondary:
        if isinstance(task, JointPostureTask):
            if task.n != 9 or not 0 <= task.index < 9:
                raise refuse(f"the secondary task {task!r:.80}")
            prm[P_QP_POSTURE_INDEX] = task.index
            prm[P_QP_POSTURE_GAIN], prm[P_QP_POSTURE_SET] = task.gain, task.setpoint
        else:
            if task.n != 9 or not np.isfinite(task.yaw_hold):
                raise refuse(f"the secondary task {task!r:.80}")
            prm[P_QP_YAW], prm[P_QP_YAW_HOLD] = 1.0, task.yaw_hold
    limits = planner.limits
    if (
        len(limits) != 2
        or not isinstance(limits[0], LegStrokeLimit)
        or not isinstance(limits[1], JointLimit)
        or not np.array_equal(
            hybrid_constants(limits[0].mechanism, np.ones(9)),
            hybrid_constants(mechanism, np.ones(9)),
        )
        or not np.array_equal(limits[1].lower, mechanism.lower)
        or not np.array_equal(limits[1].upper, mechanism.upper)
    ):
        raise refuse(
            f"the limits {limits!r:.120}: one LegStrokeLimit and one JointLimit on the "
            "mechanism's own limits"
        )
    rate = np.broadcast_to(np.asarray(planner.rate_limit.maximum, dtype=float), (9,))
    for limit in limits:
        if not (0 < limit.gain <= 1 and np.isfinite(limit.margin) and limit.margin >= 0):
            raise refuse(f"the limit {limit!r:.80} (gain in (0, 1], margin ≥ 0)")
        if not np.array_equal(np.broadcast_to(limit.rate, (9,)), rate):
            raise refuse(f"the limit {limit!r:.80} on another rate box than the QP's")
    prm[P_QP_LEG_GAIN], prm[P_QP_LEG_MARGIN] = limits[0].gain, limits[0].margin
    prm[P_QP_JOINT_GAIN], prm[P_QP_JOINT_MARGIN] = limits[1].gain, limits[1].margin
    if not np.all(rate > 0) or not np.all(np.isfinite(rate)):
        raise refuse(f"the rate limits {rate.tolist()!r:.120} (finite and > 0)")
    prm[P_QP_RATE : P_QP_RATE + 9] = rate
    if planner.solver != SOLVERS[0]:  # a library is called from Python, not in a lane
        raise refuse(
            f"the solver {planner.solver!r}: the engine solves with the compiled "
            f"{SOLVERS[0]!r} (`twin.planners.active_set`); the others only through "
            "QPPlanner.step"
        )
    if not planner.damping > 0:
        raise refuse(f"the damping {planner.damping!r} (> 0: the QP must be strictly convex)")
    prm[P_QP_SOLVER] = SOLVERS.index(planner.solver)
    return prm


@register_inline
def damper_lane(value: float, low: float, high: float, gain: float, margin_low: float,
                margin_high: float, dt: float, lower: np.ndarray, upper: np.ndarray,
                i: int) -> None:  # fmt: skip
    """`twin.planners.qp.damper` on one coordinate: lower[i], upper[i] written [unit/s]."""
    lower[i] = gain * (low + margin_low - value) / dt
    upper[i] = gain * (high - margin_high - value) / dt


@register_inline
def step_bounds_lane(prm: np.ndarray, dt: float, out: np.ndarray) -> None:
    """`twin.planners.qp.step_bounds` of the lane's rate box: out (4,) = θ, s, e_rot, e_trans."""
    r = P_QP_RATE
    theta = dt * math.sqrt(prm[r + 3] ** 2 + prm[r + 4] ** 2 + prm[r + 5] ** 2)
    s = dt * math.sqrt(prm[r] ** 2 + prm[r + 1] ** 2 + prm[r + 2] ** 2)
    e_rot = (1.0 - math.cos(theta)) + (theta - math.sin(theta))
    out[0], out[1], out[2] = theta, s, e_rot
    out[3] = e_rot / theta if theta > 0 else 0.0


@register_jitable
def problem_work() -> tuple:
    """Scratch of `qp_problem_lane`, allocated once per lane: ᴮR_P (3, 3), K (6, 9), b (6,),
    the tip task's frames (2, 4, 4), M (3, 3) and error (6,), ᴾb_o (3,), the step bounds (4,)."""
    return (
        np.empty((3, 3)), np.empty((6, 9)), np.empty(6), np.empty((2, 4, 4)), np.empty((3, 3)),
        np.empty(6), np.empty(3), np.empty(4),
    )  # fmt: skip


@register_borrowing
def qp_problem_lane(
    x: np.ndarray,
    target: np.ndarray,
    prm: np.ndarray,
    const: np.ndarray,
    dt: float,
    H: np.ndarray,
    f: np.ndarray,
    A: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    work: tuple,
) -> None:
    """One lane's QP (`QPPlanner.problem`) at the state x (9,) and the target row (18,),
    written into H (9, 9), f (9,), A (N_QP_ROWS, 9), lower and upper (9 + N_QP_ROWS,)
    (module doc); `work` from `problem_work`."""
    # the tip task: ᴮR_P, K and the demand b = ẋ_d + k_e e in B (eqs (14), (24), (34))
    R, K, b, frames, M, error, bo, bounds = work
    rpy_to_matrix_lane(x[3], x[4], x[5], R)
    tip_task_lane(x, R, target, prm[P_QP_GAIN], const, frames, M, K, b, error)

    # H, f: orientation (w_o, in P), posture and yaw terms (w_s), μ diag(1 / w_β)
    w_o, w_s, mu = prm[P_QP_ORIENTATION], prm[P_QP_SECONDARY], prm[P_QP_DAMPING]
    # bo: ᴾb_o = ᴮR_Pᵀ b_o
    for i in range(3):
        bo[i] = R[0, i] * b[3] + R[1, i] * b[4] + R[2, i] * b[5]
    for i in range(9):
        s = 0.0
        for a in range(3, 6):
            s += K[a, i] * bo[a - 3]
        f[i] = -w_o * s
        for j in range(i + 1):
            s = 0.0
            for a in range(3, 6):
                s += K[a, i] * K[a, j]
            H[i, j] = w_o * s
            H[j, i] = H[i, j]
    posture = int(prm[P_QP_POSTURE_INDEX])
    if posture >= 0:  # J_a = e_postureᵀ, b_a = k_a (q̃ − q) (seed 000 eqs (39)-(40))
        H[posture, posture] += w_s
        f[posture] -= w_s * (prm[P_QP_POSTURE_GAIN] * (prm[P_QP_POSTURE_SET] - x[posture]))
    if prm[P_QP_YAW] > 0.0:  # J_y = [0 0 0 0 yaw_hold·tan φ 1 0 0 0], b_y = 0 (PlatformYawTask)
        t = prm[P_QP_YAW_HOLD] * math.tan(x[3])
        H[4, 4] += w_s * t * t
        H[4, 5] += w_s * t
        H[5, 4] += w_s * t
        H[5, 5] += w_s
    for j in range(9):
        H[j, j] += mu / max(prm[P_QP_SPLIT + j], MIN_SPLIT)

    # the rate box and the position equality
    for j in range(9):
        upper[j] = prm[P_QP_RATE + j]
        lower[j] = -prm[P_QP_RATE + j]
    for i in range(3):
        for j in range(9):
            A[i, j] = R[i, 0] * K[0, j] + R[i, 1] * K[1, j] + R[i, 2] * K[2, j]
        lower[9 + i] = b[i]
        upper[9 + i] = b[i]

    # the legs: l̇_i = (ᴮR_Pᵀ u_i)·ᴾṖ + (ᴾP_i × ᴮR_Pᵀ u_i)·ω_P (seed 000 eqs (4)-(8)), kept
    # from the stroke's ends by the step's second-order part too (`LegStrokeLimit.margins`)
    step_bounds_lane(prm, dt, bounds)
    theta, s_max, e_rot, e_trans = bounds[0], bounds[1], bounds[2], bounds[3]
    arm = 0.0
    for i in range(6):
        c = C_PLATFORM_HINGES + 3 * i
        arm = max(arm, math.sqrt(const[c] ** 2 + const[c + 1] ** 2 + const[c + 2] ** 2))
    gain = prm[P_QP_LEG_GAIN]
    shift = e_rot * arm + e_trans * s_max
    stretch = (theta * arm + (1.0 + e_trans) * s_max) ** 2 / (2.0 * const[C_LEG_MIN])
    margin_low = prm[P_QP_LEG_MARGIN] + shift
    margin_high = prm[P_QP_LEG_MARGIN] + shift + stretch
    for i in range(6):
        P0 = const[C_PLATFORM_HINGES + 3 * i]
        P1 = const[C_PLATFORM_HINGES + 3 * i + 1]
        P2 = const[C_PLATFORM_HINGES + 3 * i + 2]
        l0 = R[0, 0] * P0 + R[0, 1] * P1 + R[0, 2] * P2 + x[0] - const[C_BASE_HINGES + 3 * i]
        l1 = R[1, 0] * P0 + R[1, 1] * P1 + R[1, 2] * P2 + x[1] - const[C_BASE_HINGES + 3 * i + 1]
        l2 = R[2, 0] * P0 + R[2, 1] * P1 + R[2, 2] * P2 + x[2] - const[C_BASE_HINGES + 3 * i + 2]
        length = math.sqrt(l0 * l0 + l1 * l1 + l2 * l2)
        u0, u1, u2 = l0 / length, l1 / length, l2 / length
        r0 = R[0, 0] * u0 + R[1, 0] * u1 + R[2, 0] * u2
        r1 = R[0, 1] * u0 + R[1, 1] * u1 + R[2, 1] * u2
        r2 = R[0, 2] * u0 + R[1, 2] * u1 + R[2, 2] * u2
        row = 3 + i
        A[row, 0], A[row, 1], A[row, 2] = r0, r1, r2
        A[row, 3], A[row, 4], A[row, 5] = P1 * r2 - P2 * r1, P2 * r0 - P0 * r2, P0 * r1 - P1 * r0
        A[row, 6], A[row, 7], A[row, 8] = 0.0, 0.0, 0.0
        damper_lane(length, const[C_LEG_MIN], const[C_LEG_MAX], gain, margin_low, margin_high,
                    dt, lower, upper, 9 + row)  # fmt: skip

    # Table 6: ẋ_B = ᴮR_P ᴾṖ, d(rpy)/dt = E(rpy)⁻¹ ᴮR_P ω_P (twin.spatial.rpy_rate_matrix),
    # q̇1, q̇2, ḋ3
    for i in range(9, N_QP_ROWS):
        for j in range(9):
            A[i, j] = 0.0
    ct, tt = math.cos(x[4]), math.tan(x[4])
    cy, sy = math.cos(x[5]), math.sin(x[5])
    for j in range(3):
        A[9 + j, 0], A[9 + j, 1], A[9 + j, 2] = R[j, 0], R[j, 1], R[j, 2]
        across = cy * R[0, j] + sy * R[1, j]  # (cψ ω_x + sψ ω_y) per ω_P,j
        A[12, 3 + j] = across / ct
        A[13, 3 + j] = -sy * R[0, j] + cy * R[1, j]
        A[14, 3 + j] = R[2, j] + tt * across
    A[15, 6], A[16, 7], A[17, 8] = 1.0, 1.0, 1.0
    # kept from Table 6 by e_trans s (position), θ² (roll, pitch, yaw) too (`JointLimit`)
    gain = prm[P_QP_JOINT_GAIN]
    for j in range(9):
        margin = prm[P_QP_JOINT_MARGIN]
        if j < 3:
            margin += e_trans * s_max
        elif j < 6:
            margin += theta**2
        damper_lane(x[j], const[C_LOWER + j], const[C_UPPER + j], gain, margin, margin, dt,
                    lower, upper, 9 + 9 + j)  # fmt: skip


@register_inline
def count_active_lane(v: np.ndarray, A: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> int:
    """`twin.planners.qp.count_active` on one lane's arrays: limit rows and rate bounds at
    their bound (to `ACTIVE_TOL`, relative to the bound's size); 0 for a non-finite v."""
    count = 0
    for row in range(3, N_QP_ROWS):
        s = 0.0
        for j in range(9):
            s += A[row, j] * v[j]
        high, low = upper[9 + row], lower[9 + row]
        if s >= high - ACTIVE_TOL * (1.0 + abs(high)) or s <= low + ACTIVE_TOL * (1.0 + abs(low)):
            count += 1
    for j in range(9):
        if abs(v[j]) >= upper[j] * (1.0 - ACTIVE_TOL):
            count += 1
    return count


@register_jitable
def qp_lane_work() -> tuple:
    """Scratch of `qp_velocity`, allocated once per lane: H (9, 9), f (9,), A (N_QP_ROWS, 9),
    lower, upper (9 + N_QP_ROWS,), `problem_work`, `levels_work`."""
    return (
        np.empty((9, 9)), np.empty(9), np.empty((N_QP_ROWS, 9)), np.empty(9 + N_QP_ROWS),
        np.empty(9 + N_QP_ROWS), problem_work(), levels_work(9, N_QP_ROWS - N_POSITION),
    )  # fmt: skip


@register_borrowing
def qp_velocity(
    x: np.ndarray,
    target: np.ndarray,
    row: np.ndarray,
    const: np.ndarray,
    dt: float,
    work: tuple,
    v: np.ndarray,
    d: np.ndarray,
) -> int:
    """The qp planner's step in a hybrid lane (`twin.sim.kernels.hybrid_runner.hybrid_lane`
    guards and integrates it): its QP at the state x (9,) and target row (18,)
    (`qp_problem_lane`), solved by the planner object's own `solve_levels_lane`; v (9,)
    written (NaN when no level is solved), and D_QP_LEVEL, D_QP_ACTIVE of d. Returns
    FAULT_INFEASIBLE at level 2 (the limits relaxed), else 0. `work` from `qp_lane_work`."""
    H, f, A, lower, upper, problem, levels = work
    qp_problem_lane(x, target, row, const, dt, H, f, A, lower, upper, problem)
    level = solve_levels_lane(H, f, A, lower, upper, row[P_QP_POSITION], levels, v)
    d[D_QP_LEVEL] = level
    d[D_QP_ACTIVE] = count_active_lane(v, A, lower, upper)  # 0 for a NaN v
    return FAULT_INFEASIBLE if level == 2 else 0

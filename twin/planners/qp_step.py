r"""The `qp` planner's step on one lane, as the engine runs it: its QP assembled and solved in
the compiled lane (issue 29 item 7).

`twin.planners.qp.QPPlanner` states the step (tasks, limits, `solve_levels`); this module
writes its matrices for one lane from floats and small arrays (`qp_problem_lane`: the object's
`problem`, `step` and limits' `rows` run these lanes over a batch, `QP_PROBLEM`, `QP_STEP`,
`LIMIT_ROWS`, `COUNT_ACTIVE`; checked against finite differences and the terms' own
definitions in tests/planners/test_qp.py), and solves them with the object's own default
solver, `twin.planners.qp_levels.solve_levels_lane` (Goldfarb-Idnani, `twin.planners.active_set`):
one statement of the math and no library call. `qp_velocity` is
the step of a qp lane in `twin.sim.kernels.hybrid_runner.run_hybrid_qp`, whose guard
(`limit_scale_lane` in `hold` mode) and integration every hybrid family shares. Its scratch is
allocated once per lane (`qp_lane_work`).

The matrices (one lane; the layout `QPProblem` keeps):

- H (9, 9), f (9,): w_o K_oᵀK_o, −w_o K_oᵀ ᴾb_o (the orientation rows in P, as the
  differential step solves in P: J = D K with D = diag(ᴮR_P, ᴮR_P) orthogonal, so
  J_oᵀJ_o = K_oᵀK_o), the posture term on q2 and the yaw term (w_s), μ diag(1 / w_β);
- A (N_QP_ROWS, 9): the position rows J_p = ᴮR_P K_p (3), the leg rows (6), the Table 6 rows
  (9) (`twin.planners.qp`: `LegStrokeLimit`, `JointLimit`);
- lower, upper (9 + N_QP_ROWS,): the rate box (9), b_p twice (the position is an equality),
  the velocity-damper bounds (15).

The lane's knobs are its `twin.planners.families.QP_PARAMETERS` record (written by
`QPPlanner.pack`), the mechanism's its `twin.mechanisms.hybrid.HYBRID_CONSTANTS` record, both
read by name.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from twin.batch import LaneBatch
from twin.compiled import register_borrowing, register_inline, register_jitable
from twin.mechanisms.hybrid import HYBRID_CONSTANTS
from twin.mechanisms.legs import leg_arm_lane, leg_component, leg_twist_row_lane
from twin.planners.families import MIN_SPLIT, QP_PARAMETERS
from twin.planners.gains import proportional_gain
from twin.planners.lane_rows import FAULT_INFEASIBLE, HYBRID_DIAGNOSTICS
from twin.planners.parameters import KIND_QP, parameter_record, refuse
from twin.planners.qp_levels import N_POSITION, levels_work, solve_levels_lane
from twin.planners.tasks import tip_task_lane
from twin.spatial import rpy_rates_lane, rpy_to_matrix_lane

if TYPE_CHECKING:  # the object imports this module: its step sits below it
    from twin.planners.qp import QPPlanner

#: rows of A: the position (3), the legs (6), Table 6 (9)
N_QP_ROWS = 18
#: relative tolerance of a limit row or rate bound counted active (`count_active_lane`)
ACTIVE_TOL = 1e-9


@register_inline
def damper_lane(value: float, low: float, high: float, gain: float, margin_low: float,
                margin_high: float, dt: float, lower: np.ndarray, upper: np.ndarray,
                i: int) -> None:  # fmt: skip
    """Velocity-damper bounds on one coordinate's rate (mink's `ConfigurationLimit` form): the
    coordinate `value` may close a fraction `gain` of its room to [low + margin_low,
    high − margin_high] in dt; beyond it, it must come back by that fraction. lower[i],
    upper[i] written [unit/s]."""
    lower[i] = gain * (low + margin_low - value) / dt
    upper[i] = gain * (high - margin_high - value) / dt


@register_inline
def step_bounds_lane(rate: np.ndarray, dt: float, out: np.ndarray) -> None:
    """How far one step of rates inside the box rate (9,) [m/s, rad/s] can stray from its
    linearisation over dt [s]: out (4,) = θ, s, e_rot, e_trans.

    With θ = |ω_P| dt and s = |ᴾṖ| dt at most (the box's corners), a step moves the platform
    by ᴮT_P exp([ᴾṖ; ω_P] dt) (`HybridBoardingSystem.integrate`, Lynch & Park eq (3.88)):
    |exp([θ]×) − I − [θ]×| ≤ (1 − cos θ) + (θ − sin θ) = e_rot and |V(θ) − I| ≤
    ((1 − cos θ) + (θ − sin θ)) / θ = e_trans, the rotation's and translation's second-order
    parts."""
    theta = dt * math.sqrt(rate[3] ** 2 + rate[4] ** 2 + rate[5] ** 2)
    s = dt * math.sqrt(rate[0] ** 2 + rate[1] ** 2 + rate[2] ** 2)
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


@register_inline
def qp_cost_lane(
    x: np.ndarray, R: np.ndarray, K: np.ndarray, b: np.ndarray, p: np.record, bo: np.ndarray,
    H: np.ndarray, f: np.ndarray,
) -> None:  # fmt: skip
    """The QP's cost into H (9, 9), f (9,): the orientation term w_o |K_o v − ᴾb_o|² (in P), the
    posture and yaw terms (w_s) and μ diag(1 / w_β) (module doc; `QPPlanner.problem`), for the
    state x (9,) with ᴮR_P R, the tip task's K (6, 9) and demand b (6,) in B; p the lane's
    `QP_PARAMETERS` record, bo (3,) scratch."""
    w_o, w_s, mu = p.orientation, p.secondary, p.damping
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
    posture = int(p.posture_index)
    if posture >= 0:  # J_a = e_postureᵀ, b_a = k_a (q̃ − q) (seed 000 eqs (39)-(40))
        H[posture, posture] += w_s
        f[posture] -= w_s * (p.posture_gain * (p.posture_set - x[posture]))
    if p.yaw > 0.0:  # J_y = [0 0 0 0 yaw_hold·tan φ 1 0 0 0], b_y = 0 (PlatformYawTask)
        t = p.yaw_hold * math.tan(x[3])
        H[4, 4] += w_s * t * t
        H[4, 5] += w_s * t
        H[5, 4] += w_s * t
        H[5, 5] += w_s
    for j in range(9):
        H[j, j] += mu / max(p.split[j], MIN_SPLIT)


@register_inline
def leg_rows_lane(
    x: np.ndarray, R: np.ndarray, p: np.record, c: np.record, bounds: np.ndarray, dt: float,
    A: np.ndarray, lower: np.ndarray, upper: np.ndarray,
) -> None:  # fmt: skip
    """The leg rows 3 … 8 of A and their damper bounds (`LegStrokeLimit`): l̇_i =
    (ᴮR_Pᵀ u_i)·ᴾṖ + ᴮR_Pᵀ(ᴮR_P ᴾP_i × u_i)·ω_P (seed 000 eqs (4)-(8): the legs by
    `leg_component`, their twist rows by `leg_twist_row_lane`, turned into P), kept from the
    stroke's ends by the step's second-order part too (`LegStrokeLimit`'s bound, from
    `step_bounds_lane`); p, c the lane's `QP_PARAMETERS` and `HYBRID_CONSTANTS` records."""
    theta, s_max, e_rot, e_trans = bounds[0], bounds[1], bounds[2], bounds[3]
    hinges, base = c.platform_hinges, c.base_hinges
    arm = 0.0
    for i in range(6):
        arm = max(arm, math.sqrt(hinges[3 * i] ** 2 + hinges[3 * i + 1] ** 2
                                 + hinges[3 * i + 2] ** 2))  # fmt: skip
    gain = p.leg_gain
    shift = e_rot * arm + e_trans * s_max
    stretch = (theta * arm + (1.0 + e_trans) * s_max) ** 2 / (2.0 * c.leg_min)
    margin_low = p.leg_margin + shift
    margin_high = p.leg_margin + shift + stretch
    for i in range(6):
        l0 = leg_component(R, x, base, hinges, i, 0)
        l1 = leg_component(R, x, base, hinges, i, 1)
        l2 = leg_component(R, x, base, hinges, i, 2)
        length = math.sqrt(l0 * l0 + l1 * l1 + l2 * l2)
        a0, a1, a2 = leg_arm_lane(R, hinges, i)
        n0, n1, n2, m0, m1, m2 = leg_twist_row_lane(a0, a1, a2, l0, l1, l2, length)
        # the row against the body twist [ᴾṖ; ω_P]: diag(ᴮR_Pᵀ, ᴮR_Pᵀ) of the twist row's halves
        row = 3 + i
        for j in range(3):
            A[row, j] = R[0, j] * n0 + R[1, j] * n1 + R[2, j] * n2
            A[row, 3 + j] = R[0, j] * m0 + R[1, j] * m1 + R[2, j] * m2
            A[row, 6 + j] = 0.0
        damper_lane(length, c.leg_min, c.leg_max, gain, margin_low, margin_high,
                    dt, lower, upper, 9 + row)  # fmt: skip


@register_inline
def joint_rows_lane(
    x: np.ndarray, R: np.ndarray, p: np.record, c: np.record, bounds: np.ndarray, dt: float,
    A: np.ndarray, lower: np.ndarray, upper: np.ndarray,
) -> None:  # fmt: skip
    """The Table 6 rows 9 … 17 of A and their damper bounds (`JointLimit`): ẋ_B = ᴮR_P ᴾṖ,
    d(rpy)/dt = E(rpy)⁻¹ ᴮR_P ω_P (`twin.spatial.rpy_rates_lane`), q̇1, q̇2, ḋ3, kept from the
    limits by e_trans s (position) and θ² (roll, pitch, yaw) too (bounds from
    `step_bounds_lane`); p, c as in `leg_rows_lane`."""
    theta, s_max, e_trans = bounds[0], bounds[1], bounds[3]
    for i in range(9, N_QP_ROWS):
        for j in range(9):
            A[i, j] = 0.0
    for j in range(3):
        A[9 + j, 0], A[9 + j, 1], A[9 + j, 2] = R[j, 0], R[j, 1], R[j, 2]
        # column j: the Euler rates of ω_P = e_j, ᴮR_P e_j in B
        A[12, 3 + j], A[13, 3 + j], A[14, 3 + j] = rpy_rates_lane(x[4], x[5], R[0, j], R[1, j],
                                                                  R[2, j])  # fmt: skip
    A[15, 6], A[16, 7], A[17, 8] = 1.0, 1.0, 1.0
    gain = p.joint_gain
    for j in range(9):
        margin = p.joint_margin
        if j < 3:
            margin += e_trans * s_max
        elif j < 6:
            margin += theta**2
        damper_lane(x[j], c.lower[j], c.upper[j], gain, margin, margin, dt,
                    lower, upper, 9 + 9 + j)  # fmt: skip


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
    (module doc); prm the lane's float row (`QP_PARAMETERS` by name), const the hybrid
    constants (`HYBRID_CONSTANTS` by name); `work` from `problem_work`."""
    p, c = prm.view(QP_PARAMETERS)[0], const.view(HYBRID_CONSTANTS)[0]
    # the tip task: ᴮR_P, K and the demand b = ẋ_d + k_e e in B (eqs (14), (24), (34)), k_e
    # sampled over dt (`proportional_gain`)
    R, K, b, frames, M, error, bo, bounds = work
    rpy_to_matrix_lane(x[3], x[4], x[5], R)
    tip_task_lane(x, R, target, proportional_gain(p.gain, dt), c.d1, c.a1, frames, M, K, b,
                  error)  # fmt: skip
    qp_cost_lane(x, R, K, b, p, bo, H, f)
    # the rate box and the position equality
    for j in range(9):
        upper[j] = p.rate[j]
        lower[j] = -p.rate[j]
    for i in range(3):
        for j in range(9):
            A[i, j] = R[i, 0] * K[0, j] + R[i, 1] * K[1, j] + R[i, 2] * K[2, j]
        lower[9 + i] = b[i]
        upper[9 + i] = b[i]
    # the limits' rows, kept from the limits by the step's second-order part too
    step_bounds_lane(p.rate, dt, bounds)
    leg_rows_lane(x, R, p, c, bounds, dt, A, lower, upper)
    joint_rows_lane(x, R, p, c, bounds, dt, A, lower, upper)


@register_inline
def count_active_lane(v: np.ndarray, A: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> int:
    """Limit rows and rate bounds of one lane's arrays (`QPProblem`'s layout) at
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
    """The qp planner's step in a hybrid lane (`twin.sim.kernels.hybrid_runner.qp_lane`
    guards and integrates it): its QP at the state x (9,) and target row (18,)
    (`qp_problem_lane`), solved by the planner object's own `solve_levels_lane`; v (9,)
    written (NaN when no level is solved), and the `qp_level`, `qp_active` of the diagnostics
    row d (`HYBRID_DIAGNOSTICS`). Returns
    FAULT_INFEASIBLE at level 2 (the limits relaxed), else 0. `work` from `qp_lane_work`."""
    H, f, A, lower, upper, problem, levels = work
    qp_problem_lane(x, target, row, const, dt, H, f, A, lower, upper, problem)
    position = row.view(QP_PARAMETERS)[0].position
    level = solve_levels_lane(H, f, A, lower, upper, position, levels, v)
    diagnostics = d.view(HYBRID_DIAGNOSTICS)[0]  # the row by name
    diagnostics.qp_level = level
    diagnostics.qp_active = count_active_lane(v, A, lower, upper)  # 0 for a NaN v
    return FAULT_INFEASIBLE if level == 2 else 0


def pack_qp(planner: QPPlanner, hold: bool) -> np.ndarray:
    """A qp planner as its lane's row (ROW_SIZE,): its `pack(hold)`, which writes
    `QP_PARAMETERS` by name.

    Raises:
        TwinError: the planner has no `pack` or is not of the qp family, or a part it refuses
            (`QPPlanner.pack`).
    """
    pack = getattr(planner, "pack", None)
    row = None if pack is None else pack(hold)
    if not isinstance(row, np.ndarray) or parameter_record(row, QP_PARAMETERS).kind != KIND_QP:
        raise refuse(f"a {type(planner).__name__} as a QPPlanner")
    return row


# ---------------------------------------------------------------------------------------------
# The lanes over a batch: what the planner object's `problem`, `step` and limits run
# ---------------------------------------------------------------------------------------------


def _qp_problem_batch(
    x: np.ndarray, target: np.ndarray, row: np.ndarray, const: np.ndarray, dt: float,
    H: np.ndarray, f: np.ndarray, A: np.ndarray, lower: np.ndarray, upper: np.ndarray,
) -> None:  # fmt: skip
    """`qp_problem_lane` over states x (N, 9) and target rows (N, 18) into H (N, 9, 9),
    f (N, 9), A (N, N_QP_ROWS, 9), lower and upper (N, 9 + N_QP_ROWS); row the planner's
    (`QPPlanner.pack`), const the hybrid constants, dt [s]."""
    work = problem_work()
    for k in range(x.shape[0]):
        qp_problem_lane(x[k], target[k], row, const, dt, H[k], f[k], A[k], lower[k], upper[k],
                        work)  # fmt: skip


#: `QPPlanner.problem` (compiled on first use, `twin.batch`)
QP_PROBLEM = LaneBatch(_qp_problem_batch, cores=(1, 1))


def _qp_step_batch(
    x: np.ndarray, target: np.ndarray, row: np.ndarray, const: np.ndarray, dt: float,
    v_out: np.ndarray, diag_out: np.ndarray,
) -> None:  # fmt: skip
    """The engine's qp step (`qp_velocity`) over states x (N, 9) and target rows (N, 18) into
    v_out (N, 9) and diag_out (N, N_HYBRID_DIAGNOSTICS) (`qp_level`, `qp_active`
    written)."""
    work = qp_lane_work()
    for k in range(x.shape[0]):
        qp_velocity(x[k], target[k], row, const, dt, work, v_out[k], diag_out[k])


#: `QPPlanner.step` with the compiled solver (compiled on first use, `twin.batch`)
QP_STEP = LaneBatch(_qp_step_batch, cores=(1, 1))


def _limit_rows_batch(
    x: np.ndarray, row: np.ndarray, const: np.ndarray, dt: float, legs: bool, A: np.ndarray,
    lower: np.ndarray, upper: np.ndarray,
) -> None:  # fmt: skip
    """The leg rows (`leg_rows_lane`, legs true) or the Table 6 rows (`joint_rows_lane`) over
    states x (N, 9), written where `qp_problem_lane` writes them in A (N, N_QP_ROWS, 9), lower
    and upper (N, 9 + N_QP_ROWS) (the rest left as it was); row a `QP_PARAMETERS` row with the
    limit's fields and the rate box, const the `HYBRID_CONSTANTS` the rows read."""
    R, bounds = np.empty((3, 3)), np.empty(4)
    p, c = row.view(QP_PARAMETERS)[0], const.view(HYBRID_CONSTANTS)[0]
    step_bounds_lane(p.rate, dt, bounds)
    for k in range(x.shape[0]):
        rpy_to_matrix_lane(x[k, 3], x[k, 4], x[k, 5], R)
        if legs:
            leg_rows_lane(x[k], R, p, c, bounds, dt, A[k], lower[k], upper[k])
        else:
            joint_rows_lane(x[k], R, p, c, bounds, dt, A[k], lower[k], upper[k])


#: `LegStrokeLimit.rows`, `JointLimit.rows` (compiled on first use, `twin.batch`)
LIMIT_ROWS = LaneBatch(_limit_rows_batch, cores=(1,))


def _count_active_batch(
    v: np.ndarray, A: np.ndarray, lower: np.ndarray, upper: np.ndarray, out: np.ndarray
) -> None:
    """`count_active_lane` over rates v (N, 9) and problems A (N, N_QP_ROWS, 9), lower and
    upper (N, 9 + N_QP_ROWS) into out (N,)."""
    for k in range(v.shape[0]):
        out[k] = count_active_lane(v[k], A[k], lower[k], upper[k])


#: `twin.planners.qp.count_active` (compiled on first use, `twin.batch`)
COUNT_ACTIVE = LaneBatch(_count_active_batch, cores=(1, 2, 1, 1))

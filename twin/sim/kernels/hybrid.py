r"""The hybrid boarding system's compiled kernel: one lane (one scenario) at a time.

Every function here handles ONE lane: floats and small numpy arrays, written in a style numba
compiles (`register_jitable`) and plain Python runs unchanged (the fallback when numba is
missing; the same arithmetic, so the same numbers to the last ulp or so of `math`). Per step
nothing is allocated: the runner allocates each lane's scratch once (`*_work`) and computes
ᴮR_P once for the planner, the guard and the step; functions that allocate nothing are
`register_borrowing` (no reference counting of their array arguments), and those on the
differential step's path `register_inline` too (inlined into their callers: a call between
compiled functions cost more than some of them compute; docs/simulation.md).

- Shared primitives (also used by `twin.sim.kernels.allocation` and `.records`): ᴮR_P from
  roll-pitch-yaw, the tip ᴮT_E and its pose error, so(3) log, matrix → rpy,
  `HybridBoardingSystem.integrate`, leg lengths, limit excess and the hold-mode step limit
  `limit_scale_lane` (the former `HybridRig`'s `limit_scale`, restated in numpy as the oracle
  of tests/sim/kernels/test_hybrid_kernel.py).
- The differential planners PI, WPI and MTMP (`DifferentialPlanner.step`, seed 000 eqs
  (26)-(40), Algorithm 1, the rate limit): `pack_differential` writes a planner's knobs into a
  `prm` row, `differential_velocity` is one step, up to the damping test where that fails:
  `damped_differential_velocity`, the SVD branch below, then finishes it (the SVD allocates, so
  that branch and its `svd_pinv_apply` are not borrowing; the common step is).

The runner that steps N lanes × B steps with these and the allocation planners, handing the
records pass what a differential step computed for its start, is
`twin.sim.kernels.hybrid_runner.run_hybrid`.

The solve runs in the platform frame P instead of the base frame B: with D = diag(ᴮR_P, ᴮR_P),
the task Jacobian of seed 000 eq (24) is J = D K where

    K = [[I, −[ᴾp_E]×, J_s,p], [0, I, J_s,ω]]      (ᴾp_E the tip in P, J_s the gangway's eq (11)),

and D is orthogonal, so J_W⁺ ẋ = W Kᵀ (K W Kᵀ + λ²I)⁻¹ Dᵀ ẋ and σ(J W^½) = σ(K W^½): the same
planner as `twin.planners.differential` to rounding. The damping test of `weighted_pinv`
(σ_min of J W^½ against ε) runs as a Cholesky factorisation of K W Kᵀ − ε²(1 + 10⁻⁶) I: when
it succeeds σ_min > ε, λ = 0 and the undamped solve is that of the Cholesky factor L of
K W Kᵀ. That factor comes first, and most steps skip the shifted one: λ_min(K W Kᵀ) =
1 / ‖L⁻¹‖₂² ≥ 1 / ‖L⁻¹‖_F², so where that bound clears the shift twice over the test passes
without it (`smallest_eigenvalue_bound`; the shifted factorisation decides the rest). Only where it
fails (near a singularity, or a rank-deficient J_W when β = 0) is the SVD of K W^½ taken, and
the solve is then `weighted_pinv`'s own SVD form (damped gains s / (s² + λ²), singular values
below s_max·9·eps dropped), so damping = 0 on a rank-deficient J_W gives its numbers too.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.compiled import (
    register_borrowing,
    register_inline,
    register_jitable,
)
from twin.sim.kernels.layout import (
    C_A1,
    C_BASE_HINGES,
    C_D1,
    C_LEG_MAX,
    C_LEG_MIN,
    C_LOWER,
    C_PLATFORM_HINGES,
    C_RATE,
    C_UPPER,
    D_DAMPING,
    D_SCALE,
    D_SHARE,
    D_WEIGHTS,
    FAULT_SINGULAR,
    KIND_DIFFERENTIAL,
    N_HYBRID_CONSTANTS,
    N_PARAMETERS,
    P_FAMILY,
    P_HOLD,
    P_KIND,
)
from twin.spatial import rpy_to_matrix_lane, so3_log_lane

if TYPE_CHECKING:
    from twin.mechanisms.hybrid import HybridBoardingSystem
    from twin.planners.differential import DifferentialPlanner
    from twin.planners.tasks import TipPoseTask



HALF_PI = math.pi / 2
#: bisection steps of `limit_scale_lane`: the step is shortened to within 2⁻¹² of the limit
LIMIT_BISECTIONS = 12
#: slack [m, rad] on the limit excess a step may keep
LIMIT_SLACK = 1e-12


def hybrid_constants(mechanism: HybridBoardingSystem, rate_limit: np.ndarray) -> np.ndarray:
    """The hybrid runner's `const` (N_HYBRID_CONSTANTS,), rows as in `twin.sim.kernels.layout`.

    Args:
        mechanism: the `HybridBoardingSystem`.
        rate_limit: (9,) [m/s, rad/s] virtual-joint rate limits (`HYBRID_RATE_LIMITS`).

    Returns:
        Table 6 joint limits (absolute, SPEC erratum 3), the rate limits, gangway d1 and a1
        (Table 1), base hinges ᴮB_i and platform hinges ᴾP_i (6 × 3 row-major, seed 000
        eqs (1)-(2)) [m], the leg stroke [m] (Table 1).
    """
    const = np.zeros(N_HYBRID_CONSTANTS)
    const[C_LOWER : C_LOWER + 9] = mechanism.lower
    const[C_UPPER : C_UPPER + 9] = mechanism.upper
    const[C_RATE : C_RATE + 9] = np.asarray(rate_limit, dtype=float)
    const[C_D1], const[C_A1] = mechanism.gangway.d1, mechanism.gangway.a1
    layout = mechanism.layout
    const[C_BASE_HINGES : C_BASE_HINGES + 18] = np.asarray(layout.base_hinges).reshape(18)
    platform = np.asarray(layout.platform_hinges)
    const[C_PLATFORM_HINGES : C_PLATFORM_HINGES + 18] = platform.reshape(18)
    const[C_LEG_MIN], const[C_LEG_MAX] = mechanism.stewart.leg_min, mechanism.stewart.leg_max
    return const


# ---------------------------------------------------------------------------------------------
# Shared primitives (imported by twin.sim.kernels.allocation: keep names and signatures).
# ---------------------------------------------------------------------------------------------



@register_inline
def gangway_tip_lane(q1: float, q2: float, d3: float, const: np.ndarray, G_out: np.ndarray) -> None:
    """ᴾT_E, the gangway tip in the platform frame (Table 2 with θ2 = q2 + 90°, SPEC erratum 3;
    seed 000 eq (10), `Gangway.forward`) in closed form.

    Args:
        q1, q2: [rad] slew and luff; d3: [m] gangway length.
        const: hybrid constants (d1, a1).
        G_out: (4, 4) written.
    """
    s1, c1 = math.sin(q1), math.cos(q1)
    s2, c2 = math.sin(q2 + HALF_PI), math.cos(q2 + HALF_PI)
    reach = const[C_A1] + d3 * s2
    G_out[0, 0], G_out[0, 1], G_out[0, 2], G_out[0, 3] = c1 * c2, s1, c1 * s2, c1 * reach
    G_out[1, 0], G_out[1, 1], G_out[1, 2], G_out[1, 3] = s1 * c2, -c1, s1 * s2, s1 * reach
    G_out[2, 0], G_out[2, 1], G_out[2, 2], G_out[2, 3] = s2, 0.0, -c2, const[C_D1] - d3 * c2
    G_out[3, 0], G_out[3, 1], G_out[3, 2], G_out[3, 3] = 0.0, 0.0, 0.0, 1.0


@register_inline
def tip_transform(
    x: np.ndarray, R: np.ndarray, const: np.ndarray, G: np.ndarray, T_out: np.ndarray
) -> None:
    """ᴮT_E = ᴮT_P ᴾT_E, the gangway tip in the Stewart base frame (seed 000 eq (14),
    `HybridBoardingSystem.end_effector`).

    Args:
        x: (9,) xi [m, rad].
        R: (3, 3) ᴮR_P of x (`rpy_to_matrix_lane`; its caller has it already).
        const: hybrid constants.
        G: (4, 4) written: ᴾT_E (`gangway_tip_lane`).
        T_out: (4, 4) written.
    """
    gangway_tip_lane(x[6], x[7], x[8], const, G)
    for i in range(3):
        for j in range(4):
            T_out[i, j] = R[i, 0] * G[0, j] + R[i, 1] * G[1, j] + R[i, 2] * G[2, j]
        T_out[i, 3] += x[i]
    T_out[3, 0], T_out[3, 1], T_out[3, 2], T_out[3, 3] = 0.0, 0.0, 0.0, 1.0




@register_inline
def integrate_hybrid(
    x: np.ndarray, R: np.ndarray, v: np.ndarray, dt: float, x_out: np.ndarray
) -> None:
    """xi after the virtual-joint velocity v held for dt (`HybridBoardingSystem.integrate`).

    The platform pose moves on SE(3) by the exponential map of its body twist,
    ᴮT_P ← ᴮT_P exp([ᴾṖ; ω_P] dt) (`twin.spatial.se3_exp`: Rodrigues, and V(ω) v for the
    translation, Lynch & Park eq (3.88)); the gangway joints add q̇ dt (Euler).

    Args:
        x: (9,) xi [m, rad].
        R: (3, 3) ᴮR_P of x (`rpy_to_matrix_lane`; the planner's, shared by the bisection).
        v: (9,) [ᴾṖ [m/s]; ω_P [rad/s] (in P); q̇1, q̇2 [rad/s]; ḋ3 [m/s]].
        dt: [s].
        x_out: (9,) written; may be x itself.
    """
    vx, vy, vz = v[0] * dt, v[1] * dt, v[2] * dt
    wx, wy, wz = v[3] * dt, v[4] * dt, v[5] * dt
    theta = math.sqrt(wx * wx + wy * wy + wz * wz)
    if theta < 1e-8:
        a = 1.0 - theta**2 / 6.0
        b = 0.5 - theta**2 / 24.0
        c = 1.0 / 6.0 - theta**2 / 120.0
    else:
        a = math.sin(theta) / theta
        b = (1.0 - math.cos(theta)) / theta**2
        c = (theta - math.sin(theta)) / theta**3
    # S = skew(ω dt), S² = [k_ij]; exp(S) = I + a S + b S² = [e_ij], V = I + b S + c S²
    # (scalars, not arrays: numba would put a (3, 3) on the heap at every call)
    k00, k11, k22 = -wz * wz - wy * wy, -wz * wz - wx * wx, -wy * wy - wx * wx
    k01, k02, k12 = wx * wy, wx * wz, wy * wz
    e00, e01, e02 = 1.0 + b * k00, -a * wz + b * k01, a * wy + b * k02
    e10, e11, e12 = a * wz + b * k01, 1.0 + b * k11, -a * wx + b * k12
    e20, e21, e22 = -a * wy + b * k02, a * wx + b * k12, 1.0 + b * k22
    t0 = (1.0 + c * k00) * vx + (-b * wz + c * k01) * vy + (b * wy + c * k02) * vz
    t1 = (b * wz + c * k01) * vx + (1.0 + c * k11) * vy + (-b * wx + c * k12) * vz
    t2 = (-b * wy + c * k02) * vx + (b * wx + c * k12) * vy + (1.0 + c * k22) * vz
    # the entries of N = ᴮR_P exp(S) that matrix_to_rpy reads
    n00 = R[0, 0] * e00 + R[0, 1] * e10 + R[0, 2] * e20
    n10 = R[1, 0] * e00 + R[1, 1] * e10 + R[1, 2] * e20
    n20 = R[2, 0] * e00 + R[2, 1] * e10 + R[2, 2] * e20
    n21 = R[2, 0] * e01 + R[2, 1] * e11 + R[2, 2] * e21
    n22 = R[2, 0] * e02 + R[2, 1] * e12 + R[2, 2] * e22
    p0 = R[0, 0] * t0 + R[0, 1] * t1 + R[0, 2] * t2 + x[0]
    p1 = R[1, 0] * t0 + R[1, 1] * t1 + R[1, 2] * t2 + x[1]
    p2 = R[2, 0] * t0 + R[2, 1] * t1 + R[2, 2] * t2 + x[2]
    q1, q2, d3 = x[6] + v[6] * dt, x[7] + v[7] * dt, x[8] + v[8] * dt
    x_out[0], x_out[1], x_out[2] = p0, p1, p2
    x_out[3] = math.atan2(n21, n22)  # twin.spatial.matrix_to_rpy
    x_out[4] = math.atan2(-n20, math.hypot(n21, n22))
    x_out[5] = math.atan2(n10, n00)
    x_out[6], x_out[7], x_out[8] = q1, q2, d3


@register_borrowing
def leg_lengths_lane(x: np.ndarray, R: np.ndarray, const: np.ndarray, out: np.ndarray) -> None:
    """Stewart leg lengths l_i = |ᴮR_P ᴾP_i + ᴮO_P − ᴮB_i| [m] (seed 000 eqs (4)-(5),
    `HybridBoardingSystem.leg_lengths`) of xi x (9,) with R (3, 3) its ᴮR_P
    (`rpy_to_matrix_lane`); written to out (6,)."""
    for i in range(6):
        P0 = const[C_PLATFORM_HINGES + 3 * i]
        P1 = const[C_PLATFORM_HINGES + 3 * i + 1]
        P2 = const[C_PLATFORM_HINGES + 3 * i + 2]
        l0 = R[0, 0] * P0 + R[0, 1] * P1 + R[0, 2] * P2 + x[0] - const[C_BASE_HINGES + 3 * i]
        l1 = R[1, 0] * P0 + R[1, 1] * P1 + R[1, 2] * P2 + x[1] - const[C_BASE_HINGES + 3 * i + 1]
        l2 = R[2, 0] * P0 + R[2, 1] * P1 + R[2, 2] * P2 + x[2] - const[C_BASE_HINGES + 3 * i + 2]
        out[i] = math.sqrt(l0 * l0 + l1 * l1 + l2 * l2)


@register_inline
def positive_part(d: float) -> float:
    """max(d, 0) that keeps a NaN (as `np.maximum`)."""
    return 0.0 if d <= 0.0 else d


@register_borrowing
def limit_excess_lane(x: np.ndarray, R: np.ndarray, const: np.ndarray, out: np.ndarray) -> None:
    """How far each virtual joint (Table 6) and each leg (Table 1) is past its limit, 0 inside
    (`HybridBoardingSystem.limit_excess`), of xi x (9,) with R (3, 3) its ᴮR_P
    (`rpy_to_matrix_lane`): out (15,) [m, rad], the 9 joints then the 6 legs."""
    for i in range(9):
        out[i] = positive_part(const[C_LOWER + i] - x[i]) + positive_part(x[i] - const[C_UPPER + i])
    legs = out[9:]  # the lengths first, turned into their excess in place
    leg_lengths_lane(x, R, const, legs)
    low, high = const[C_LEG_MIN], const[C_LEG_MAX]
    for i in range(6):
        legs[i] = positive_part(low - legs[i]) + positive_part(legs[i] - high)


@register_jitable
def limit_work() -> tuple[np.ndarray, np.ndarray]:
    """Scratch of `limit_scale_lane`, allocated once per lane (numba puts every array on the
    heap: a malloc per step would cost more than the arithmetic): rows (4, 15) for the excess
    now, the trial step's excess, xi and velocity; (3, 3) for the trial's ᴮR_P."""
    return np.empty((4, 15)), np.empty((3, 3))


@register_borrowing
def step_fits(
    x: np.ndarray,
    R: np.ndarray,
    v: np.ndarray,
    s: float,
    dt: float,
    const: np.ndarray,
    work: tuple[np.ndarray, np.ndarray],
) -> bool:
    """Whether the step s·v·dt carries no joint and no leg past the excess now, work's row 0
    (limit_scale's `fits`); x, R, v, dt, const and work as in `limit_scale_lane`."""
    rows, R_trial = work
    now, excess, trial, scaled = rows[0], rows[1], rows[2, :9], rows[3, :9]
    for j in range(9):
        scaled[j] = s * v[j]
    integrate_hybrid(x, R, scaled, dt, trial)
    rpy_to_matrix_lane(trial[3], trial[4], trial[5], R_trial)
    limit_excess_lane(trial, R_trial, const, excess)
    for i in range(15):
        if not excess[i] <= now[i]:
            return False
    return True


@register_borrowing
def limit_scale_lane(
    x: np.ndarray,
    R: np.ndarray,
    v: np.ndarray,
    dt: float,
    const: np.ndarray,
    work: tuple[np.ndarray, np.ndarray],
) -> float:
    """The largest s in [0, 1] such that the step s·v·dt carries no joint and no leg further
    past its limit than it already is (a joint at its limit stops there; one beyond it, e.g. a
    start outside the limits, may only come back), to within 2⁻¹² by 12 bisections; the limit
    excess may grow by at most 1e-12 (the former `HybridRig`'s `limit_scale`, exactly).

    Args:
        x: (9,) xi [m, rad]; R: (3, 3) its ᴮR_P (`rpy_to_matrix_lane`).
        v: (9,) velocity (`integrate_hybrid`); dt: [s].
        const: hybrid constants.
        work: `limit_work()`, overwritten.
    """
    now = work[0][0]
    limit_excess_lane(x, R, const, now)
    for i in range(15):
        now[i] = now[i] + LIMIT_SLACK
    if step_fits(x, R, v, 1.0, dt, const, work):
        return 1.0
    low, high = 0.0, 1.0
    for _ in range(LIMIT_BISECTIONS):
        mid = 0.5 * (low + high)
        if step_fits(x, R, v, mid, dt, const, work):
            low = mid
        else:
            high = mid
    return low


# ---------------------------------------------------------------------------------------------
# The differential planners PI, WPI, MTMP (seed 000 eqs (26)-(40), Algorithm 1).
# ---------------------------------------------------------------------------------------------

#: This family's rows of `prm` (from layout.P_FAMILY on), written by `pack_differential`:
#: k_e [1/s] (eq (34)); the β split β^l per joint (eqs (27)-(30), 1 without weights, 9); the
#: joint-limit weight scale (1, k_c on the telescope, eq (37), 9); the posture task's joint
#: index (−1: none), gain k_a [1/s] and set-point q̃ (eqs (39)-(40)); Algorithm 1 on (1) / off
#: (0), its σ [rad], q̇1,max [rad/s], q1,min and q1,max [rad]; λ_max and ε of the damped solve
#: (`weighted_pinv`); λ of eq (34); joint-limit weights on/off (eqs (35)-(37)); the rate
#: limit on/off and its per-joint maxima [m/s, rad/s] (9, `VelocityLimit`); Algorithm 1's
#: yaw_hold.
P_GAIN, P_SPLIT, P_SCALE = P_FAMILY, P_FAMILY + 1, P_FAMILY + 10
P_POSTURE_INDEX, P_POSTURE_GAIN, P_POSTURE_SET = P_FAMILY + 19, P_FAMILY + 20, P_FAMILY + 21
P_SLEW, P_SIGMA, P_SLEW_RATE = P_FAMILY + 22, P_FAMILY + 23, P_FAMILY + 24
P_Q1_MIN, P_Q1_MAX = P_FAMILY + 25, P_FAMILY + 26
P_DAMPING, P_EPSILON, P_SECONDARY = P_FAMILY + 27, P_FAMILY + 28, P_FAMILY + 29
P_JOINT_LIMITS, P_RATE_LIMITED, P_RATE = P_FAMILY + 30, P_FAMILY + 31, P_FAMILY + 32
#: Algorithm 1's yaw_hold [-] (`SlewPriority`: 1 holds the platform's Euler yaw, 0 its body
#: yaw rate).
P_YAW_HOLD = P_RATE + 9
P_DIFFERENTIAL_END = P_YAW_HOLD + 1  # first row not used by this family

#: machine epsilon of float64 (`np.finfo(float).eps`), `weighted_pinv`'s rank cut-off
EPS = 2.220446049250313e-16


def _flat_weights(weights: object) -> list:
    """The factors of a weight object, nested `ProductWeights` flattened."""
    from twin.planners.weights import ProductWeights

    if weights is None:
        return []
    if isinstance(weights, ProductWeights):
        return [part for inner in weights.parts for part in _flat_weights(inner)]
    return [weights]


def hybrid_tip_task(planner: Any, refuse: Callable[[str], Exception]) -> TipPoseTask:
    """The planner's primary task, if the hybrid kernels can run it: a `TipPoseTask` on the
    hybrid system; else the error `refuse(what)` (which names the kernel) is raised."""
    from twin.mechanisms.hybrid import HybridBoardingSystem
    from twin.planners.tasks import TipPoseTask

    tip = planner.tip
    if not isinstance(tip, TipPoseTask) or not isinstance(tip.mechanism, HybridBoardingSystem):
        raise refuse(f"the primary task {tip!r:.80}: only TipPoseTask on the hybrid system")
    return tip


def pack_differential(planner: DifferentialPlanner, hold: bool) -> np.ndarray:
    """A `DifferentialPlanner` as its lane's `prm` row (N_PARAMETERS,).

    Args:
        planner: the planner (`get_planner("pi" | "wpi" | "mtmp", "hybrid").build(...)`, or one
            composed from the same parts).
        hold: the lane holds its joint limits (`Scenario.joint_limits == "hold"`).

    Raises:
        TwinError: the planner has a part the kernel does not implement (a tip task other than
            `TipPoseTask` on a hybrid system, weights other than `BetaSplit` and one
            `JointLimitWeights` with the mechanism's limits, more than one or another kind of
            secondary task, Algorithm 1 on other columns than 5 and 6) or knobs outside the
            kernel's domain (ε ≤ 0, σ ≤ 0, a rate limit ≤ 0, a negative weight: where numpy
            would give inf or NaN, plain Python would raise).
    """
    from twin.errors import TwinError
    from twin.planners.differential import DifferentialPlanner
    from twin.planners.tasks import JointPostureTask
    from twin.planners.weights import BetaSplit, JointLimitWeights

    def refuse(what: str) -> TwinError:
        return TwinError(f"planner: the compiled hybrid kernel cannot run {what}")

    if not isinstance(planner, DifferentialPlanner):
        raise refuse(f"a {type(planner).__name__} as a differential planner")
    tip = hybrid_tip_task(planner, refuse)
    prm = np.zeros(N_PARAMETERS)
    prm[P_KIND], prm[P_HOLD] = KIND_DIFFERENTIAL, 1.0 if hold else 0.0
    prm[P_GAIN] = tip.gain
    split, limits = np.ones(9), []
    for part in _flat_weights(planner.weights):
        if isinstance(part, BetaSplit):
            split = split * part(np.zeros(9))
        elif isinstance(part, JointLimitWeights):
            limits.append(part)
        else:
            raise refuse(f"the weight {part!r:.80}")
    prm[P_SPLIT : P_SPLIT + 9] = split
    prm[P_SCALE : P_SCALE + 9] = 1.0
    if limits:
        mechanism = tip.mechanism
        same = np.array_equal(limits[0].lower, mechanism.lower) and np.array_equal(
            limits[0].upper, mechanism.upper
        )
        if len(limits) > 1 or not same or np.shape(limits[0].scale) != (9,):
            raise refuse("joint-limit weights other than one set on the mechanism's limits")
        prm[P_SCALE : P_SCALE + 9] = limits[0].scale
        prm[P_JOINT_LIMITS] = 1.0
    weights = prm[P_SPLIT : P_SCALE + 9]
    if not np.all(np.isfinite(weights) & (weights >= 0)):
        raise refuse(f"weights {weights.tolist()!r:.120} (finite and ≥ 0 only)")
    prm[P_POSTURE_INDEX] = -1.0
    if len(planner.secondary) > 1:
        raise refuse(f"{len(planner.secondary)} secondary tasks (one posture task at most)")
    for task in planner.secondary:
        if not isinstance(task, JointPostureTask) or task.n != 9 or not 0 <= task.index < 9:
            raise refuse(f"the secondary task {task!r:.80}")
        prm[P_POSTURE_INDEX] = task.index
        prm[P_POSTURE_GAIN], prm[P_POSTURE_SET] = task.gain, task.setpoint
    slew = planner.slew_priority
    if slew is not None:
        columns = (slew.yaw_index, slew.slew_index, slew.roll_index, slew.pitch_rate_index)
        if columns != (5, 6, 3, 4):
            raise refuse(
                "Algorithm 1 on other columns than the platform yaw (5), slew (6), roll (3) "
                "and pitch rate (4)"
            )
        if not np.isfinite(slew.yaw_hold):
            raise refuse(f"Algorithm 1 with yaw_hold = {slew.yaw_hold!r} (must be finite)")
        if not slew.sigma > 0:
            raise refuse(f"Algorithm 1 with σ = {slew.sigma!r} (must be > 0)")
        prm[P_SLEW] = 1.0
        prm[P_SIGMA], prm[P_SLEW_RATE] = slew.sigma, slew.rate_max
        prm[P_Q1_MIN], prm[P_Q1_MAX] = slew.q1_min, slew.q1_max
        prm[P_YAW_HOLD] = slew.yaw_hold
    if not planner.epsilon > 0:
        raise refuse(f"epsilon = {planner.epsilon!r} (must be > 0)")
    prm[P_DAMPING], prm[P_EPSILON] = planner.damping_max, planner.epsilon
    prm[P_SECONDARY] = planner.secondary_weight
    if planner.velocity_limit is not None:
        maximum = np.broadcast_to(np.asarray(planner.velocity_limit.maximum, dtype=float), (9,))
        if not np.all(maximum > 0):
            raise refuse(f"the rate limits {maximum.tolist()!r:.120} (must be > 0)")
        prm[P_RATE_LIMITED] = 1.0
        prm[P_RATE : P_RATE + 9] = maximum
    return prm


@register_inline
def cholesky_lane(A: np.ndarray, shift: float, L: np.ndarray) -> bool:
    """Lower Cholesky factor of A − shift·I (A (6, 6) symmetric; its lower triangle is read)
    into L's lower triangle (L (6, 6), the strict upper one left as it was; L may be A itself),
    its diagonal stored inverted: L[j, j] = 1 / l_jj, so the factorisation and the solves
    (`cholesky_pinv_apply`) multiply where they would divide (a division costs several
    multiplications' latency, and these chains are latency-bound).

    Returns whether A − shift·I is positive definite (every pivot > 0; False on a NaN).
    """
    for j in range(6):
        d = A[j, j] - shift
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        inverse = 1.0 / math.sqrt(d)
        L[j, j] = inverse
        for i in range(j + 1, 6):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s * inverse
    return True


@register_inline
def smallest_eigenvalue_bound(L: np.ndarray) -> float:
    """1 / ‖L⁻¹‖_F², a lower bound on the smallest eigenvalue of A = L Lᵀ (λ_min(A) =
    1 / ‖L⁻¹‖₂² and ‖·‖₂ ≤ ‖·‖_F), from its Cholesky factor L (6, 6) with the diagonal stored
    inverted (`cholesky_lane`). X = L⁻¹ column by column by forward substitution, kept in L's
    strict upper triangle (X[i, j] at L[j, i]), which `cholesky_lane` leaves unused: at most a
    sixth of the bound is lost (the Frobenius norm sums the six 1/λ_i), for half the cost of a
    factorisation and no square root or division but the last."""
    total = 0.0
    for j in range(6):
        x0 = L[j, j]
        column = x0 * x0
        for i in range(j + 1, 6):
            s = -L[i, j] * x0
            for k in range(j + 1, i):
                s -= L[i, k] * L[j, k]
            x = s * L[i, i]
            L[j, i] = x
            column += x * x
        total += column
    return 1.0 / total


@register_inline
def cholesky_pinv_apply(
    K: np.ndarray, w: np.ndarray, L: np.ndarray, c: np.ndarray, y: np.ndarray, out: np.ndarray
) -> None:
    """out (9,) = W Kᵀ (K W Kᵀ)⁻¹ c, the undamped J_W⁺ (seed 000 eq (31)) in P applied to c (6,),
    with L Lᵀ = K W Kᵀ (`cholesky_lane`: its diagonal inverted) and W = diag(w); y (6,) is
    scratch."""
    for i in range(6):  # L z = c
        s = c[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s * L[i, i]
    for i in range(5, -1, -1):  # Lᵀ y = z
        s = y[i]
        for k in range(i + 1, 6):
            s -= L[k, i] * y[k]
        y[i] = s * L[i, i]
    for j in range(9):
        s = 0.0
        for a in range(6):
            s += K[a, j] * y[a]
        out[j] = w[j] * s


@register_jitable
def svd_pinv_apply(
    U: np.ndarray, gain: np.ndarray, Vt: np.ndarray, sqrt_w: np.ndarray, c: np.ndarray,
    out: np.ndarray,
) -> None:  # fmt: skip
    """out (9,) = W^½ V diag(gain) Uᵀ c: `weighted_pinv`'s SVD form of J_W⁺ (in P) applied to
    c (6,), with K W^½ = U S Vᵀ and gain_k = s_k / (s_k² + λ²) (0 for a dropped s_k)."""
    g = np.empty(6)
    for k in range(6):
        s = 0.0
        for a in range(6):
            s += U[a, k] * c[a]
        g[k] = gain[k] * s
    for j in range(9):
        s = 0.0
        for k in range(6):
            s += Vt[k, j] * g[k]
        out[j] = sqrt_w[j] * s


@register_inline
def tip_error_lane(
    x: np.ndarray,
    R: np.ndarray,
    target: np.ndarray,
    const: np.ndarray,
    frames: np.ndarray,
    M: np.ndarray,
    error_out: np.ndarray,
) -> None:
    """The tip of one lane and its pose error against the target: what the tip task plans on
    (`tip_task_lane`) and what a run records (`twin.sim.kernels.records`), computed once.

    Args:
        x: (9,) xi [m, rad]; R: (3, 3) its ᴮR_P (`rpy_to_matrix_lane`).
        target: (18,) the target row (layout `TARGET_*`; ᴮR_d and ᴮp_d read).
        const: hybrid constants.
        frames: (2, 4, 4) written: ᴾT_E and ᴮT_E (`tip_transform`).
        M: (3, 3) written: R_d R_Eᵀ.
        error_out: (6,) written: e = [p_d − p_E; log(R_d R_Eᵀ)] [m, rad] in B (seed 000
            eq (34), SPEC erratum 6).
    """
    E = frames[1]
    tip_transform(x, R, const, frames[0], E)
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
    const: np.ndarray,
    frames: np.ndarray,
    M: np.ndarray,
    K: np.ndarray,
    demand: np.ndarray,
    error: np.ndarray,
) -> None:
    """The tip task of one lane (`TipPoseTask`): the task Jacobian in P,
    K = [[I, −[ᴾp_E]×, J_s,p], [0, I, J_s,ω]] (seed 000 eq (24) with D = diag(ᴮR_P, ᴮR_P)
    factored out; J_s eq (11)) into K (6, 9), and the demand ẋ_d + k_e e in B (eq (34);
    e = [p_d − p; log(R_d Rᵀ)], SPEC erratum 6) into demand (6,).

    Args:
        x: (9,) xi [m, rad]; R: (3, 3) its ᴮR_P (`rpy_to_matrix_lane`).
        target: (18,) the target row (layout `TARGET_*`); gain: k_e [1/s].
        const: hybrid constants.
        frames: (2, 4, 4) written: ᴾT_E and ᴮT_E (`tip_transform`).
        M: (3, 3) written: R_d R_Eᵀ.
        error: (6,) written: e (`tip_error_lane`), kept for what is recorded.
    """
    G = frames[0]
    tip_error_lane(x, R, target, const, frames, M, error)
    for i in range(6):
        demand[i] = target[12 + i] + gain * error[i]
    for a in range(6):
        for j in range(9):
            K[a, j] = 1.0 if a == j else 0.0
    gx, gy, gz = G[0, 3], G[1, 3], G[2, 3]
    K[0, 4], K[0, 5], K[1, 3], K[1, 5], K[2, 3], K[2, 4] = gz, -gy, -gz, gx, gy, -gx
    # sin, cos of q1 and θ2 = q2 + 90° as gangway_tip_lane put them in ᴾT_E's rotation
    s1, c1, s2, c2 = G[0, 1], -G[1, 1], G[2, 0], -G[2, 2]
    d3, a1 = x[8], const[C_A1]
    K[0, 6], K[0, 7], K[0, 8] = -a1 * s1 - d3 * s1 * s2, d3 * c1 * c2, c1 * s2
    K[1, 6], K[1, 7], K[1, 8] = a1 * c1 + d3 * c1 * s2, d3 * s1 * c2, s1 * s2
    K[2, 7], K[2, 8] = d3 * s2, -c2
    K[3, 7], K[4, 7], K[5, 6] = s1, -c1, 1.0


#: rows of `differential_work`'s vectors (9 wide; the 6-vectors use the first 6): diag(W⁻¹),
#: the demand (turned into P), the posture column, its back-projection, the solve's scratch,
#: the tip's pose error e in B (`tip_error_lane`; the runner hands it to the record)
W_WEIGHTS, W_DEMAND, W_COLUMN, W_BACK, W_SOLVE, W_ERROR = 0, 1, 2, 3, 4, 5


@register_jitable
def differential_work() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                 np.ndarray]:  # fmt: skip
    """Scratch of `differential_velocity`, allocated once per lane (numba puts every array on
    the heap: a malloc per step would cost more than the arithmetic; and leading-axis views
    are free where a reshape is not): K (6, 9), A = K W Kᵀ and its factor L (6, 6), ᴾT_E and
    ᴮT_E (2, 4, 4), R_d R_Eᵀ (3, 3), the vectors (6, 9) (rows `W_*`)."""
    return (np.empty((6, 9)), np.empty((6, 6)), np.empty((6, 6)), np.empty((2, 4, 4)),
            np.empty((3, 3)), np.empty((6, 9)))  # fmt: skip


@register_inline
def posture_rate(x: np.ndarray, prm: np.ndarray, posture: int) -> float:
    """ζ̇_a = k_a (q̃ − q_i) [rad/s or m/s], the posture task's joint rate (eqs (39)-(40)), of
    joint `posture` (prm[P_POSTURE_INDEX] ≥ 0) of xi x (9,)."""
    return prm[P_POSTURE_GAIN] * (prm[P_POSTURE_SET] - x[posture])


#: `differential_velocity`'s return where the damping test fails (module doc): the step goes on
#: in `damped_differential_velocity`, which allocates the SVD's arrays and so cannot borrow
NEEDS_SVD = -1


# Called, not inlined, from its lane (`hybrid_lane`): inlining it there too made numba type
# the whole step twice, 40 s more of a first compile, for 5 % of the kernel's time per step
# (one call with its arguments' structs; docs/simulation.md)
@register_borrowing
def differential_velocity(
    x: np.ndarray,
    R: np.ndarray,
    target: np.ndarray,
    prm: np.ndarray,
    const: np.ndarray,
    work: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    v_out: np.ndarray,
    diag_out: np.ndarray,
) -> int:
    """One lane of `DifferentialPlanner.step`: the velocity of seed 000 eq (34),

        ξ̇ = J_W⁺ (ẋ_d + k_e e) + λ (I − J_W⁺ J) J_aᵀ k_a (q̃ − q_i),

    then Algorithm 1 (`SlewPriority`) and the common rate scale (`VelocityLimit`), all in
    `differential_finish`; where the damping test fails, only up to the test (NEEDS_SVD).

    Args:
        x: (9,) xi [m, rad] at sample k; R: (3, 3) its ᴮR_P (`rpy_to_matrix_lane`).
        target: (18,) the held target in B (layout `TARGET_*`): ᴮR_d row-major, ᴮp_d [m],
            twist ᴮξ̇_d = [ᴮṗ_d; ᴮω_d] [m/s, rad/s].
        prm: (N_PARAMETERS,) the lane's row (`pack_differential`).
        const: (N_HYBRID_CONSTANTS,) `hybrid_constants`.
        work: `differential_work()`, overwritten: K, K W Kᵀ, diag(W⁻¹), the demand and the
            posture column in P, which `damped_differential_velocity` goes on from; the tip
            ᴮT_E (frames[1]) and its error (row W_ERROR), which the runner hands to the record.
        v_out: (9,) written: the velocity [ᴾṖ [m/s]; ω_P [rad/s] in P; q̇1, q̇2 [rad/s];
            ḋ3 [m/s]], exactly `DifferentialPlanner.step(...).velocity` (to rounding).
        diag_out: (N_HYBRID_DIAGNOSTICS,) rows D_WEIGHTS … D_SCALE written (weights, null-space
            share, damping λ, rate scale); the other families' rows are left alone.

    Returns:
        Fault bits (0: λ = 0 on this path), or NEEDS_SVD where the damping test fails (near a
        singularity): v_out and diag_out are then not written, and the caller finishes the
        step with `damped_differential_velocity(x, prm, work, v_out, diag_out)`.
    """
    K, A, L, frames, M, vectors = work
    w, b, column = vectors[W_WEIGHTS], vectors[W_DEMAND, :6], vectors[W_COLUMN, :6]
    back, y = vectors[W_BACK], vectors[W_SOLVE, :6]
    # the tip task: K and the demand ẋ_d + k_e e in B (eqs (14), (24), (34))
    tip_task_lane(x, R, target, prm[P_GAIN], const, frames, M, K, b, vectors[W_ERROR, :6])
    # turned into P in place: b = Dᵀ (ẋ_d + k_e e)
    for half in (0, 3):
        d0, d1, d2 = b[half], b[half + 1], b[half + 2]
        for i in range(3):
            b[half + i] = R[0, i] * d0 + R[1, i] * d1 + R[2, i] * d2

    # diag(W⁻¹): β split (eqs (27)-(30)) × joint-limit weights (eqs (35)-(37), SPEC erratum 4)
    joint_limits = prm[P_JOINT_LIMITS] > 0.0
    for i in range(9):
        if joint_limits:
            lower, upper = const[C_LOWER + i], const[C_UPPER + i]
            span = upper - lower
            q = min(max(x[i], lower + 1e-3 * span), upper - 1e-3 * span)
            gradient = span * (2 * q - upper - lower) / ((upper - q) * (q - lower))
            w[i] = prm[P_SPLIT + i] * (prm[P_SCALE + i] / (1.0 + abs(gradient)))
        else:
            w[i] = prm[P_SPLIT + i]

    # A = K W Kᵀ; the damping test of weighted_pinv as a Cholesky factorisation (module doc).
    # Row a of K W once per row (in `back`, free until the solve), not once per entry: the
    # same products, (K_aj w_j) K_cj, in the same order.
    for a in range(6):
        for j in range(9):
            back[j] = K[a, j] * w[j]
        for c in range(a + 1):
            s = 0.0
            for j in range(9):
                s += back[j] * K[c, j]
            A[a, c] = s
            A[c, a] = s
    posture = int(prm[P_POSTURE_INDEX])
    if posture >= 0:  # J J_aᵀ ζ̇_a in P: K's posture column times k_a (q̃ − q_i) (eqs (39)-(40))
        wanted = posture_rate(x, prm, posture)
        for a in range(6):
            column[a] = K[a, posture] * wanted
    shift = prm[P_EPSILON] ** 2 * (1.0 + 1e-6)
    if not cholesky_lane(A, 0.0, L):
        return NEEDS_SVD
    # the shifted factor only where the bound does not decide; A's own lower triangle takes
    # it (each entry is read once, before its place is written), L stays A's factor
    if not (smallest_eigenvalue_bound(L) > 2.0 * shift or cholesky_lane(A, shift, A)):
        return NEEDS_SVD
    # σ_min(J W^½) > ε: λ = 0, J_W⁺ = W Kᵀ (K W Kᵀ)⁻¹ Dᵀ (eq (31))
    cholesky_pinv_apply(K, w, L, b, y, v_out)  # J_W⁺ ẋ; the null-space term in the finish
    if posture >= 0:
        cholesky_pinv_apply(K, w, L, column, y, back)
    return differential_finish(x, prm, work, 0.0, v_out, diag_out)


@register_jitable  # not borrowing: the SVD allocates
def damped_differential_velocity(
    x: np.ndarray,
    prm: np.ndarray,
    work: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    v_out: np.ndarray,
    diag_out: np.ndarray,
) -> int:
    """The rest of a `differential_velocity` that returned NEEDS_SVD (rare: near a singularity,
    or a rank-deficient J_W when β = 0): `weighted_pinv`'s SVD form of the solve, with
    λ² = (1 − (σ_min/ε)²) λ_max² and gains s / (s² + λ²), then `differential_finish`.

    Args:
        x: (9,) xi [m, rad]; prm: (N_PARAMETERS,) the lane's row, as given to
            `differential_velocity`.
        work: the `differential_work()` that `differential_velocity` filled.
        v_out, diag_out: as in `differential_velocity`, written.

    Returns:
        Fault bits: FAULT_SINGULAR when the damping λ > 0.
    """
    K, vectors = work[0], work[5]
    w, b, column = vectors[W_WEIGHTS], vectors[W_DEMAND, :6], vectors[W_COLUMN, :6]
    back = vectors[W_BACK]
    sqrt_w = np.empty(9)
    KW = np.empty((6, 9))
    for j in range(9):
        sqrt_w[j] = math.sqrt(w[j])
    for a in range(6):
        for j in range(9):
            KW[a, j] = K[a, j] * sqrt_w[j]
    U, sv, Vt = np.linalg.svd(KW, full_matrices=False)
    ratio = min(max(sv[5] / prm[P_EPSILON], 0.0), 1.0)
    lam2 = (1.0 - ratio**2) * prm[P_DAMPING] ** 2
    gain = np.empty(6)
    for k in range(6):
        kept = sv[k] > sv[0] * 9 * EPS
        gain[k] = 1.0 / (sv[k] + lam2 / sv[k]) if kept else 0.0
    svd_pinv_apply(U, gain, Vt, sqrt_w, b, v_out)
    if int(prm[P_POSTURE_INDEX]) >= 0:
        svd_pinv_apply(U, gain, Vt, sqrt_w, column, back)
    return differential_finish(x, prm, work, lam2, v_out, diag_out)


@register_inline
def differential_finish(
    x: np.ndarray,
    prm: np.ndarray,
    work: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    lam2: float,
    v_out: np.ndarray,
    diag_out: np.ndarray,
) -> int:
    """The end of a differential step once J_W⁺ is applied (either solve): the null-space term
    of eq (34), Algorithm 1, the rate scale and the diagnostics.

    Args:
        x: (9,) xi [m, rad]; prm: (N_PARAMETERS,) the lane's row.
        work: `differential_work()` holding diag(W⁻¹) and J_W⁺ J J_aᵀ ζ̇_a (rows W_WEIGHTS,
            W_BACK; the latter read only with a posture task).
        lam2: λ² of the solve [-].
        v_out: (9,) J_W⁺ ẋ on entry; the velocity on return (`differential_velocity`).
        diag_out: (N_HYBRID_DIAGNOSTICS,) rows D_WEIGHTS … D_SCALE written.

    Returns:
        Fault bits: FAULT_SINGULAR when the damping λ > 0.
    """
    vectors = work[5]
    w, back = vectors[W_WEIGHTS], vectors[W_BACK]
    # v = J_W⁺ ẋ + λ (I − J_W⁺ J) J_aᵀ ζ̇_a (eq (34); J_a⁺ = J_aᵀ for a selector row)
    posture = int(prm[P_POSTURE_INDEX])
    wanted = posture_rate(x, prm, posture) if posture >= 0 else 0.0
    weight = prm[P_SECONDARY]
    null2 = 0.0
    for j in range(9):
        null = 0.0
        if posture >= 0:
            null = weight * ((wanted if j == posture else 0.0) - back[j])
        null2 += null * null
        v_out[j] += null

    if prm[P_SLEW] > 0.0:  # Algorithm 1 (twin.planners.limits.SlewPriority)
        q1, q1_min, q1_max = x[6], prm[P_Q1_MIN], prm[P_Q1_MAX]
        sigma, rate = prm[P_SIGMA], prm[P_SLEW_RATE]
        total = v_out[5] + v_out[6]  # w_1sum
        # the platform keeps ω_pz,hold = −yaw_hold·tan(φ)·ω_py (its Euler yaw held at 1)
        hold = 0.0
        if prm[P_YAW_HOLD] != 0.0:
            hold = -prm[P_YAW_HOLD] * math.tan(x[3]) * v_out[4]
        free = total - hold  # what q̇1 may take
        if q1 >= q1_min + sigma and q1 <= q1_max - sigma:  # lines 2-7
            slew = rate if free > rate else (-rate if free < -rate else free)
        elif q1 > q1_min and q1 < q1_min + sigma:  # lines 8-9
            slew = 0.5 * free * (1.0 + math.cos((q1_min + sigma - q1) / sigma * math.pi))
        elif q1 > q1_max - sigma and q1 < q1_max:  # lines 10-11
            slew = 0.5 * free * (1.0 + math.cos((q1 - q1_max + sigma) / sigma * math.pi))
        else:
            slew = 0.0
        v_out[5] = total - slew
        v_out[6] = slew

    scale = 1.0
    if prm[P_RATE_LIMITED] > 0.0:  # VelocityLimit: one scale, the direction kept
        most, nan = 1.0, False
        for j in range(9):
            ratio_j = abs(v_out[j]) / prm[P_RATE + j]
            if ratio_j != ratio_j:
                nan = True
            elif ratio_j > most:
                most = ratio_j
        scale = math.nan if nan else 1.0 / most
        for j in range(9):
            v_out[j] = v_out[j] * scale
    norm2 = 0.0
    for j in range(9):
        norm2 += v_out[j] * v_out[j]
        diag_out[D_WEIGHTS + j] = w[j]
    norm = math.sqrt(norm2)
    diag_out[D_SHARE] = math.sqrt(null2) / (1e-12 if norm < 1e-12 else norm)
    damping = math.sqrt(lam2)
    diag_out[D_DAMPING] = damping
    diag_out[D_SCALE] = scale
    return FAULT_SINGULAR if damping > 0.0 else 0

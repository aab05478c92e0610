r"""The differential planners' step on one lane: PI, WPI and MTMP as the engine runs them.

`differential_velocity` is the step of `twin.planners.differential.DifferentialPlanner` (seed 000
eqs (26)-(40), Algorithm 1, the rate limit) written on one lane (floats and small arrays, in
a style numba compiles and plain Python runs unchanged), on the lane's
`DIFFERENTIAL_PARAMETERS` record (written by `DifferentialPlanner.pack`) and the hybrid
system's constants (`HybridBoardingSystem.pack`, read by name). It composes the lane
functions of the layers they belong to: `twin.planners.tasks` (the tip task's error and
Jacobian), `.weights` (joint-limit weights), `.limits` (Algorithm 1, the rate limit) and
`.linalg` (the damped weighted pseudo-inverse). The engine's runner
(`twin.sim.kernels.hybrid_runner.run_hybrid`) calls it, guards and integrates its velocity;
`DifferentialPlanner.step` runs it over its batch (`differential_step`, through
`DIFFERENTIAL_STEP`): the math is written here once.

Per step nothing is allocated: the runner allocates the lane's scratch once
(`differential_work`); the step is `register_borrowing` (no reference counting of its array
arguments) and its small functions `register_inline` (`twin.compiled`). Where the damping test
fails (near a singularity), `differential_velocity` stops (NEEDS_SVD) and
`damped_differential_velocity`, which allocates the SVD's arrays and so cannot borrow,
finishes the step.

The solve runs in the platform frame P instead of the base frame B: with D = diag(ᴮR_P, ᴮR_P),
the task Jacobian of seed 000 eq (24) is J = D K where

    K = [[I, −[ᴾp_E]×, J_s,p], [0, I, J_s,ω]]      (ᴾp_E the tip in P, J_s the gangway's eq (11)),

and D is orthogonal, so J_W⁺ ẋ = W Kᵀ (K W Kᵀ + λ²I)⁻¹ Dᵀ ẋ and σ(J W^½) = σ(K W^½): the same
planner as `DifferentialPlanner` to rounding. The damping test of `weighted_pinv` (σ_min of
J W^½ against ε) runs as a Cholesky factorisation of K W Kᵀ − ε²(1 + 10⁻⁶) I: when it succeeds
σ_min > ε, λ = 0 and the undamped solve is that of the Cholesky factor L of K W Kᵀ. That factor
comes first, and most steps skip the shifted one: λ_min(K W Kᵀ) = 1 / ‖L⁻¹‖₂² ≥ 1 / ‖L⁻¹‖_F²,
so where that bound clears the shift twice over the test passes without it
(`smallest_eigenvalue_bound`; the shifted factorisation decides the rest). Only where it fails
(near a singularity, or a rank-deficient J_W when β = 0) is the SVD of K W^½ taken, and the
solve is then `weighted_pinv`'s own SVD form (damped gains s / (s² + λ²), singular values
below s_max·9·eps dropped), so damping = 0 on a rank-deficient J_W gives its numbers too.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from twin.batch import LaneBatch
from twin.compiled import register_borrowing, register_inline, register_jitable
from twin.mechanisms.hybrid import HYBRID_CONSTANTS
from twin.planners.families import DIFFERENTIAL_PARAMETERS
from twin.planners.gains import proportional_gain
from twin.planners.lane_rows import FAULT_SINGULAR, HYBRID_DIAGNOSTICS, N_HYBRID_DIAGNOSTICS
from twin.planners.limits import held_yaw_rate_lane, slew_priority_lane, velocity_limit_lane
from twin.planners.linalg import (
    cholesky_lane,
    cholesky_pinv_apply,
    damped_gains_lane,
    smallest_eigenvalue_bound,
    svd_pinv_apply,
    weighted_gram_lane,
)
from twin.planners.parameters import (
    KIND_DIFFERENTIAL,
    as_records,
    parameter_record,
    record_dtype,
    refuse,
)
from twin.planners.target import PlannerOutput, TipTarget
from twin.planners.tasks import target_rows, tip_task_lane
from twin.planners.weights import joint_limit_weight_lane
from twin.spatial import rpy_to_matrix_lane
from twin.validation import as_array

if TYPE_CHECKING:  # the object imports this module: its step sits below it
    from twin.planners.differential import DifferentialPlanner


def pack_differential(planner: DifferentialPlanner, hold: bool) -> np.ndarray:
    """A differential planner as its lane's row (N_PARAMETERS,): its `pack(hold)`, which
    writes `twin.planners.families.DIFFERENTIAL_PARAMETERS` by name.

    Raises:
        TwinError: the planner has no `pack`, or a part it refuses (`DifferentialPlanner.pack`).
    """
    pack = getattr(planner, "pack", None)
    row = None if pack is None else pack(hold)
    if (
        not isinstance(row, np.ndarray)
        or parameter_record(row, DIFFERENTIAL_PARAMETERS).kind != KIND_DIFFERENTIAL
    ):
        raise refuse(f"a {type(planner).__name__} as a differential planner")
    return row


#: `differential_work`'s vectors, read by name (9 wide; the 6-vectors use the first 6):
#: diag(W⁻¹), the demand (turned into P), the posture column, its back-projection, the solve's
#: scratch, the tip's pose error e in B (`tip_error_lane`; the runner hands it to the record)
DIFFERENTIAL_VECTORS = record_dtype(
    (("weights", 9), ("demand", 9), ("column", 9), ("back", 9), ("solve", 9), ("error", 9)),
    what="DIFFERENTIAL_VECTORS",
)


@register_jitable
def differential_work() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                 np.ndarray]:  # fmt: skip
    """Scratch of `differential_velocity`, allocated once per lane (numba puts every array on
    the heap: a malloc per step would cost more than the arithmetic; and leading-axis views
    are free where a reshape is not): K (6, 9), A = K W Kᵀ and its factor L (6, 6), ᴾT_E and
    ᴮT_E (2, 4, 4), R_d R_Eᵀ (3, 3), the vectors (1,) (`DIFFERENTIAL_VECTORS`: its one
    record, indexed where it is read, while the work holds the array)."""
    return (np.empty((6, 9)), np.empty((6, 6)), np.empty((6, 6)), np.empty((2, 4, 4)),
            np.empty((3, 3)), np.empty(1, DIFFERENTIAL_VECTORS))  # fmt: skip


@register_inline
def posture_rate(x: np.ndarray, p: np.record, posture: int) -> float:
    """ζ̇_a = k_a (q̃ − q_i) [rad/s or m/s], the posture task's joint rate (eqs (39)-(40)), of
    joint `posture` (p.posture_index ≥ 0) of xi x (9,)."""
    return p.posture_gain * (p.posture_set - x[posture])


@register_inline
def differential_weights(x: np.ndarray, p: np.record, w_out: np.ndarray) -> None:
    """diag(W⁻¹) (9,) into w_out: the β split (eqs (27)-(30)) times, with the lane's
    joint-limit weights on, `joint_limit_weight_lane` (eqs (35)-(37), SPEC erratum 4) of xi x
    (9,); p the lane's `DIFFERENTIAL_PARAMETERS` record."""
    joint_limits = p.joint_limits > 0.0
    for i in range(9):
        if joint_limits:
            w_out[i] = p.split[i] * joint_limit_weight_lane(
                x[i], p.lower[i], p.upper[i], p.scale[i]
            )
        else:
            w_out[i] = p.split[i]


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
    p: np.record,
    const: np.ndarray,
    dt: float,
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
        target: (N_TARGET,) the held target in B (a `TARGET` row): ᴮR_d row-major, ᴮp_d [m],
            twist ᴮξ̇_d = [ᴮṗ_d; ᴮω_d] [m/s, rad/s].
        p: the lane's `DIFFERENTIAL_PARAMETERS` record (its row, `DifferentialPlanner.pack`).
        const: (N_HYBRID_CONSTANTS,) the hybrid constants (`HybridBoardingSystem.pack`).
        dt: [s] the control period the velocity is held for: k_e is applied sampled,
            (1 − e^(−k_e dt))/dt (`proportional_gain`); dt ≤ 0 applies k_e itself.
        work: `differential_work()`, overwritten: K, K W Kᵀ, diag(W⁻¹), the demand and the
            posture column in P, which `damped_differential_velocity` goes on from; the tip
            ᴮT_E (frames[1]) and its error (the vectors' `error`), which the runner hands to
            the record.
        v_out: (9,) written: the velocity [ᴾṖ [m/s]; ω_P [rad/s] in P; q̇1, q̇2 [rad/s];
            ḋ3 [m/s]]: `DifferentialPlanner.step(...).velocity`.
        diag_out: (N_HYBRID_DIAGNOSTICS,) a `HYBRID_DIAGNOSTICS` row: weights, null-space
            share, damping λ and rate scale written; the other families' fields left alone.

    Returns:
        Fault bits (0: λ = 0 on this path), or NEEDS_SVD where the damping test fails (near a
        singularity): v_out and diag_out are then not written, and the caller finishes the
        step with `damped_differential_velocity(x, p, work, v_out, diag_out)`.
    """
    K, A, L, frames, M, vectors = work
    named = vectors[0]  # the vectors by name
    w, b, column = named.weights, named.demand[:6], named.column[:6]
    back, y = named.back, named.solve[:6]
    # the tip task: K and the demand ẋ_d + k_e e in B (eqs (14), (24), (34)), k_e sampled
    c = const.view(HYBRID_CONSTANTS)[0]  # the constants by name
    tip_task_lane(x, R, target, proportional_gain(p.gain, dt), c.d1, c.a1, frames, M, K, b,
                  named.error[:6])  # fmt: skip
    # turned into P in place: b = Dᵀ (ẋ_d + k_e e)
    for half in (0, 3):
        d0, d1, d2 = b[half], b[half + 1], b[half + 2]
        for i in range(3):
            b[half + i] = R[0, i] * d0 + R[1, i] * d1 + R[2, i] * d2

    differential_weights(x, p, w)
    # A = K W Kᵀ (`back` free until the solve); the damping test of weighted_pinv as a
    # Cholesky factorisation (module doc)
    weighted_gram_lane(K, w, back, A)
    posture = int(p.posture_index)
    if posture >= 0:  # J J_aᵀ ζ̇_a in P: K's posture column times k_a (q̃ − q_i) (eqs (39)-(40))
        wanted = posture_rate(x, p, posture)
        for a in range(6):
            column[a] = K[a, posture] * wanted
    shift = p.epsilon ** 2 * (1.0 + 1e-6)
    if not cholesky_lane(A, 6, 0.0, L):
        return NEEDS_SVD
    # the shifted factor only where the bound does not decide; A's own lower triangle takes
    # it (each entry is read once, before its place is written), L stays A's factor
    if not (smallest_eigenvalue_bound(L) > 2.0 * shift or cholesky_lane(A, 6, shift, A)):
        return NEEDS_SVD
    # σ_min(J W^½) > ε: λ = 0, J_W⁺ = W Kᵀ (K W Kᵀ)⁻¹ Dᵀ (eq (31))
    cholesky_pinv_apply(K, w, L, b, y, v_out)  # J_W⁺ ẋ; the null-space term in the finish
    if posture >= 0:
        cholesky_pinv_apply(K, w, L, column, y, back)
    return differential_finish(x, p, work, 0.0, v_out, diag_out)


@register_jitable  # not borrowing: the SVD allocates
def damped_differential_velocity(
    x: np.ndarray,
    p: np.record,
    work: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    v_out: np.ndarray,
    diag_out: np.ndarray,
) -> int:
    """The rest of a `differential_velocity` that returned NEEDS_SVD (rare: near a singularity,
    or a rank-deficient J_W when β = 0): `weighted_pinv`'s SVD form of the solve, with
    λ² = (1 − (σ_min/ε)²) λ_max² and gains s / (s² + λ²), then `differential_finish`.

    Args:
        x: (9,) xi [m, rad]; p: the lane's parameter record, as given to
            `differential_velocity`.
        work: the `differential_work()` that `differential_velocity` filled.
        v_out, diag_out: as in `differential_velocity`, written.

    Returns:
        Fault bits: FAULT_SINGULAR when the damping λ > 0.
    """
    K, named = work[0], work[5][0]  # the vectors by name
    w, b, column = named.weights, named.demand[:6], named.column[:6]
    back = named.back
    sqrt_w = np.empty(9)
    KW = np.empty((6, 9))
    for j in range(9):
        sqrt_w[j] = math.sqrt(w[j])
    for a in range(6):
        for j in range(9):
            KW[a, j] = K[a, j] * sqrt_w[j]
    U, sv, Vt = np.linalg.svd(KW, full_matrices=False)
    gain = np.empty(6)
    lam2 = damped_gains_lane(sv, 9, p.epsilon, p.damping, gain)
    svd_pinv_apply(U, gain, Vt, sqrt_w, b, v_out)
    if int(p.posture_index) >= 0:
        svd_pinv_apply(U, gain, Vt, sqrt_w, column, back)
    return differential_finish(x, p, work, lam2, v_out, diag_out)


@register_inline
def differential_finish(
    x: np.ndarray,
    p: np.record,
    work: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    lam2: float,
    v_out: np.ndarray,
    diag_out: np.ndarray,
) -> int:
    """The end of a differential step once J_W⁺ is applied (either solve): the null-space term
    of eq (34), Algorithm 1, the rate scale and the diagnostics.

    Args:
        x: (9,) xi [m, rad]; p: the lane's `DIFFERENTIAL_PARAMETERS` record.
        work: `differential_work()` holding diag(W⁻¹) and J_W⁺ J J_aᵀ ζ̇_a (the vectors'
            `weights` and `back`; the latter read only with a posture task).
        lam2: λ² of the solve [-].
        v_out: (9,) J_W⁺ ẋ on entry; the velocity on return (`differential_velocity`).
        diag_out: (N_HYBRID_DIAGNOSTICS,) its weights … velocity_scale written.

    Returns:
        Fault bits: FAULT_SINGULAR when the damping λ > 0.
    """
    named = work[5][0]  # the vectors by name
    w, back = named.weights, named.back
    # v = J_W⁺ ẋ + λ (I − J_W⁺ J) J_aᵀ ζ̇_a (eq (34); J_a⁺ = J_aᵀ for a selector row)
    posture = int(p.posture_index)
    wanted = posture_rate(x, p, posture) if posture >= 0 else 0.0
    weight = p.secondary
    null2 = 0.0
    for j in range(9):
        null = 0.0
        if posture >= 0:
            null = weight * ((wanted if j == posture else 0.0) - back[j])
        null2 += null * null
        v_out[j] += null

    if p.slew > 0.0:  # Algorithm 1 (twin.planners.limits.SlewPriority)
        q1, q1_min, q1_max = x[6], p.q1_min, p.q1_max
        sigma, rate = p.sigma, p.slew_rate
        total = v_out[5] + v_out[6]  # w_1sum
        # the platform keeps ω_pz,hold = −yaw_hold·tan(φ)·ω_py (its Euler yaw held at 1)
        hold = held_yaw_rate_lane(p.yaw_hold, x[3], v_out[4])
        slew = slew_priority_lane(q1, total - hold, q1_min, q1_max, sigma, rate)
        v_out[5] = total - slew
        v_out[6] = slew

    scale = 1.0
    if p.rate_limited > 0.0:  # VelocityLimit: one scale, the direction kept
        scale = velocity_limit_lane(v_out, p.rate)
    d = diag_out.view(HYBRID_DIAGNOSTICS)[0]  # the row by name
    weights = d.weights
    norm2 = 0.0
    for j in range(9):
        norm2 += v_out[j] * v_out[j]
        weights[j] = w[j]
    norm = math.sqrt(norm2)
    d.null_space_share = math.sqrt(null2) / (1e-12 if norm < 1e-12 else norm)
    # λ ≤ λ_max by its definition; for a λ_max under 1e-154, λ_max² is subnormal and its
    # square root can come back above λ_max (`weighted_pinv_lane`)
    damping = min(math.sqrt(lam2), p.damping)
    d.damping = damping
    d.velocity_scale = scale
    return FAULT_SINGULAR if damping > 0.0 else 0


# ---------------------------------------------------------------------------------------------
# The step over a batch of lanes: what `DifferentialPlanner.step` runs
# ---------------------------------------------------------------------------------------------


def _differential_batch(
    x: np.ndarray,
    target: np.ndarray,
    row: np.ndarray,
    const: np.ndarray,
    dt: float,
    v_out: np.ndarray,
    diag_out: np.ndarray,
    error_out: np.ndarray,
) -> None:
    """The engine's step of one planner row over states x (N, 9) and target rows (N, 18):
    `differential_velocity`, finished by `damped_differential_velocity` where it returns
    NEEDS_SVD (as `twin.sim.kernels.hybrid_runner.run_hybrid` takes it), into v_out (N, 9),
    diag_out (N, N_HYBRID_DIAGNOSTICS) (`HYBRID_DIAGNOSTICS`' weights … velocity_scale
    written) and the tip's pose error e (N, 6) [m, rad] in B that the tip task planned on (the
    work vectors' `error`).
    row: the planner's (ROW_SIZE,) (`DifferentialPlanner.pack`); const: the hybrid constants;
    dt: [s] the control period (`differential_velocity`)."""
    R = np.empty((3, 3))
    work = differential_work()
    p = row.view(DIFFERENTIAL_PARAMETERS)[0]  # the row by name, as the runner reads it
    vectors = work[5]
    for k in range(x.shape[0]):
        rpy_to_matrix_lane(x[k, 3], x[k, 4], x[k, 5], R)
        bits = differential_velocity(x[k], R, target[k], p, const, dt, work, v_out[k],
                                     diag_out[k])  # fmt: skip
        if bits == NEEDS_SVD:
            damped_differential_velocity(x[k], p, work, v_out[k], diag_out[k])
        error = vectors[0].error
        for i in range(6):
            error_out[k, i] = error[i]


#: the step over a batch (compiled on first use, `twin.batch`): what `DifferentialPlanner.step`
#: calls
DIFFERENTIAL_STEP = LaneBatch(_differential_batch, cores=(1, 1))


def differential_step(
    planner: DifferentialPlanner, xi: np.ndarray, target: TipTarget, dt: float
) -> PlannerOutput:
    """`DifferentialPlanner.step`: the planner packed (`pack`; `hold` is the runner's guard's,
    not the velocity's) and stepped lane by lane by the engine's own step (`DIFFERENTIAL_STEP`).

    Args:
        planner: the planner; every part must `pack`.
        xi: (..., 9) [m, rad] the states; target: the desired tip motion in B, its leading
            axes broadcast against xi's.
        dt: [s] the control period the velocity is held for (k_e sampled over it,
            `differential_velocity`); dt ≤ 0: k_e itself.

    Returns:
        velocity (..., 9) and the diagnostics `weights` (..., 9) diag(W⁻¹), `task_error`
        (..., 6) [m, rad] e in B, `null_space_share` (...) [-], `damping` (...) λ [-],
        `velocity_scale` (...) [-] (numpy floats for one lane).

    Raises:
        TwinError: xi not (..., 9) or not finite; a part without `pack`, or one the kernel
            cannot run (`DifferentialPlanner.pack`).
    """
    xi = as_array(xi, "xi", (9,))
    row = pack_differential(planner, False)
    # the constants' rate limits are the runner's guard's: the planner's step reads only the
    # gangway's d1, a1 (its own rate limit is its row's, `VelocityLimit.pack`)
    const = planner.tip.mechanism.pack(np.full(9, np.inf))
    v, diag, error = DIFFERENTIAL_STEP(
        [xi, target_rows(target)], [row, const, float(dt)], [(9,), (N_HYBRID_DIAGNOSTICS,), (6,)]
    )
    d = as_records(diag, HYBRID_DIAGNOSTICS)  # by name
    return PlannerOutput(
        velocity=v,
        diagnostics={
            "weights": d["weights"],
            "task_error": error,
            "null_space_share": d["null_space_share"][()],
            "damping": d["damping"][()],
            "velocity_scale": d["velocity_scale"][()],
        },
    )

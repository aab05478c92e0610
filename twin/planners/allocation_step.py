r"""The position-level planners of seed 004 (conv1, conv2, dwa) on one lane, as the engine runs
them.

`allocation_velocity` is the step of `twin.planners.allocation.AllocationPlanner` on one lane
(floats and small arrays, in a style numba compiles and plain Python runs unchanged): the
runner `twin.sim.kernels.hybrid_runner.run_hybrid` calls it, guards and integrates its
velocity, and `AllocationPlanner.step` runs it over its batch (`allocation_step`, through
`ALLOCATION_STEP`): the math is written here once. Tests hold it to seed 004's split typed in
numpy (tests/planners/test_allocation.py).

Each step splits the compensating motion C = ᴮT_E,d(t + dt) · ᴮT_E(0)⁻¹ (seed 000 §5.1)
between the Stewart platform and the gangway and solves the gangway's analytic inverse
(seed 004 eqs (7)-(8)) for the tip position; DWA's position shares [λ_p w_i]³ (seed 004 §3.2)
come from the Stewart manipulability (seed 004 §3.1 b) and the closed-form reachable range
(seed 004 §3.1 c) of the previous step's pose, carried in the lane's `memory`.

A lane's parameters are `twin.planners.families.ALLOCATION_PARAMETERS`, read by name
(written by `AllocationPlanner.pack` after its reset); the hybrid system's constants are
`twin.mechanisms.hybrid.HYBRID_CONSTANTS`, read by name.

`memory` is read by name (`ALLOCATION_MEMORY`): DWA's position shares for the next step
(seed 004's t − 1).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from twin.batch import LaneBatch
from twin.compiled import register_borrowing, register_inline, register_jitable
from twin.mechanisms.gangway import gangway_inverse_lane
from twin.mechanisms.hybrid import HYBRID_CONSTANTS, HybridBoardingSystem
from twin.mechanisms.legs import leg_vectors_lane, manipulability_lane
from twin.planners.families import ALLOCATION_METHODS, ALLOCATION_PARAMETERS
from twin.planners.lane_rows import (
    FAULT_PLANNER,
    HYBRID_DIAGNOSTICS,
    N_HYBRID_DIAGNOSTICS,
    N_TARGET,
    TARGET,
)
from twin.planners.parameters import MEMORY_SIZE, record_dtype, refuse
from twin.planners.target import TipTarget
from twin.planners.tasks import advance_target_lane, target_rows, tip_error_lane
from twin.spatial import (
    matrix_to_rpy_lane,
    rpy_to_matrix_lane,
    se3_log_lane,
)
from twin.validation import as_array

if TYPE_CHECKING:  # the object imports this module: its step sits below it
    from twin.planners.allocation import AllocationPlanner

#: Methods (a row's `method`), as `twin.planners.families.ALLOCATION_METHODS` numbers them.
METHOD_CONV1, METHOD_CONV2, METHOD_DWA = (ALLOCATION_METHODS["conv1"], ALLOCATION_METHODS["conv2"],
                                          ALLOCATION_METHODS["dwa"])  # fmt: skip
#: An allocation lane's memory (MEMORY_SIZE floats, read by name): DWA's position shares (3).
ALLOCATION_MEMORY = record_dtype((("share", 3),), MEMORY_SIZE, "ALLOCATION_MEMORY")


@register_borrowing
def shares_lane(
    R: np.ndarray,
    p: np.ndarray,
    prm: np.record,
    c: np.record,
    vectors: np.ndarray,
    lengths: np.ndarray,
    J: np.ndarray,
    out: np.ndarray,
) -> None:
    """DWA's position shares [λ_p w_i]³ (3,) into out, clipped to [0, 1] (seed 004 §3.2,
    docs/planners.md), for the platform pose [ᴮR_P (3, 3), ᴮp_P (3,) [m]]: λ_p the
    manipulability over the working state's, w_i the reachable range over the working
    state's (`AllocationPlanner.shares`); prm the lane's `ALLOCATION_PARAMETERS` and c its
    `HYBRID_CONSTANTS` record. vectors (6, 3), lengths (6,) and J (6, 6) are scratch (the legs
    and `manipulability_lane`'s)."""
    platform = c.platform_hinges
    leg_vectors_lane(R, p, c.base_hinges, platform, vectors, lengths)
    lam = manipulability_lane(R, vectors, lengths, platform, J) / prm.manip_mid
    # the ranges, made shares in place
    reachable_range_lane(vectors, lengths, c.leg_min, c.leg_max, out)
    for k in range(3):
        out[k] = min(max(lam * (out[k] / prm.range_mid[k]), 0.0), 1.0) ** 3


# ---------------------------------------------------------------------------------------------
# The planner step
# ---------------------------------------------------------------------------------------------


@register_borrowing
def compose_lane(
    R: np.ndarray, p: np.ndarray, rows: np.ndarray, R_out: np.ndarray, p_out: np.ndarray
) -> None:
    """[R_out p_out] = [R p] · T for a rigid transform T given by its top three rows (12,),
    row-major (as `pack_allocation` stores ᴮT_P(0) and ᴮT_E(0)⁻¹)."""
    for i in range(3):
        for j in range(4):
            s = 0.0
            for k in range(3):
                s += R[i, k] * rows[4 * k + j]
            if j < 3:
                R_out[i, j] = s
            else:
                p_out[i] = s + p[i]


@register_inline
def platform_pose_lane(
    method: int, prm: np.record, memory: np.ndarray, Ra: np.ndarray, pa: np.ndarray,
    Rc: np.ndarray, pc: np.ndarray, rpy: np.ndarray, R_out: np.ndarray, p_out: np.ndarray,
) -> None:  # fmt: skip
    """The platform pose a method plans, [R_out (3, 3), p_out (3,) [m]] in B, for the predicted
    target [Ra, pa]: T_full = C ᴮT_P(0) with the compensating motion C = T_a ᴮT_E(0)⁻¹
    (seed 000 §5.1) for conv1; its rotation at the reset position for conv2; its roll and pitch,
    the reset yaw and the share of each position axis for dwa (seed 004 §3.2; the memory's
    `share`, `ALLOCATION_MEMORY`). Rc, pc, rpy: scratch."""
    compose_lane(Ra, pa, prm.T_E0_inv, Rc, pc)
    compose_lane(Rc, pc, prm.T_P0, R_out, p_out)
    if method == METHOD_CONV2:
        for i in range(3):
            p_out[i] = prm.T_P0[4 * i + 3]
    elif method == METHOD_DWA:
        matrix_to_rpy_lane(R_out, rpy)
        rpy_to_matrix_lane(rpy[0], rpy[1], prm.yaw0, R_out)  # the slew takes the yaw
        share = memory.view(ALLOCATION_MEMORY)[0].share
        for i in range(3):
            p0 = prm.T_P0[4 * i + 3]
            p_out[i] = p0 + share[i] * (p_out[i] - p0)


@register_inline
def reaching_velocity_lane(
    x: np.ndarray, R: np.ndarray, RP: np.ndarray, pP: np.ndarray, q: np.ndarray, dt: float,
    Rrel: np.ndarray, prel: np.ndarray, v_out: np.ndarray,
) -> int:  # fmt: skip
    """The velocity v_out (9,) that reaches the platform pose [RP, pP] and the gangway joints
    q (3,) from xi x (9,) (R its ᴮR_P) in one dt: the body twist of ᴮT_P(xi)⁻¹ T_P over dt
    (`se3_log_lane`), then (q − x[6:]) / dt; Rrel, prel scratch. Fault bits returned:
    `FAULT_PLANNER` when v is not finite."""
    for i in range(3):
        for j in range(3):
            Rrel[i, j] = R[0, i] * RP[0, j] + R[1, i] * RP[1, j] + R[2, i] * RP[2, j]
        prel[i] = R[0, i] * (pP[0] - x[0]) + R[1, i] * (pP[1] - x[1]) + R[2, i] * (pP[2] - x[2])
    se3_log_lane(Rrel, prel, v_out)
    finite = True
    for i in range(9):
        if i < 6:
            v_out[i] = v_out[i] / dt
        else:
            v_out[i] = (q[i - 6] - x[i]) / dt
        finite = finite and math.isfinite(v_out[i])
    return 0 if finite else FAULT_PLANNER


@register_jitable
def allocation_work() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Scratch of `allocation_velocity`, allocated once per lane (numba puts every array on
    the heap: a malloc per step would cost more than the arithmetic): rotations (5, 3, 3)
    (exp(ω dt), the predicted target's, the compensating motion's, the platform's, the
    relative one), points (7, 3) (the predicted target, the compensating motion, the platform
    position, its rpy, the gangway joints, the next shares, the relative position), then the
    legs (6, 3), their lengths (6,) and the leg Jacobian (6, 6) of `shares_lane`."""
    return (np.empty((5, 3, 3)), np.empty((7, 3)), np.empty((6, 3)), np.empty(6),
            np.empty((6, 6)))  # fmt: skip


@register_borrowing
def allocation_velocity(
    x: np.ndarray,
    R: np.ndarray,
    target: np.ndarray,
    prm: np.record,
    memory: np.ndarray,
    const: np.ndarray,
    dt: float,
    work: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    v_out: np.ndarray,
    diag_out: np.ndarray,
) -> int:
    """`AllocationPlanner.step` on one lane: the velocity that reaches, in one dt, the state
    holding the tip at the target predicted one dt ahead (seed 004 §3).

    The prediction is T_d(t + dt) ≈ [exp(ω dt) R_d, p_d + v dt] (seed 004 §1); the platform
    pose that alone would hold the tip is T_full = T_d(t + dt) ᴮT_E(0)⁻¹ ᴮT_P(0) (seed 000
    §5.1). conv1 moves the platform to T_full and keeps the gangway; conv2 gives the platform
    T_full's rotation and the gangway the position; dwa gives the platform T_full's roll and
    pitch, the reset yaw (the slew takes the yaw) and the share [λ_p w_i]³ of each position
    axis. The gangway then solves seed 004 eqs (7)-(8) for the tip position in P.

    Args:
        x: (9,) xi [m, rad]: platform pose in B, then q1, q2 [rad], d3 [m].
        R: (3, 3) ᴮR_P of x (`rpy_to_matrix_lane`).
        target: (N_TARGET,) a `TARGET` row: ᴮR_d row-major, ᴮp_d [m], twist [ᴮṗ_d; ᴮω_d]
            [m/s, rad/s] in B.
        prm: the lane's `ALLOCATION_PARAMETERS` record (its row, `AllocationPlanner.pack`).
        memory: (MEMORY_SIZE,) the lane's state (`ALLOCATION_MEMORY`): DWA's shares, read and
            updated.
        const: (N_HYBRID_CONSTANTS,) the hybrid constants (`HybridBoardingSystem.pack`).
        dt: [s] control period.
        work: `allocation_work()`, overwritten.
        v_out: (9,) written: platform body twist [ᴾṖ; ω_P] in P [m/s, rad/s], then q̇1, q̇2
            [rad/s], ḋ3 [m/s] (`HybridBoardingSystem.integrate`).
        diag_out: (N_HYBRID_DIAGNOSTICS,) a `HYBRID_DIAGNOSTICS` row: its `position_share`
            (3) written, the shares used (dwa), 1 (conv1) or 0 (conv2); the other families'
            fields left alone; `limit_scale` is the runner's.

    Returns:
        Fault bits: `FAULT_PLANNER` when the velocity is not finite, else 0.
    """
    method = int(prm.method)
    c = const.view(HYBRID_CONSTANTS)[0]  # the constants by name
    rotations, points, vectors, lengths, J = work
    E, Ra, Rc, RP, Rrel = rotations[0], rotations[1], rotations[2], rotations[3], rotations[4]
    pa, pc, pP, rpy = points[0], points[1], points[2], points[3]
    q, following, prel = points[4], points[5], points[6]
    # the target one dt ahead, T_a = [exp(ω dt) R_d, p_d + v dt] (seed 004 §1)
    t = target.view(TARGET)[0]  # the rows by name
    advance_target_lane(t.R_d, t.p_d, t.twist, dt, E, Ra, pa)
    platform_pose_lane(method, prm, memory, Ra, pa, Rc, pc, rpy, RP, pP)
    # gangway joints: conv1 keeps them, else seed 004 eqs (7)-(8) for the tip in P
    if method == METHOD_CONV1:
        for i in range(3):
            q[i] = prm.q0[i]
    else:
        d0, d1, d2 = pa[0] - pP[0], pa[1] - pP[1], pa[2] - pP[2]
        gangway_inverse_lane(RP[0, 0] * d0 + RP[1, 0] * d1 + RP[2, 0] * d2,
                             RP[0, 1] * d0 + RP[1, 1] * d1 + RP[2, 1] * d2,
                             RP[0, 2] * d0 + RP[1, 2] * d1 + RP[2, 2] * d2,
                             c.d1, c.a1, q)  # fmt: skip
    used = diag_out.view(HYBRID_DIAGNOSTICS)[0].position_share
    if method == METHOD_DWA:
        share = memory.view(ALLOCATION_MEMORY)[0].share
        for i in range(3):
            used[i] = share[i]  # the shares used
        # next step's shares (t − 1 in seed 004); a step that cannot be planned (a target that
        # is not finite: AllocationPlanner raises there) keeps the last good ones
        shares_lane(RP, pP, prm, c, vectors, lengths, J, following)
        if math.isfinite(following[0] + following[1] + following[2]):
            for i in range(3):
                share[i] = following[i]
    else:
        one = 1.0 if method == METHOD_CONV1 else 0.0
        for i in range(3):
            used[i] = one
    return reaching_velocity_lane(x, R, RP, pP, q, dt, Rrel, prel, v_out)


def pack_allocation(planner: AllocationPlanner, hold: bool) -> tuple[np.ndarray, np.ndarray]:
    """(prm (ROW_SIZE,), memory (MEMORY_SIZE,)) of one lane from an `AllocationPlanner` after
    its `reset(xi, target)`: its `pack(hold)` (`ALLOCATION_PARAMETERS` by name), and memory
    with DWA's shares (`ALLOCATION_MEMORY`).

    Raises:
        TwinError: the planner has no `pack`, is not reset, or has an unknown method.
    """
    pack = getattr(planner, "pack", None)
    if pack is None:
        raise refuse(f"a {type(planner).__name__} as an allocation planner")
    prm, shares = pack(hold)
    memory = np.zeros(MEMORY_SIZE)
    memory.view(ALLOCATION_MEMORY)[0].share = shares
    return prm, memory


# ---------------------------------------------------------------------------------------------
# The step over a batch of lanes: what `AllocationPlanner.step` runs
# ---------------------------------------------------------------------------------------------


def _allocation_batch(
    x: np.ndarray,
    target: np.ndarray,
    rows: np.ndarray,
    shares: np.ndarray,
    const: np.ndarray,
    dt: float,
    v_out: np.ndarray,
    share_out: np.ndarray,
    following: np.ndarray,
    error_out: np.ndarray,
) -> None:
    """The engine's step (`allocation_velocity`) over states x (N, 9), target rows (N, 18),
    parameter rows (N, ROW_SIZE) and DWA's shares (N, 3) carried in: the velocity v_out
    (N, 9), the shares used (N, 3; the diagnostics' `position_share`), the shares carried to
    the next step (N, 3; the lane's memory after the step) and the pose error e (N, 6)
    [m, rad] in B of the tip of the state the step plans (its platform pose and gangway
    joints, from the work) against the predicted target it planned for (`tip_error_lane`)."""
    R, memory, diag = np.empty((3, 3)), np.zeros(MEMORY_SIZE), np.empty(N_HYBRID_DIAGNOSTICS)
    share, used = memory.view(ALLOCATION_MEMORY)[0].share, diag.view(HYBRID_DIAGNOSTICS)[0]
    goal = np.zeros(N_TARGET)  # the predicted target, the state planned
    ahead = goal.view(TARGET)[0]
    work = allocation_work()
    rotations, points = work[0], work[1]
    planned = np.zeros(9)
    frames, M = np.empty((2, 4, 4)), np.empty((3, 3))
    c = const.view(HYBRID_CONSTANTS)[0]
    for k in range(x.shape[0]):
        rpy_to_matrix_lane(x[k, 3], x[k, 4], x[k, 5], R)
        for i in range(3):
            share[i] = shares[k, i]
        prm = rows[k].view(ALLOCATION_PARAMETERS)[0]  # the row by name, as the runner reads it
        allocation_velocity(x[k], R, target[k], prm, memory, const, dt, work, v_out[k], diag)
        for i in range(3):
            share_out[k, i] = used.position_share[i]
            following[k, i] = share[i]
            # the work's predicted target [Ra, pa] and planned platform [RP, pP], joints q
            for j in range(3):
                ahead.R_d[3 * i + j] = rotations[1, i, j]
            ahead.p_d[i] = points[0, i]
            planned[i], planned[6 + i] = points[2, i], points[4, i]
        tip_error_lane(planned, rotations[3], goal, c.d1, c.a1, frames, M, error_out[k])


#: the step over a batch (compiled on first use, `twin.batch`): what `AllocationPlanner.step`
#: calls
ALLOCATION_STEP = LaneBatch(_allocation_batch, cores=(1, 1, 1, 1))


def allocation_step(
    mechanism: HybridBoardingSystem,
    rows: np.ndarray,
    shares: np.ndarray,
    xi: np.ndarray,
    target: TipTarget,
    dt: float,
) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """`AllocationPlanner.step`: its rows and shares stepped lane by lane by the engine's own
    step (`ALLOCATION_STEP`).

    Args:
        mechanism: the hybrid system.
        rows: (..., ROW_SIZE) the planner's parameter rows (`AllocationPlanner.rows`).
        shares: (..., 3) DWA's position shares for this step (`ALLOCATION_MEMORY`).
        xi: (..., 9) [m, rad] the states; target: the desired tip motion in B; the leading
            axes of these four broadcast.
        dt: [s] the control period.

    Returns:
        (velocity (..., 9), diagnostics {`task_error` (..., 6) [m, rad], `position_share`
        (..., 3) [-]}, the shares for the next step (..., 3): DWA's, the given ones for conv1
        and conv2).

    Raises:
        TwinError: xi not (..., 9) or not finite, or a target that is not finite.
    """
    xi = as_array(xi, "xi", (9,))
    targets = as_array(target_rows(target), "target", (N_TARGET,))
    # the constants' rate limits are the runner's guard's: the planner's step reads only the
    # geometry (gangway d1, a1; hinges and leg stroke for DWA's shares)
    const = mechanism.pack(np.full(9, np.inf))
    velocity, share, following, error = ALLOCATION_STEP(
        [xi, targets, rows, shares], [const, float(dt)], [(9,), (3,), (3,), (6,)]
    )
    return velocity, {"task_error": error, "position_share": share}, following


# ---------------------------------------------------------------------------------------------
# One lane (floats and small arrays, compiled by numba into the engine's kernel,
# `twin.compiled`; plain Python without numba)
# ---------------------------------------------------------------------------------------------


@register_borrowing
def reachable_range_lane(
    vectors: np.ndarray, lengths: np.ndarray, leg_min: float, leg_max: float, out: np.ndarray
) -> None:
    r"""Δx_p, Δy_p, Δz_p [m] into out (3,): per position axis, the length of the interval of
    offsets s (other five pose coordinates held) whose six legs stay inside their stroke —
    seed 004 §3.1 c's "space search" in closed form (`reachable_range`, one lane).

    Leg i at offset s along axis k has |l_i + s e_k|² = s² + 2 b s + c, b = l_i,k, c = |l_i|²:
    l_max bounds s to −b ± sqrt(b² − c + l_max²); l_min cuts out −b ± sqrt(b² − c + l_min²),
    on one side of s = 0 for a feasible pose. Zero when the pose itself is outside.

    Args:
        vectors: (6, 3) [m] leg vectors in B; lengths: (6,) [m]
            (`twin.mechanisms.legs.leg_vectors_lane`).
        leg_min, leg_max: [m] the leg stroke (Table 1).
    """
    inside = True
    for i in range(6):
        inside = inside and lengths[i] >= leg_min and lengths[i] <= leg_max
    for k in range(3):
        upper_min, lower_max = math.inf, -math.inf
        for i in range(6):
            b = vectors[i, k]
            c = lengths[i] ** 2
            reach = math.sqrt(max(b**2 - c + leg_max**2, 0.0))
            upper, lower = -b + reach, -b - reach
            hole = b**2 - c + leg_min**2
            if hole > 0:
                half = math.sqrt(hole)
                if -b > 0:
                    upper = min(upper, -b - half)
                else:
                    lower = max(lower, -b + half)
            upper_min = min(upper_min, upper)
            lower_max = max(lower_max, lower)
        out[k] = max(upper_min - lower_max, 0.0) if inside else 0.0


def _reachable_range_batch(
    vectors: np.ndarray, lengths: np.ndarray, leg_min: float, leg_max: float, out: np.ndarray
) -> None:
    """`reachable_range_lane` over legs vectors (N, 6, 3), lengths (N, 6) into out (N, 3)."""
    for k in range(vectors.shape[0]):
        reachable_range_lane(vectors[k], lengths[k], leg_min, leg_max, out[k])


#: the lane over a batch of poses: what `reachable_range` calls
REACHABLE_RANGE = LaneBatch(_reachable_range_batch, cores=(2, 1))

r"""The position-level planners of seed 004 (conv1, conv2, dwa) as a one-lane compiled kernel.

`allocation_velocity` is `twin.planners.allocation.AllocationPlanner.step` written on one lane
(floats and small arrays, `register_jitable`): the runner
`twin.sim.kernels.hybrid_runner.run_hybrid` calls it under numba, and without numba it runs as
plain Python on the same numbers. The planner object stays the readable statement and the
tests' oracle (to 1e-9, step after step).

Each step splits the compensating motion C = ᴮT_E,d(t + dt) · ᴮT_E(0)⁻¹ (seed 000 §5.1)
between the Stewart platform and the gangway and solves the gangway's analytic inverse
(seed 004 eqs (7)-(8)) for the tip position; DWA's position shares [λ_p w_i]³ (seed 004 §3.2)
come from the Stewart manipulability (seed 004 §3.1 b) and the closed-form reachable range
(seed 004 §3.1 c) of the previous step's pose, carried in the lane's `memory`.

`prm` rows from `P_FAMILY` on (constant for the lane; packed by `pack_allocation`):

- `P_METHOD`: `METHOD_CONV1`, `METHOD_CONV2` or `METHOD_DWA`;
- `P_MANIP_MID`, `P_RANGE_MID` (3): Stewart manipulability [-] and reachable range Δx, Δy,
  Δz [m] at the working state, DWA's normalisers;
- `P_T_P0` (12): ᴮT_P(0) rows 0-2 row-major (ᴮR_P | ᴮp_P [m]), the platform at reset;
- `P_T_E0_INV` (12): ᴮT_E(0)⁻¹ rows 0-2 row-major, the inverse tip pose at reset;
- `P_YAW0`: [rad] the platform yaw at reset (the slew joint takes the yaw, dwa);
- `P_Q0` (3): [rad, rad, m] the gangway joints at reset (conv1 keeps them).

`memory` rows: `M_SHARE` (3), DWA's position shares for the next step (seed 004's t − 1).

It imports the shared one-lane primitives from `twin.sim.kernels.hybrid`; the runner that
calls it is `twin.sim.kernels.hybrid_runner.run_hybrid`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from twin.compiled import register_borrowing, register_inline, register_jitable
from twin.sim.kernels.layout import (
    C_A1,
    C_BASE_HINGES,
    C_D1,
    C_LEG_MAX,
    C_LEG_MIN,
    C_PLATFORM_HINGES,
    D_POSITION_SHARE,
    FAULT_PLANNER,
    KIND_ALLOCATION,
    N_MEMORY,
    N_PARAMETERS,
    P_FAMILY,
    P_HOLD,
    P_KIND,
    TARGET_P,
    TARGET_R,
    TARGET_V,
    TARGET_W,
)
from twin.spatial import (
    matrix_to_rpy,
    matrix_to_rpy_lane,
    rpy_to_matrix_lane,
    se3_log_lane,
    so3_exp_lane,
)

if TYPE_CHECKING:
    from twin.planners.allocation import AllocationPlanner



#: Methods (prm[P_METHOD]).
METHOD_CONV1, METHOD_CONV2, METHOD_DWA = 0, 1, 2
METHODS = {"conv1": METHOD_CONV1, "conv2": METHOD_CONV2, "dwa": METHOD_DWA}
#: prm rows of the allocation family (see the module docstring).
P_METHOD = P_FAMILY
P_MANIP_MID = P_FAMILY + 1
P_RANGE_MID = P_FAMILY + 2
P_T_P0 = P_FAMILY + 5
P_T_E0_INV = P_FAMILY + 17
P_YAW0 = P_FAMILY + 29
P_Q0 = P_FAMILY + 30
N_ALLOCATION_PARAMETERS = P_FAMILY + 33
#: memory rows: DWA's position shares (3).
M_SHARE = 0
N_ALLOCATION_MEMORY = 3
assert N_ALLOCATION_PARAMETERS <= N_PARAMETERS and N_ALLOCATION_MEMORY <= N_MEMORY


# ---------------------------------------------------------------------------------------------
# Primitives of the allocation planners
# ---------------------------------------------------------------------------------------------




@register_borrowing
def gangway_inverse_lane(
    px: float, py: float, pz: float, const: np.ndarray, q_out: np.ndarray
) -> None:
    """Gangway joints [q1, q2, d3] [rad, rad, m] into q_out (3,) that put the tip at ᴾp
    [m] in the platform frame: seed 004 eqs (7)-(8) as `twin.mechanisms.gangway.Gangway.inverse`
    writes them (d3 = hypot(p_x/cos θ1 − a1, d1 − p_z), never singular), unchecked."""
    rho = math.hypot(px, py) - const[C_A1]
    height = const[C_D1] - pz
    q_out[0] = math.atan2(py, px)
    q_out[1] = math.atan2(rho, height) - math.pi / 2
    q_out[2] = math.hypot(rho, height)


@register_inline
def leg_vectors_lane(
    R: np.ndarray,
    p: np.ndarray,
    const: np.ndarray,
    vectors_out: np.ndarray,
    lengths_out: np.ndarray,
) -> None:
    """Stewart legs of the platform pose [ᴮR_P (3, 3), ᴮp_P (3,) [m]] (seed 000 eqs (4)-(5),
    `twin.mechanisms.legs.legs`): l_i = ᴮR_P ᴾP_i + ᴮp_P − ᴮB_i into vectors_out (6, 3) [m],
    in B, and |l_i| into lengths_out (6,) [m]."""
    for i in range(6):
        h0 = const[C_PLATFORM_HINGES + 3 * i]
        h1 = const[C_PLATFORM_HINGES + 3 * i + 1]
        h2 = const[C_PLATFORM_HINGES + 3 * i + 2]
        s = 0.0
        for k in range(3):
            arm = R[k, 0] * h0 + R[k, 1] * h1 + R[k, 2] * h2
            v = arm + p[k] - const[C_BASE_HINGES + 3 * i + k]
            vectors_out[i, k] = v
            s += v * v
        lengths_out[i] = math.sqrt(s)


@register_inline
def manipulability_lane(
    R: np.ndarray, vectors: np.ndarray, lengths: np.ndarray, const: np.ndarray, J: np.ndarray
) -> float:
    """Yoshikawa's sqrt(det(J Jᵀ)) = |det J| [-] of the Stewart leg Jacobian J (6, 6), rows
    [n_iᵀ, (ᴮR_P ᴾP_i × n_i)ᵀ] (`twin.mechanisms.legs.twist_jacobian`; seed 004 §3.1 b,
    SPEC erratum 7), by Gaussian elimination with partial pivoting.

    Args:
        R: (3, 3) ᴮR_P; vectors, lengths: the legs (`leg_vectors_lane`) [m].
        J: (6, 6) scratch (the caller's, allocated once: numba puts arrays on the heap).
    """
    for i in range(6):
        h0 = const[C_PLATFORM_HINGES + 3 * i]
        h1 = const[C_PLATFORM_HINGES + 3 * i + 1]
        h2 = const[C_PLATFORM_HINGES + 3 * i + 2]
        a0 = R[0, 0] * h0 + R[0, 1] * h1 + R[0, 2] * h2
        a1 = R[1, 0] * h0 + R[1, 1] * h1 + R[1, 2] * h2
        a2 = R[2, 0] * h0 + R[2, 1] * h1 + R[2, 2] * h2
        inverse = 1.0 / lengths[i]  # one division, three multiplications
        n0, n1, n2 = vectors[i, 0] * inverse, vectors[i, 1] * inverse, vectors[i, 2] * inverse
        J[i, 0], J[i, 1], J[i, 2] = n0, n1, n2
        J[i, 3], J[i, 4], J[i, 5] = a1 * n2 - a2 * n1, a2 * n0 - a0 * n2, a0 * n1 - a1 * n0
    det = 1.0
    for j in range(6):
        pivot = j
        for i in range(j + 1, 6):
            if abs(J[i, j]) > abs(J[pivot, j]):
                pivot = i
        if pivot != j:
            det = -det
            for k in range(j, 6):
                J[j, k], J[pivot, k] = J[pivot, k], J[j, k]
        d = J[j, j]
        det *= d
        if d == 0.0:
            return 0.0
        inverse = 1.0 / d
        for i in range(j + 1, 6):
            f = J[i, j] * inverse
            for k in range(j + 1, 6):
                J[i, k] -= f * J[j, k]
    return abs(det)


@register_borrowing
def reachable_range_lane(
    vectors: np.ndarray, lengths: np.ndarray, const: np.ndarray, out: np.ndarray
) -> None:
    r"""Δx_p, Δy_p, Δz_p [m] into out (3,): per position axis, the length of the interval of
    offsets s (other five pose coordinates held) whose six legs stay inside their stroke —
    seed 004 §3.1 c's "space search" in closed form (`twin.planners.allocation.reachable_range`).

    Leg i at offset s along axis k has |l_i + s e_k|² = s² + 2 b s + c, b = l_i,k, c = |l_i|²:
    l_max bounds s to −b ± sqrt(b² − c + l_max²); l_min cuts out −b ± sqrt(b² − c + l_min²),
    on one side of s = 0 for a feasible pose. Zero when the pose itself is outside.

    Args:
        vectors: (6, 3) [m] leg vectors in B; lengths: (6,) [m] (`leg_vectors_lane`).
    """
    leg_min, leg_max = const[C_LEG_MIN], const[C_LEG_MAX]
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


@register_borrowing
def shares_lane(
    R: np.ndarray,
    p: np.ndarray,
    prm: np.ndarray,
    const: np.ndarray,
    vectors: np.ndarray,
    lengths: np.ndarray,
    J: np.ndarray,
    out: np.ndarray,
) -> None:
    """DWA's position shares [λ_p w_i]³ (3,) into out, clipped to [0, 1] (seed 004 §3.2,
    docs/planners.md), for the platform pose [ᴮR_P (3, 3), ᴮp_P (3,) [m]]: λ_p the
    manipulability over the working state's, w_i the reachable range over the working
    state's (`AllocationPlanner.shares`). vectors (6, 3), lengths (6,) and J (6, 6) are
    scratch (the legs and `manipulability_lane`'s)."""
    leg_vectors_lane(R, p, const, vectors, lengths)
    lam = manipulability_lane(R, vectors, lengths, const, J) / prm[P_MANIP_MID]
    reachable_range_lane(vectors, lengths, const, out)  # the ranges, made shares in place
    for k in range(3):
        out[k] = min(max(lam * (out[k] / prm[P_RANGE_MID + k]), 0.0), 1.0) ** 3


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
    prm: np.ndarray,
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
        target: (18,) `layout.TARGET_*`: ᴮR_d row-major, ᴮp_d [m], twist [ᴮṗ_d; ᴮω_d]
            [m/s, rad/s] in B.
        prm: (N_PARAMETERS,) the lane's row (`pack_allocation`).
        memory: (N_MEMORY,) the lane's state: DWA's shares at `M_SHARE`, read and updated.
        const: (N_HYBRID_CONSTANTS,) `layout.C_*` hybrid constants.
        dt: [s] control period.
        work: `allocation_work()`, overwritten.
        v_out: (9,) written: platform body twist [ᴾṖ; ω_P] in P [m/s, rad/s], then q̇1, q̇2
            [rad/s], ḋ3 [m/s] (`HybridBoardingSystem.integrate`).
        diag_out: (N_HYBRID_DIAGNOSTICS,) written: at `D_POSITION_SHARE` (3) the position
            shares used (dwa), 1 (conv1) or 0 (conv2); the differential planners' rows
            (`D_WEIGHTS` … `D_SCALE`) NaN; `D_LIMIT_SCALE` is the runner's.

    Returns:
        Fault bits: `FAULT_PLANNER` when the velocity is not finite, else 0.
    """
    method = int(prm[P_METHOD])
    rotations, points, vectors, lengths, J = work
    E, Ra, Rc, RP, Rrel = rotations[0], rotations[1], rotations[2], rotations[3], rotations[4]
    pa, pc, pP, rpy = points[0], points[1], points[2], points[3]
    q, following, prel = points[4], points[5], points[6]
    # the target one dt ahead, T_a = [exp(ω dt) R_d, p_d + v dt] (R_d row-major in target)
    w = TARGET_W
    so3_exp_lane(target[w] * dt, target[w + 1] * dt, target[w + 2] * dt, E)
    for i in range(3):
        for j in range(3):
            Ra[i, j] = (
                E[i, 0] * target[TARGET_R + j]
                + E[i, 1] * target[TARGET_R + 3 + j]
                + E[i, 2] * target[TARGET_R + 6 + j]
            )
        pa[i] = target[TARGET_P + i] + target[TARGET_V + i] * dt
    # compensating motion C = T_a ᴮT_E(0)⁻¹, then T_full = C ᴮT_P(0)
    compose_lane(Ra, pa, prm[P_T_E0_INV : P_T_E0_INV + 12], Rc, pc)
    compose_lane(Rc, pc, prm[P_T_P0 : P_T_P0 + 12], RP, pP)
    if method == METHOD_CONV2:
        for i in range(3):
            pP[i] = prm[P_T_P0 + 4 * i + 3]
    elif method == METHOD_DWA:
        matrix_to_rpy_lane(RP, rpy)
        rpy_to_matrix_lane(rpy[0], rpy[1], prm[P_YAW0], RP)  # the slew takes the yaw
        for i in range(3):
            p0 = prm[P_T_P0 + 4 * i + 3]
            pP[i] = p0 + memory[M_SHARE + i] * (pP[i] - p0)
    # gangway joints: conv1 keeps them, else seed 004 eqs (7)-(8) for the tip in P
    if method == METHOD_CONV1:
        for i in range(3):
            q[i] = prm[P_Q0 + i]
    else:
        d0, d1, d2 = pa[0] - pP[0], pa[1] - pP[1], pa[2] - pP[2]
        gangway_inverse_lane(
            RP[0, 0] * d0 + RP[1, 0] * d1 + RP[2, 0] * d2,
            RP[0, 1] * d0 + RP[1, 1] * d1 + RP[2, 1] * d2,
            RP[0, 2] * d0 + RP[1, 2] * d1 + RP[2, 2] * d2,
            const,
            q,
        )
    if method == METHOD_DWA:
        for i in range(3):
            diag_out[D_POSITION_SHARE + i] = memory[M_SHARE + i]  # the shares used
        # next step's shares (t − 1 in seed 004); a step that cannot be planned (a target that
        # is not finite: AllocationPlanner raises there) keeps the last good ones
        shares_lane(RP, pP, prm, const, vectors, lengths, J, following)
        if math.isfinite(following[0] + following[1] + following[2]):
            for i in range(3):
                memory[M_SHARE + i] = following[i]
    else:
        one = 1.0 if method == METHOD_CONV1 else 0.0
        for i in range(3):
            diag_out[D_POSITION_SHARE + i] = one
    # twist of ᴮT_P(xi)⁻¹ T_P over dt: the body twist that reaches T_P in one step
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


def pack_allocation(planner: AllocationPlanner, hold: bool) -> tuple[np.ndarray, np.ndarray]:
    """(prm (N_PARAMETERS,), memory (N_MEMORY,)) of one lane from an `AllocationPlanner` after
    its `reset(xi, target)`: the method, DWA's working-state normalisers, the reset poses
    ᴮT_P(0) and ᴮT_E(0)⁻¹, the reset yaw [rad] and gangway joints; memory the shares.

    Args:
        planner: reset, for one lane (unbatched state).
        hold: the lane holds its joint limits (`Scenario.joint_limits == "hold"`).
    """
    if planner._T_P0 is None:
        raise ValueError("pack_allocation: reset the AllocationPlanner first")
    if planner.method not in METHODS:
        raise ValueError(f"method: unknown {planner.method!r}; allowed: {list(METHODS)}")
    prm = np.zeros(N_PARAMETERS)
    prm[P_KIND] = KIND_ALLOCATION
    prm[P_HOLD] = 1.0 if hold else 0.0
    prm[P_METHOD] = METHODS[planner.method]
    manip_mid, range_mid = planner._mid
    prm[P_MANIP_MID] = manip_mid
    prm[P_RANGE_MID : P_RANGE_MID + 3] = range_mid
    prm[P_T_P0 : P_T_P0 + 12] = np.asarray(planner._T_P0)[:3, :].ravel()
    prm[P_T_E0_INV : P_T_E0_INV + 12] = np.asarray(planner._T_E0_inv)[:3, :].ravel()
    prm[P_YAW0] = matrix_to_rpy(np.asarray(planner._T_P0)[:3, :3])[2]
    prm[P_Q0 : P_Q0 + 3] = planner._q0
    memory = np.zeros(N_MEMORY)
    memory[M_SHARE : M_SHARE + 3] = planner._share
    return prm, memory

r"""One control step of the velocity-level planners (PI, WPI, MTMP) written once for two engines.

The step is written on *lanes*: `x[i]` is either an `(N,)` array (numpy, N scenarios stepped
together, `twin.sim.batch`) or a float (one scenario, compiled by numba when it is installed).
Only operations that mean the same on both are used (`where`, `np.minimum`, no `np.clip`, no
Python `if` on a lane), so the two engines run the same arithmetic and give the same numbers.

The solve is seed 000 eqs (31)-(34) in the platform frame P instead of the base frame B: with
D = diag(ᴮR_P, ᴮR_P), the task Jacobian is J = D K where

    K = [[I, −[ᴾp_E]×, J_s,p], [0, I, J_s,ω]]      (ᴾp_E the tip in P, J_s the gangway's eq (11)),

and D is orthogonal, so J_W⁺ ẋ = W Kᵀ (K W Kᵀ + λ²I)⁻¹ Dᵀ ẋ and σ(J W^½) = σ(K W^½): the same
planner as `DifferentialPlanner` (`twin.planners.differential`) to rounding, with a sparse K
(23 entries of 54 vary) instead of a dense J. The damping test of `weighted_pinv` (σ_min of
J W^½ against ε) runs as a Cholesky factorisation of K W Kᵀ − ε²(1 + 10⁻⁶) I: when it
succeeds σ_min > ε and λ = 0, as in `weighted_pinv`; only where it fails is σ_min computed by
an SVD, as `weighted_pinv` does every step.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import Any, TypeAlias

import numpy as np

try:  # numba is optional: without it these are plain Python functions used on numpy lanes
    from numba import prange
    from numba.extending import overload, register_jitable
except ImportError:  # pragma: no cover - exercised where numba is not installed
    overload = None
    prange = range

    def register_jitable(function: Callable) -> Callable:
        return function


#: a lane: (N,) values on the numpy engine, one float on the numba one
Lane: TypeAlias = "float | np.ndarray"

HALF_PI = np.pi / 2

#: Rows of the per-scenario parameter array `prm` (`twin.sim.batch.pack_planner`).
P_GAIN, P_SPLIT, P_SCALE = 0, 1, 10  # k_e; β-split factors (9); joint-limit scale (9)
P_POSTURE_GAIN, P_POSTURE_SET = 19, 20  # k_a2, q̃2 (seed 000 eqs (39)-(40))
P_SIGMA, P_SLEW_RATE, P_Q1_MIN, P_Q1_MAX = 21, 22, 23, 24  # Algorithm 1
P_DAMPING, P_EPSILON, P_SECONDARY = 25, 26, 27  # λ_max, ε, λ of eq (34)
N_PARAMETERS = 28
#: Rows of the constant array `const`.
C_LOWER, C_UPPER, C_RATE, C_D1, C_A1 = 0, 9, 18, 27, 28
N_CONSTANTS = 29
#: Rows of the diagnostics a step writes: weights (9), null-space share, λ, rate scale, fault.
D_WEIGHTS, D_SHARE, D_DAMPING, D_SCALE, D_FAULT = 0, 9, 10, 11, 12
N_DIAGNOSTICS = 13

#: Entries of K that vary (True) or hold a constant 0 or 1 (`constant_k`); the Gram product
#: skips the zeros.
K_NONZERO = np.array(
    [
        [1, 0, 0, 0, 1, 1, 1, 1, 1],
        [0, 1, 0, 1, 0, 1, 1, 1, 1],
        [0, 0, 1, 1, 1, 0, 0, 1, 1],
        [0, 0, 0, 1, 0, 0, 0, 1, 0],
        [0, 0, 0, 0, 1, 0, 0, 1, 0],
        [0, 0, 0, 0, 0, 1, 1, 0, 0],
    ],
    dtype=np.bool_,
)


def constant_k(lanes: tuple[int, ...] = ()) -> np.ndarray:
    """K (6, 9, *lanes) with its constant entries set; `step` fills the rest."""
    K = np.zeros((6, 9, *lanes))
    for i in range(6):
        K[i, i] = 1.0
    K[5, 6] = 1.0  # the slew axis is P's z axis
    return K


def smallest_singular_value(K: np.ndarray, w: np.ndarray, need: np.ndarray) -> np.ndarray:
    """σ_min of K diag(w)^½ (`weighted_pinv`'s test) on lanes where `need`, +inf elsewhere.

    Args:
        K: (6, 9, N); w: (9, N) weights; need: (N,) bool.
    """
    sigma = np.full(need.shape, np.inf)
    if np.any(need):
        KW = np.moveaxis(K[:, :, need], -1, 0) * np.sqrt(w[:, need]).T[:, None, :]
        sigma[need] = np.linalg.svd(KW, compute_uv=False)[:, -1]
    return sigma


if overload is not None:

    @overload(smallest_singular_value)
    def _smallest_singular_value_scalar(K: Any, w: Any, need: Any) -> Callable:
        """The one-scenario form: K (6, 9), w (9,), need a bool."""

        def implementation(K: Any, w: Any, need: Any) -> float:  # numba: same signature
            if not need:
                return np.inf
            KW = np.empty((6, 9))
            for a in range(6):
                for j in range(9):
                    KW[a, j] = K[a, j] * np.sqrt(w[j])
            return np.linalg.svd(KW)[1][-1]

        return implementation


def where(condition: Lane, a: Lane, b: Lane) -> Lane:
    """`np.where` on lanes; on one scenario under numba a plain branch (numba's `np.where` on
    scalars may return a 0-d array, which does not unify with a float)."""
    return np.where(condition, a, b)


if overload is not None:

    @overload(where)
    def _where_scalar(condition: Any, a: Any, b: Any) -> Callable:
        def implementation(condition: Any, a: Any, b: Any) -> float:  # numba: same signature
            return a if condition else b

        return implementation


@register_jitable
def so3_log_lanes(
    q00: Lane,
    q01: Lane,
    q02: Lane,
    q10: Lane,
    q11: Lane,
    q12: Lane,
    q20: Lane,
    q21: Lane,
    q22: Lane,
) -> tuple[Lane, Lane, Lane]:
    """`twin.spatial.so3_log` of the rotation matrix with entries q_ij, on lanes; (wx, wy, wz)."""
    cos = np.minimum(np.maximum((q00 + q11 + q22 - 1.0) / 2.0, -1.0), 1.0)
    theta = np.arccos(cos)
    v0, v1, v2 = q21 - q12, q02 - q20, q10 - q01
    sin = np.sin(theta)
    small = theta < 1e-6
    scale = where(small, 0.5 + theta**2 / 12.0, theta / (2.0 * where(small, 1.0, sin)))
    w0, w1, w2 = scale * v0, scale * v1, scale * v2
    near_pi = theta > np.pi - 1e-4
    if np.any(near_pi):
        # the antisymmetric part vanishes near π: the axis is the symmetric part's largest row
        s00, s11, s22 = q00 - cos, q11 - cos, q22 - cos
        s01, s02, s12 = (q01 + q10) / 2.0, (q02 + q20) / 2.0, (q12 + q21) / 2.0
        first = (s00 >= s11) & (s00 >= s22)
        second = np.logical_not(first) & (s11 >= s22)
        a0 = where(first, s00, where(second, s01, s02))
        a1 = where(first, s01, where(second, s11, s12))
        a2 = where(first, s02, where(second, s12, s22))
        norm = np.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        sign = where(a0 * v0 + a1 * v1 + a2 * v2 < 0, -1.0, 1.0) * theta / norm
        w0 = where(near_pi, sign * a0, w0)
        w1 = where(near_pi, sign * a1, w1)
        w2 = where(near_pi, sign * a2, w2)
    return w0, w1, w2


@register_jitable
def cholesky_lanes(A: np.ndarray, L: np.ndarray, shift: Lane) -> Lane:
    """Lower Cholesky factor of the lower triangle of A (6, 6, …) − shift I into L.

    Returns the smallest pivot² (…); ≤ 0 or NaN where A − shift I is not positive definite.
    """
    smallest = np.inf
    for j in range(6):
        d = A[j, j] - shift
        for k in range(j):
            d = d - L[j, k] * L[j, k]
        smallest = np.minimum(smallest, d)
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, 6):
            s = A[i, j]
            for k in range(j):
                s = s - L[i, k] * L[j, k]
            L[i, j] = s / L[j, j]
    return smallest


@register_jitable
def cholesky_solve_lanes(
    L: np.ndarray, b0: Lane, b1: Lane, b2: Lane, b3: Lane, b4: Lane, b5: Lane
) -> tuple[Lane, Lane, Lane, Lane, Lane, Lane]:
    """y with L Lᵀ y = b, L from `cholesky_lanes`; six lanes in, six out."""
    z0 = b0 / L[0, 0]
    z1 = (b1 - L[1, 0] * z0) / L[1, 1]
    z2 = (b2 - L[2, 0] * z0 - L[2, 1] * z1) / L[2, 2]
    z3 = (b3 - L[3, 0] * z0 - L[3, 1] * z1 - L[3, 2] * z2) / L[3, 3]
    z4 = (b4 - L[4, 0] * z0 - L[4, 1] * z1 - L[4, 2] * z2 - L[4, 3] * z3) / L[4, 4]
    z5 = (b5 - L[5, 0] * z0 - L[5, 1] * z1 - L[5, 2] * z2 - L[5, 3] * z3 - L[5, 4] * z4) / L[5, 5]
    y5 = z5 / L[5, 5]
    y4 = (z4 - L[5, 4] * y5) / L[4, 4]
    y3 = (z3 - L[4, 3] * y4 - L[5, 3] * y5) / L[3, 3]
    y2 = (z2 - L[3, 2] * y3 - L[4, 2] * y4 - L[5, 2] * y5) / L[2, 2]
    y1 = (z1 - L[2, 1] * y2 - L[3, 1] * y3 - L[4, 1] * y4 - L[5, 1] * y5) / L[1, 1]
    y0 = (z0 - L[1, 0] * y1 - L[2, 0] * y2 - L[3, 0] * y3 - L[4, 0] * y4 - L[5, 0] * y5) / L[0, 0]
    return y0, y1, y2, y3, y4, y5


@register_jitable
def step(
    x: np.ndarray,
    target: np.ndarray,
    prm: np.ndarray,
    const: np.ndarray,
    dt: float,
    joint_limits: bool,
    posture: int,
    slew: bool,
    K: np.ndarray,
    A: np.ndarray,
    L: np.ndarray,
    w: np.ndarray,
    x_out: np.ndarray,
    diag_out: np.ndarray,
) -> None:
    """Plan (`DifferentialPlanner.step`), guard (`HybridRig.advance`) and integrate one dt.

    Args (`…` is the lane shape: (N,) on numpy, nothing on numba):
        x: (9, …) xi at sample k [m, rad].
        target: (18, …) ᴮR_d row-major (9), ᴮp_d [m] (3), twist ᴮξ̇_d [m/s, rad/s] (6).
        prm: (N_PARAMETERS, …) planner knobs (`twin.sim.batch.pack_planner`).
        const: (N_CONSTANTS,) mechanism constants (`twin.sim.batch.mechanism_constants`).
        dt: [s] control period.
        joint_limits: joint-limit weights, eqs (35)-(37).
        posture: index of the posture task's joint (eqs (39)-(40)), −1 for none.
        slew: Algorithm 1.
        K: (6, 9, …) scratch from `constant_k`; A, L: (6, 6, …) and w: (9, …) scratch.
        x_out: (9, …) written: xi at sample k + 1.
        diag_out: (N_DIAGNOSTICS, …) written.
    """
    # ᴮR_P = Rz·Ry·Rx (twin.spatial.rpy_to_matrix)
    cf, ct, cp = np.cos(x[3]), np.cos(x[4]), np.cos(x[5])
    sf, st, sp = np.sin(x[3]), np.sin(x[4]), np.sin(x[5])
    r00, r01, r02 = cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf
    r10, r11, r12 = sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf
    r20, r21, r22 = -st, ct * sf, ct * cf
    # gangway tip ᴾT_E from Table 2 (θ2 = q2 + 90°, SPEC erratum 3) in closed form
    s1, c1 = np.sin(x[6]), np.cos(x[6])
    s2, c2 = np.sin(x[7] + HALF_PI), np.cos(x[7] + HALF_PI)
    d3, a1 = x[8], const[C_A1]
    gx, gy, gz = c1 * (a1 + d3 * s2), s1 * (a1 + d3 * s2), const[C_D1] - d3 * c2
    g00, g01, g02 = c1 * c2, s1, c1 * s2
    g10, g11, g12 = s1 * c2, -c1, s1 * s2
    g20, g22 = s2, -c2  # g21 = 0
    # ᴮT_E = ᴮT_P ᴾT_E
    e00 = r00 * g00 + r01 * g10 + r02 * g20
    e01 = r00 * g01 + r01 * g11
    e02 = r00 * g02 + r01 * g12 + r02 * g22
    e10 = r10 * g00 + r11 * g10 + r12 * g20
    e11 = r10 * g01 + r11 * g11
    e12 = r10 * g02 + r11 * g12 + r12 * g22
    e20 = r20 * g00 + r21 * g10 + r22 * g20
    e21 = r20 * g01 + r21 * g11
    e22 = r20 * g02 + r21 * g12 + r22 * g22
    px = r00 * gx + r01 * gy + r02 * gz + x[0]
    py = r10 * gx + r11 * gy + r12 * gz + x[1]
    pz = r20 * gx + r21 * gy + r22 * gz + x[2]

    # e = [p_d − p; log(R_d Rᵀ)] in B (twin.spatial.pose_error), demand ẋ_d + k_e e (eq (34))
    d00, d01, d02 = target[0], target[1], target[2]
    d10, d11, d12 = target[3], target[4], target[5]
    d20, d21, d22 = target[6], target[7], target[8]
    ew0, ew1, ew2 = so3_log_lanes(
        d00 * e00 + d01 * e01 + d02 * e02,
        d00 * e10 + d01 * e11 + d02 * e12,
        d00 * e20 + d01 * e21 + d02 * e22,
        d10 * e00 + d11 * e01 + d12 * e02,
        d10 * e10 + d11 * e11 + d12 * e12,
        d10 * e20 + d11 * e21 + d12 * e22,
        d20 * e00 + d21 * e01 + d22 * e02,
        d20 * e10 + d21 * e11 + d22 * e12,
        d20 * e20 + d21 * e21 + d22 * e22,
    )
    k_e = prm[P_GAIN]
    l0 = target[12] + k_e * (target[9] - px)
    l1 = target[13] + k_e * (target[10] - py)
    l2 = target[14] + k_e * (target[11] - pz)
    l3 = target[15] + k_e * ew0
    l4 = target[16] + k_e * ew1
    l5 = target[17] + k_e * ew2
    # the demand in P: Dᵀ ẋ
    b0 = r00 * l0 + r10 * l1 + r20 * l2
    b1 = r01 * l0 + r11 * l1 + r21 * l2
    b2 = r02 * l0 + r12 * l1 + r22 * l2
    b3 = r00 * l3 + r10 * l4 + r20 * l5
    b4 = r01 * l3 + r11 * l4 + r21 * l5
    b5 = r02 * l3 + r12 * l4 + r22 * l5

    # K: −[ᴾp_E]× and J_s (twin.mechanisms.gangway.Gangway.jacobian)
    K[0, 4], K[0, 5], K[1, 3], K[1, 5], K[2, 3], K[2, 4] = gz, -gy, -gz, gx, gy, -gx
    K[0, 6], K[0, 7], K[0, 8] = -a1 * s1 - d3 * s1 * s2, d3 * c1 * c2, c1 * s2
    K[1, 6], K[1, 7], K[1, 8] = a1 * c1 + d3 * c1 * s2, d3 * s1 * c2, s1 * s2
    K[2, 7], K[2, 8] = d3 * s2, -c2
    K[3, 7], K[4, 7] = s1, -c1

    # diag(W⁻¹): β split (eq (28)) × joint-limit weights (eqs (35)-(37), SPEC erratum 4)
    for i in range(9):
        if joint_limits:
            lower, upper = const[C_LOWER + i], const[C_UPPER + i]
            span = upper - lower
            q = np.minimum(np.maximum(x[i], lower + 1e-3 * span), upper - 1e-3 * span)
            gradient = span * (2 * q - upper - lower) / ((upper - q) * (q - lower))
            w[i] = prm[P_SPLIT + i] * (prm[P_SCALE + i] / (1.0 + np.abs(gradient)))
        else:
            w[i] = prm[P_SPLIT + i]

    # K W Kᵀ (lower triangle), damping test, damped factor (twin.planners.linalg)
    for a in range(6):
        for b in range(a + 1):
            s = 0.0
            for j in range(9):
                if K_NONZERO[a, j] and K_NONZERO[b, j]:
                    s = s + K[a, j] * w[j] * K[b, j]
            A[a, b] = s
    epsilon = prm[P_EPSILON]
    need = np.logical_not(cholesky_lanes(A, L, epsilon**2 * (1.0 + 1e-6)) > 0.0)
    ratio = np.minimum(smallest_singular_value(K, w, need) / epsilon, 1.0)
    lam2 = (1.0 - ratio**2) * prm[P_DAMPING] ** 2
    cholesky_lanes(A, L, -lam2)

    # primary J_W⁺ ẋ and null-space motion λ (I − J_W⁺J) J_aᵀ ζ̇_a (eqs (33)-(34))
    y0, y1, y2, y3, y4, y5 = cholesky_solve_lanes(L, b0, b1, b2, b3, b4, b5)
    wanted = z0 = z1 = z2 = z3 = z4 = z5 = 0.0
    if posture >= 0:
        wanted = prm[P_POSTURE_GAIN] * (prm[P_POSTURE_SET] - x[posture])
        z0, z1, z2, z3, z4, z5 = cholesky_solve_lanes(
            L,
            K[0, posture] * wanted,
            K[1, posture] * wanted,
            K[2, posture] * wanted,
            K[3, posture] * wanted,
            K[4, posture] * wanted,
            K[5, posture] * wanted,
        )
    null2 = 0.0
    for j in range(9):
        primary = w[j] * (
            K[0, j] * y0 + K[1, j] * y1 + K[2, j] * y2 + K[3, j] * y3 + K[4, j] * y4 + K[5, j] * y5
        )
        null = 0.0
        if posture >= 0:
            back = w[j] * (
                K[0, j] * z0
                + K[1, j] * z1
                + K[2, j] * z2
                + K[3, j] * z3
                + K[4, j] * z4
                + K[5, j] * z5
            )
            null = prm[P_SECONDARY] * ((wanted if j == posture else 0.0) - back)
        null2 = null2 + null * null
        x_out[j] = primary + null  # v, integrated below

    if slew:  # Algorithm 1 (twin.planners.limits.SlewPriority)
        q1, q1_min, q1_max = x[6], prm[P_Q1_MIN], prm[P_Q1_MAX]
        sigma, rate = prm[P_SIGMA], prm[P_SLEW_RATE]
        total = x_out[5] + x_out[6]
        flexible = (q1 >= q1_min + sigma) & (q1 <= q1_max - sigma)
        slew_flexible = np.minimum(np.maximum(total, -rate), rate)
        low_band = (q1 > q1_min) & (q1 < q1_min + sigma)
        high_band = (q1 > q1_max - sigma) & (q1 < q1_max)
        phase = where(low_band, (q1_min + sigma - q1) / sigma, (q1 - q1_max + sigma) / sigma)
        slew_band = 0.5 * total * (1.0 + np.cos(phase * np.pi))
        rate_6 = where(flexible, slew_flexible, where(low_band | high_band, slew_band, 0.0))
        x_out[5] = total - rate_6
        x_out[6] = rate_6

    # common rate limit (VelocityLimit), then HybridRig's fault guard
    most = np.abs(x_out[0]) / const[C_RATE]
    for j in range(1, 9):
        most = np.maximum(most, np.abs(x_out[j]) / const[C_RATE + j])
    scale = 1.0 / np.maximum(most, 1.0)
    norm2 = 0.0
    finite = True
    for j in range(9):
        x_out[j] = x_out[j] * scale
        norm2 = norm2 + x_out[j] * x_out[j]
        finite = finite & np.isfinite(x_out[j])
    for j in range(9):
        diag_out[D_WEIGHTS + j] = w[j]
        x_out[j] = where(finite, x_out[j], 0.0) * dt  # the step v dt
    diag_out[D_SHARE] = np.sqrt(null2) / np.maximum(np.sqrt(norm2), 1e-12)
    diag_out[D_DAMPING] = np.sqrt(lam2)
    diag_out[D_SCALE] = scale
    diag_out[D_FAULT] = where(finite, 0.0, 1.0)

    # ᴮT_P ← ᴮT_P exp([ᴾṖ; ω_P] dt) (HybridBoardingSystem.integrate, twin.spatial.se3_exp)
    vx, vy, vz, wx, wy, wz = x_out[0], x_out[1], x_out[2], x_out[3], x_out[4], x_out[5]
    theta = np.sqrt(wx * wx + wy * wy + wz * wz)
    small = theta < 1e-8
    t = where(small, 1.0, theta)
    ea = where(small, 1.0 - theta**2 / 6.0, np.sin(t) / t)
    eb = where(small, 0.5 - theta**2 / 24.0, (1.0 - np.cos(t)) / t**2)
    ec = where(small, 1.0 / 6.0 - theta**2 / 120.0, (t - np.sin(t)) / t**3)
    # exp(ω dt) = I + a S + b S² and V = I + b S + c S², S = skew(ω dt), S² = [k_ij]
    k00, k11, k22 = -wz * wz - wy * wy, -wz * wz - wx * wx, -wy * wy - wx * wx
    k01, k02, k12 = wy * wx, wz * wx, wz * wy
    m00, m01, m02 = 1.0 + eb * k00, -ea * wz + eb * k01, ea * wy + eb * k02
    m10, m11, m12 = ea * wz + eb * k01, 1.0 + eb * k11, -ea * wx + eb * k12
    m20, m21, m22 = -ea * wy + eb * k02, ea * wx + eb * k12, 1.0 + eb * k22
    t0 = (1.0 + ec * k00) * vx + (-eb * wz + ec * k01) * vy + (eb * wy + ec * k02) * vz
    t1 = (eb * wz + ec * k01) * vx + (1.0 + ec * k11) * vy + (-eb * wx + ec * k12) * vz
    t2 = (-eb * wy + ec * k02) * vx + (eb * wx + ec * k12) * vy + (1.0 + ec * k22) * vz
    # only the entries matrix_to_rpy reads of ᴮR_P exp(ω dt)
    n00 = r00 * m00 + r01 * m10 + r02 * m20
    n10 = r10 * m00 + r11 * m10 + r12 * m20
    n20 = r20 * m00 + r21 * m10 + r22 * m20
    n21 = r20 * m01 + r21 * m11 + r22 * m21
    n22 = r20 * m02 + r21 * m12 + r22 * m22
    x_out[0] = r00 * t0 + r01 * t1 + r02 * t2 + x[0]
    x_out[1] = r10 * t0 + r11 * t1 + r12 * t2 + x[1]
    x_out[2] = r20 * t0 + r21 * t1 + r22 * t2 + x[2]
    x_out[3] = np.arctan2(n21, n22)  # twin.spatial.matrix_to_rpy
    x_out[4] = np.arctan2(-n20, np.hypot(n21, n22))
    x_out[5] = np.arctan2(n10, n00)
    for j in range(6, 9):
        x_out[j] = x[j] + x_out[j]


def run_lanes(
    xs: np.ndarray,
    targets: np.ndarray,
    prm: np.ndarray,
    const: np.ndarray,
    dt: float,
    joint_limits: bool,
    posture: int,
    slew: bool,
    diag: np.ndarray,
) -> None:
    """Step every scenario through a block of samples, one scenario per thread (numba engine).

    Args:
        xs: (N, B + 1, 9) xi; row 0 is the start, rows 1 … B are written.
        targets: (N, B, 18) as `step`'s `target`.
        prm: (N, N_PARAMETERS).
        diag: (N, B, N_DIAGNOSTICS), written.
        The rest as `step`.
    """
    for n in prange(xs.shape[0]):
        K = np.zeros((6, 9))
        for i in range(6):
            K[i, i] = 1.0
        K[5, 6] = 1.0
        A, L, w = np.empty((6, 6)), np.empty((6, 6)), np.empty(9)
        for k in range(targets.shape[1]):
            step(xs[n, k], targets[n, k], prm[n], const, dt, joint_limits, posture, slew, K, A,
                 L, w, xs[n, k + 1], diag[n, k])  # fmt: skip


@cache
def compiled_runner(parallel: bool) -> Callable:
    """`run_lanes` compiled by numba, parallel over scenarios or serial (one scenario, or one
    thread per process as in a Dask worker); cached on disk after the first compilation."""
    import numba

    return numba.njit(parallel=parallel, cache=True, error_model="numpy")(run_lanes)

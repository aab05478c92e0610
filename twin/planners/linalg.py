r"""Damped weighted pseudo-inverse, the one solver all differential planners share."""

from __future__ import annotations

import math

import numpy as np

from twin.batch import LaneBatch
from twin.compiled import register_inline, register_jitable

#: machine epsilon of float64 (`np.finfo(float).eps`), the rank cut-off of the SVD form
EPS = 2.220446049250313e-16


def weighted_pinv(
    J: np.ndarray, w: np.ndarray, *, epsilon: float = 0.01, damping_max: float = 0.05
) -> tuple[np.ndarray, np.ndarray]:
    r"""J_W⁺ = W⁻¹ Jᵀ (J W⁻¹ Jᵀ + λ² I)⁻¹ (seed 000 eq (31), damped).

    With `w` = diag(W⁻¹) all ones this is the plain pseudo-inverse of eq (26). The damping
    λ is zero while the smallest singular value σ_min of J_W = J W^{-1/2} exceeds `epsilon`
    and rises smoothly to `damping_max` as σ_min → 0 (Maciejewski & Klein 1988 / Chiaverini
    1997 numerical filtering): λ² = (1 − (σ_min/ε)²) λ_max². Joint velocities therefore stay
    bounded through singularities at the cost of a task error there.

    Args:
        J: (..., m, n) task Jacobian.
        w: (..., n) diagonal of W⁻¹ (≥ 0; a zero weight freezes that joint).
        epsilon: σ_min [task units] below which damping starts.
        damping_max: λ_max, the damping at σ_min = 0.

    Returns:
        J_W⁺ (..., n, m) and λ (...,), by `weighted_pinv_lane` problem by problem.
    """
    J, w = np.asarray(J, dtype=float), np.asarray(w, dtype=float)
    m, n = J.shape[-2:]
    pinv, damping = WEIGHTED_PINV([J, w], [float(epsilon), float(damping_max)], [(n, m), ()])
    return pinv, damping


# ---------------------------------------------------------------------------------------------
# One lane: the same solve on a single (6, 9) problem, as the engine's kernels compose it
# (floats and small arrays, compiled by numba, `twin.compiled`; plain Python without numba).
# The undamped solve is a Cholesky factorisation of K W Kᵀ; where `weighted_pinv`'s damping
# test fails, the SVD form with `damped_gains_lane` (twin.planners.differential module doc).
# ---------------------------------------------------------------------------------------------


@register_inline
def damping_ratio(sigma_min: float, epsilon: float) -> float:
    """σ_min / ε clipped to [0, 1] [-]: the damping is λ = √(1 − ratio²) λ_max (numerical
    filtering, `weighted_pinv`)."""
    return min(max(sigma_min / epsilon, 0.0), 1.0)


@register_inline
def damped_gains_lane(s: np.ndarray, n: int, epsilon: float, damping_max: float,
                      gain_out: np.ndarray) -> float:  # fmt: skip
    """`weighted_pinv`'s damping on one problem: the gains s_k / (s_k² + λ²) into gain_out
    (m,) (0 for a singular value below s_max·n·eps), λ² = (1 − (σ_min/ε)²) λ_max² returned.

    Args:
        s: (m,) singular values of J_W, descending; n: J's number of columns.
        epsilon: ε [task units]; damping_max: λ_max [-].
    """
    m = s.shape[0]
    ratio = damping_ratio(s[m - 1], epsilon)
    lam2 = (1.0 - ratio**2) * damping_max**2
    for k in range(m):
        kept = s[k] > s[0] * n * EPS
        gain_out[k] = 1.0 / (s[k] + lam2 / s[k]) if kept else 0.0
    return lam2


@register_inline
def weighted_gram_lane(K: np.ndarray, w: np.ndarray, row: np.ndarray, A_out: np.ndarray) -> None:
    """A_out (6, 6) = K W Kᵀ with W = diag(w), K (6, 9), w (9,): the matrix `weighted_pinv`
    inverts (seed 000 eq (31)). Row a of K W once per row (in `row` (9,), scratch), not once per
    entry: the products (K_aj w_j) K_cj, summed over j in order. (The sizes are constants, as
    in the other lane functions here: numba unrolls loops of known length.)"""
    for a in range(6):
        for j in range(9):
            row[j] = K[a, j] * w[j]
        for c in range(a + 1):
            s = 0.0
            for j in range(9):
                s += row[j] * K[c, j]
            A_out[a, c] = s
            A_out[c, a] = s


@register_inline
def cholesky_lane(A: np.ndarray, n: int, shift: float, L: np.ndarray) -> bool:
    """Lower Cholesky factor of A − shift·I (A (≥ n, ≥ n) symmetric; the lower triangle of its
    first n rows and columns is read) into L's lower triangle (L (≥ n, ≥ n), the strict upper
    one left as it was; L may be A itself), its diagonal stored inverted: L[j, j] = 1 / l_jj,
    so the factorisation and the solves (`cholesky_pinv_apply`, `twin.planners.active_set`)
    multiply where they would divide (a division costs several multiplications' latency, and
    these chains are latency-bound).

    Returns whether A − shift·I is positive definite (every pivot > 0; False on a NaN).
    """
    for j in range(n):
        d = A[j, j] - shift
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        inverse = 1.0 / math.sqrt(d)
        L[j, j] = inverse
        for i in range(j + 1, n):
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


@register_jitable  # not borrowing: it allocates
def svd_pinv_apply(
    U: np.ndarray, gain: np.ndarray, Vt: np.ndarray, sqrt_w: np.ndarray, c: np.ndarray,
    out: np.ndarray,
) -> None:  # fmt: skip
    """out (n,) = W^½ V diag(gain) Uᵀ c: `weighted_pinv`'s SVD form of J_W⁺ (in P) applied to
    c (m,), with K W^½ = U S Vᵀ (K (m, n), thin: U (m, r), Vt (r, n)) and gain_k = s_k / (s_k²
    + λ²) (0 for a dropped s_k); (6, 9) on the engine's lanes."""
    r = gain.shape[0]
    g = np.empty(r)
    for k in range(r):
        s = 0.0
        for a in range(U.shape[0]):
            s += U[a, k] * c[a]
        g[k] = gain[k] * s
    for j in range(Vt.shape[1]):  # out may be longer than n (a row of the caller's scratch)
        s = 0.0
        for k in range(r):
            s += Vt[k, j] * g[k]
        out[j] = sqrt_w[j] * s


@register_jitable  # not borrowing: it allocates (the SVD)
def weighted_pinv_lane(
    J: np.ndarray, w: np.ndarray, epsilon: float, damping_max: float, pinv_out: np.ndarray
) -> float:
    """`weighted_pinv` on one problem: J_W⁺ = W^½ V diag(s / (s² + λ²)) Uᵀ with J W^½ = U S Vᵀ
    (seed 000 eq (31), damped: `damped_gains_lane`) into pinv_out (n, m), column by column
    (`svd_pinv_apply` on the unit vectors); λ returned, as √(1 − r²) λ_max rather than √λ²
    (for a λ_max under 1e-154, λ_max² is subnormal and its square root came back above λ_max).

    Not a solve: with λ = 0 and a rank-deficient J_W the Gram matrix is singular; the singular
    values lost to rounding get a gain of 0, as in numpy's pinv.

    Args:
        J: (m, n) task Jacobian; w: (n,) diagonal of W⁻¹ (≥ 0).
        epsilon: ε [task units]; damping_max: λ_max [-].
    """
    m, n = J.shape
    sqrt_w = np.sqrt(w)
    U, s, Vt = np.linalg.svd(J * sqrt_w, full_matrices=False)
    gain = np.empty(s.shape[0])
    damped_gains_lane(s, max(m, n), epsilon, damping_max, gain)
    unit = np.zeros(m)
    for i in range(m):
        unit[i] = 1.0
        svd_pinv_apply(U, gain, Vt, sqrt_w, unit, pinv_out[:, i])
        unit[i] = 0.0
    ratio = damping_ratio(s[s.shape[0] - 1], epsilon)
    return math.sqrt(1.0 - ratio**2) * damping_max


def _weighted_pinv_batch(
    J: np.ndarray,
    w: np.ndarray,
    epsilon: float,
    damping_max: float,
    pinv: np.ndarray,
    damping: np.ndarray,
) -> None:
    """`weighted_pinv_lane` over problems J (N, m, n), w (N, n) into pinv (N, n, m) and
    damping (N,)."""
    for k in range(J.shape[0]):
        damping[k] = weighted_pinv_lane(J[k], w[k], epsilon, damping_max, pinv[k])


#: the lane over a batch of problems: what `weighted_pinv` calls
WEIGHTED_PINV = LaneBatch(_weighted_pinv_batch, cores=(2, 1))

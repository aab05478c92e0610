r"""Damped weighted pseudo-inverse, the one solver all differential planners share."""

from __future__ import annotations

import numpy as np


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
        J_W⁺ (..., n, m) and λ (...,).
    """
    sqrt_w = np.sqrt(w)
    U, s, Vt = np.linalg.svd(J * sqrt_w[..., None, :], full_matrices=False)  # J_W = U S Vᵀ
    sigma_min = s[..., -1]
    ratio = np.clip(sigma_min / epsilon, 0.0, 1.0)
    lam2 = (1.0 - ratio**2) * damping_max**2
    # W⁻¹Jᵀ(J W⁻¹ Jᵀ + λ²I)⁻¹ = W^{-1/2} V diag(s / (s² + λ²)) Uᵀ, from the same SVD. Not a
    # solve: with λ = 0 (damping_max = 0) and a rank-deficient J_W (β = 0 keeps three joints)
    # J W⁻¹ Jᵀ is singular; singular values lost to rounding then get 0, as in numpy's pinv.
    kept = s > s[..., :1] * max(J.shape[-2:]) * np.finfo(float).eps
    safe = np.where(kept, s, 1.0)
    gain = np.where(kept, 1.0 / (safe + lam2[..., None] / safe), 0.0)  # s / (s² + λ²)
    VG = np.swapaxes(Vt, -1, -2) * gain[..., None, :]  # (..., n, k)
    pinv = sqrt_w[..., :, None] * (VG @ np.swapaxes(U, -1, -2))  # (..., n, m)
    # λ itself from √(1 − r²) λ_max, not √λ²: for a λ_max under 1e-154, λ_max² is subnormal
    # and its square root came back above λ_max (hypothesis found 1.31119e-158)
    return pinv, np.sqrt(1.0 - ratio**2) * damping_max

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
    sqrt_w = np.sqrt(w)[..., None, :]
    sigma_min = np.linalg.svd(J * sqrt_w, compute_uv=False)[..., -1]
    ratio = np.clip(sigma_min / epsilon, 0.0, 1.0)
    lam2 = (1.0 - ratio**2) * damping_max**2
    WJt = w[..., :, None] * np.swapaxes(J, -1, -2)  # W⁻¹ Jᵀ, (..., n, m)
    m = J.shape[-2]
    A = J @ WJt + lam2[..., None, None] * np.eye(m)
    # (J W⁻¹ Jᵀ + λ²I) is symmetric positive (semi)definite: solve, never invert
    pinv = np.swapaxes(np.linalg.solve(A, np.swapaxes(WJt, -1, -2)), -1, -2)
    return pinv, np.sqrt(lam2)

"""weighted_pinv: seed 000 eqs (26), (31) and damped least squares."""

from __future__ import annotations

import numpy as np

from twin.planners import weighted_pinv


def test_unit_weights_give_the_moore_penrose_inverse(rng: np.random.Generator) -> None:
    """eq (26): with W = I (and no damping needed) J⁺ = Jᵀ(JJᵀ)⁻¹ = numpy's pinv."""
    J = rng.normal(size=(6, 9))
    pinv, damping = weighted_pinv(J, np.ones(9))
    np.testing.assert_allclose(pinv, np.linalg.pinv(J), atol=1e-12)
    assert damping == 0.0


def test_weighted_inverse_is_a_right_inverse_minimising_the_weighted_norm(rng) -> None:
    """eq (31): J J_W⁺ = I, and J_W⁺ ẋ minimises ξ̇ᵀ W ξ̇ among all solutions of J ξ̇ = ẋ."""
    J, w, xdot = rng.normal(size=(6, 9)), rng.uniform(0.1, 2.0, 9), rng.normal(size=6)
    pinv, _ = weighted_pinv(J, w)
    np.testing.assert_allclose(J @ pinv, np.eye(6), atol=1e-10)
    best = pinv @ xdot
    null = np.linalg.svd(J)[2][6:].T  # basis of the null space
    for _ in range(20):
        other = best + null @ rng.normal(size=3)
        assert other @ (other / w) >= best @ (best / w) - 1e-12


def test_damping_keeps_velocities_bounded_at_a_singularity() -> None:
    """A rank-deficient J gives finite velocities and reports the damping it used."""
    J = np.zeros((6, 9))
    J[:5, :5] = np.eye(5)  # the 6th task direction is unreachable
    pinv, damping = weighted_pinv(J, np.ones(9), epsilon=0.01, damping_max=0.05)
    assert np.all(np.isfinite(pinv))
    assert damping == 0.05
    np.testing.assert_allclose(pinv[:5, :5], np.eye(5) / (1 + 0.05**2), atol=1e-12)


def test_batched_equals_single(rng: np.random.Generator) -> None:
    """The batched weighted pseudo-inverse equals the single-matrix one for every batch member to
    1e-12."""
    J, w = rng.normal(size=(4, 6, 9)), rng.uniform(0.1, 1.0, (4, 9))
    batch, _ = weighted_pinv(J, w)
    for k in range(4):
        np.testing.assert_allclose(batch[k], weighted_pinv(J[k], w[k])[0], atol=1e-12)


def test_damped_inverse_is_the_regularised_normal_equations(rng: np.random.Generator) -> None:
    """With the λ it reports, J_W⁺ = W⁻¹Jᵀ(J W⁻¹ Jᵀ + λ² I)⁻¹ (seed 000 eq (31), damped),
    solved here by numpy: near-singular J (rows 5 and 6 almost equal) and random weights,
    each problem of a batch and of several sizes m ≤ n."""
    for m, n in ((6, 9), (3, 5), (1, 4)):
        J, w = rng.normal(size=(8, m, n)), rng.uniform(0.1, 2.0, (8, n))
        J[:4, -1] = J[:4, 0] * (1 + 1e-9)
        pinv, damping = weighted_pinv(J, w, epsilon=0.3, damping_max=0.2)
        assert pinv.shape == (8, n, m) and damping.shape == (8,)
        if m > 1:
            assert np.all(damping[:4] > 0.19)  # σ_min ≈ 0: nearly λ_max
        for k in range(8):
            JW = J[k] * w[k]
            gram = JW @ J[k].T + damping[k] ** 2 * np.eye(m)
            np.testing.assert_allclose(pinv[k], np.linalg.solve(gram, JW).T, atol=1e-12)

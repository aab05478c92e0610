"""Weights: seed 000 eq (28) β split, eqs (35)-(37) joint-limit weights with k_c."""

from __future__ import annotations

import numpy as np
import pytest

from twin.mechanisms import HybridBoardingSystem
from twin.planners import BetaSplit, JointLimitWeights, ProductWeights

H = HybridBoardingSystem()


def test_beta_split_is_eq28() -> None:
    """BetaSplit(0.7) weighs the six platform joints 0.7 and the three gangway joints 0.3 (eq
    28)."""
    w = BetaSplit(0.7)(H.working_state)
    np.testing.assert_allclose(w, [0.7] * 6 + [0.3] * 3)


def test_index_zero_is_plain_pseudo_inverse() -> None:
    """eq (30): l = 0 removes the weighting."""
    np.testing.assert_allclose(BetaSplit(0.7, index=0.0)(H.working_state), 1.0)


def test_joint_limit_weight_is_one_at_mid_range_and_falls_to_zero_at_limits() -> None:
    """eq (37) below: w_i = 1 at the middle of the range, → 0 at either limit."""
    weights = JointLimitWeights(H.lower, H.upper, np.ones(9))
    mid = (H.lower + H.upper) / 2
    np.testing.assert_allclose(weights(mid), 1.0)
    for frac in (0.999, 0.9999):
        near = H.lower + frac * (H.upper - H.lower)
        assert np.all(weights(near) < 0.01)
    # monotone from the middle out to the upper limit
    path = mid + np.linspace(0, 0.99, 50)[:, None] * (H.upper - mid)
    assert np.all(np.diff(weights(path), axis=0) < 0)


def test_gradient_is_eq36_with_the_spec_denominator() -> None:
    """∂H/∂q of eq (36) (SPEC erratum 4) with c_i = q_max − q_min, by hand for one joint."""
    weights = JointLimitWeights(np.array([0.0]), np.array([2.0]), np.ones(1))
    q = np.array([1.5])
    by_hand = 2.0**2 * (2 * 1.5 - 2.0 - 0.0) / (2.0 * (2.0 - 1.5) * (1.5 - 0.0))
    assert weights.gradient(q)[0] == pytest.approx(by_hand)
    assert weights(q)[0] == pytest.approx(1 / (1 + by_hand))


def test_kc_scales_the_telescope_weight() -> None:
    """eq (37): (1 − β) k_c w_9 on the telescope."""
    scale = np.r_[np.ones(8), 9.0]
    w = ProductWeights((BetaSplit(0.7), JointLimitWeights(H.lower, H.upper, scale)))
    mid = (H.lower + H.upper) / 2
    assert w(mid)[8] == pytest.approx(0.3 * 9.0)
    assert w(mid)[0] == pytest.approx(0.7)


def test_beyond_a_limit_the_weight_is_small_but_not_zero() -> None:
    """Past a joint limit the weight is positive and below 2e-3, never zero."""
    weights = JointLimitWeights(H.lower, H.upper, np.ones(9))
    w = weights(H.upper + 0.1)
    assert np.all((w > 0) & (w < 2e-3))

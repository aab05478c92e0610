"""The sampled loop gain (`twin.planners.gains`): the discrete loop equals the continuous one."""

from __future__ import annotations

import numpy as np
import pytest

from twin.planners.gains import proportional_gain


@pytest.mark.parametrize("k", [0.5, 25.0, 120.0])
@pytest.mark.parametrize("dt", [1e-3, 0.01, 0.085, 0.2, 1.0])
def test_a_step_leaves_the_continuous_loops_error(k: float, dt: float) -> None:
    """Stepping ė = −g e with the sampled gain g leaves e^(−k dt) of the error each step (to
    the rounding of 1 − g dt): the continuous loop's, between 0 and 1 at every k·dt (never an
    overshoot, never divergence)."""
    left = 1.0 - proportional_gain(k, dt) * dt
    assert left == pytest.approx(np.exp(-k * dt), rel=1e-12, abs=1e-15)
    assert 0.0 <= left < 1.0


def test_the_gain_is_k_for_short_steps_and_without_a_step() -> None:
    """≈ k when k·dt ≪ 1 (first order: k (1 − k dt / 2)); exactly k for dt ≤ 0."""
    assert proportional_gain(25.0, 1e-6) == pytest.approx(25.0 * (1 - 25.0 * 1e-6 / 2), rel=1e-9)
    assert proportional_gain(25.0, 0.0) == 25.0
    assert proportional_gain(25.0, -1.0) == 25.0

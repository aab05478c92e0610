"""Seed 000 Algorithm 1 (SlewPriority) and the rate limit."""

from __future__ import annotations

import numpy as np
import pytest

from twin.planners import SlewPriority, VelocityLimit

DEG = np.pi / 180
ALGO = SlewPriority(q1_min=-30 * DEG, q1_max=30 * DEG, sigma=5 * DEG, rate_max=10 * DEG)


def state(q1: float) -> np.ndarray:
    xi = np.zeros(9)
    xi[6] = q1
    return xi


def velocity(w_pz: float, q1_dot: float) -> np.ndarray:
    v = np.arange(9, dtype=float)
    v[5], v[6] = w_pz, q1_dot
    return v


@pytest.mark.parametrize(
    ("q1", "w_sum", "slew", "yaw"),
    [
        (0.0, 4 * DEG, 4 * DEG, 0.0),  # lines 2-3: all to the slew
        (0.0, 15 * DEG, 10 * DEG, 5 * DEG),  # lines 4-5: slew saturates
        (0.0, -15 * DEG, -10 * DEG, -5 * DEG),  # lines 6-7
        (-27.5 * DEG, 4 * DEG, 2 * DEG, 2 * DEG),  # line 9: mid-band, cos(π/2) = 0
        (27.5 * DEG, 4 * DEG, 2 * DEG, 2 * DEG),  # line 11
        (-31 * DEG, 4 * DEG, 0.0, 4 * DEG),  # line 13: beyond the limit
    ],
)
def test_algorithm1_cases(q1: float, w_sum: float, slew: float, yaw: float) -> None:
    out = ALGO(state(q1), velocity(w_sum / 3, 2 * w_sum / 3))
    assert out[6] == pytest.approx(slew)
    assert out[5] == pytest.approx(yaw)
    np.testing.assert_array_equal(np.delete(out, [5, 6]), np.delete(np.arange(9.0), [5, 6]))


def test_band_blend_is_continuous_at_both_edges() -> None:
    """Raised cosine: full slew at the band's inner edge, none at the limit."""
    w = 4 * DEG
    inner = ALGO(state(-25 * DEG + 1e-12), velocity(0.0, w))
    edge = ALGO(state(-30 * DEG + 1e-12), velocity(0.0, w))
    assert inner[6] == pytest.approx(w)
    assert edge[6] == pytest.approx(0.0, abs=1e-9)


def test_velocity_limit_scales_uniformly() -> None:
    limit = VelocityLimit(np.full(3, 1.0))
    v, scale = limit(np.array([0.5, -4.0, 2.0]))
    np.testing.assert_allclose(v, [0.125, -1.0, 0.5])
    assert scale == pytest.approx(0.25)
    v, scale = limit(np.array([0.5, -0.4, 0.2]))
    assert scale == 1.0

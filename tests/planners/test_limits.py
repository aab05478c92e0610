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
    """Algorithm 1 sets the slew and yaw rates of each case and leaves every other joint rate
    unchanged."""
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
    """A velocity past its limit is scaled uniformly so the worst joint is at its limit; one within
    is kept (scale 1)."""
    limit = VelocityLimit(np.full(3, 1.0))
    v, scale = limit(np.array([0.5, -4.0, 2.0]))
    np.testing.assert_allclose(v, [0.125, -1.0, 0.5])
    assert scale == pytest.approx(0.25)
    v, scale = limit(np.array([0.5, -0.4, 0.2]))
    assert scale == 1.0


def test_euler_yaw_hold_keeps_the_platforms_euler_yaw() -> None:
    """Default `yaw_hold` = 1: in the flexible range the platform keeps ω_pz = −tan φ·ω_py, at
    which ψ̇ = (sin φ ω_py + cos φ ω_pz)/cos θ of R = Rz Ry Rx vanishes; q̇1 takes the rest of
    w_1sum. Checked on the integrated pose: the Euler yaw moves by O(dt²) only, while the
    body-rate reading (`yaw_hold` = 0) turns it at first order."""
    from twin.mechanisms import HybridBoardingSystem

    H = HybridBoardingSystem()
    xi = H.working_state.copy()
    xi[3], xi[4] = 0.2, -0.1  # [rad] roll, pitch
    v = np.zeros(9)
    v[3], v[4], v[5], v[6] = 0.05, 0.3, 0.02, 0.01  # [rad/s]
    euler, body = ALGO(xi, v), SlewPriority(**{**ALGO.__dict__, "yaw_hold": 0.0})(xi, v)
    assert euler[5] == pytest.approx(-np.tan(0.2) * 0.3)
    assert euler[5] + euler[6] == pytest.approx(0.03)  # w_1sum kept
    assert (body[5], body[6]) == (0.0, pytest.approx(0.03))
    dt = 1e-3
    yaw_rate = {name: (H.integrate(xi, out, dt)[5] - xi[5]) / dt
                for name, out in (("euler", euler), ("body", body))}  # fmt: skip
    assert abs(yaw_rate["euler"]) < 1e-3 * abs(yaw_rate["body"])
    assert abs(yaw_rate["body"]) > 0.05  # [rad/s] ψ̇ = sin φ ω_py / cos θ ≈ 0.06


@pytest.mark.parametrize("yaw_hold", [0.0, 0.5, 1.0])
def test_moving_rate_between_yaw_and_slew_leaves_the_tip_untouched(yaw_hold: float) -> None:
    """J_task's yaw and slew columns are equal (the slew axis is P's z axis), so any split of
    w_1sum gives the same tip twist."""
    from twin.mechanisms import HybridBoardingSystem

    H = HybridBoardingSystem()
    xi = H.working_state + np.r_[0.1, -0.05, 0.2, 0.3, -0.2, 0.1, 0.2, 0.1, 1.0]
    v = np.array([0.1, -0.2, 0.05, 0.2, 0.4, -0.1, 0.3, 0.05, -0.2])
    out = SlewPriority(ALGO.q1_min, ALGO.q1_max, ALGO.sigma, ALGO.rate_max, yaw_hold=yaw_hold)(
        xi, v
    )
    J = H.task_jacobian(xi)
    np.testing.assert_allclose(J[:, 5], J[:, 6], atol=1e-12)
    np.testing.assert_allclose(J @ out, J @ v, atol=1e-12)
    assert out[5] != v[5]  # the split did change

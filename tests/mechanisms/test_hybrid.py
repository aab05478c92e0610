"""HybridBoardingSystem: seed 000 eqs (14)-(25), Tables 5-6, SPEC check values."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import random_hybrid_states
from twin.mechanisms import HybridBoardingSystem
from twin.spatial import so3_log

HYBRID = HybridBoardingSystem()
DEG = np.pi / 180


def test_working_state_is_table5() -> None:
    """The hybrid system's working state is Table 5's, exactly."""
    np.testing.assert_array_equal(HYBRID.working_state, [0, 0, 2.475, 0, 0, 0, 0, 0, 13.052])


def test_working_state_tip_matches_spec() -> None:
    """SPEC: tip at (13.282, 0, 5.581) m in B at the working state."""
    np.testing.assert_allclose(
        HYBRID.end_effector(HYBRID.working_state)[:3, 3], [13.282, 0, 5.581], atol=1e-12
    )


def test_limits_are_table6_about_the_working_state() -> None:
    """Table 6 read relative to Table 5 (SPEC erratum 3): z_p 1.525-3.595 m equals d2 of Table 1."""
    np.testing.assert_allclose(
        HYBRID.lower,
        [-1.36, -1.15, 1.525, -30 * DEG, -30 * DEG, -36 * DEG, -30 * DEG, -30 * DEG, 9.552],
    )
    np.testing.assert_allclose(
        HYBRID.upper, [1.165, 1.15, 3.595, 30 * DEG, 30 * DEG, 36 * DEG, 30 * DEG, 30 * DEG, 16.552]
    )


def test_end_effector_composes_eq14(rng: np.random.Generator) -> None:
    """ᴮP_E = ᴮP_P + ᴮR_P ᴾP_E (eq (15)): a rotated platform carries the tip around with it."""
    xi = HYBRID.working_state.copy()
    xi[5] = 0.2  # platform yaw
    p = HYBRID.end_effector(xi)[:3, 3]
    c, s = np.cos(0.2), np.sin(0.2)
    np.testing.assert_allclose(p, [13.282 * c, 13.282 * s, 5.581], atol=1e-12)


def test_task_jacobian_equals_finite_difference(rng: np.random.Generator) -> None:
    """J_task (eq (24)) maps virtual-joint velocities to the tip twist in B."""
    h = 1e-6
    for xi in random_hybrid_states(rng, 30):
        J = HYBRID.task_jacobian(xi)
        for k in range(9):
            v = np.eye(9)[k]
            Tp = HYBRID.end_effector(HYBRID.integrate(xi, v, h))
            Tm = HYBRID.end_effector(HYBRID.integrate(xi, v, -h))
            np.testing.assert_allclose((Tp[:3, 3] - Tm[:3, 3]) / (2 * h), J[:3, k], atol=2e-6)
            np.testing.assert_allclose(
                so3_log(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * h), J[3:, k], atol=2e-6
            )


def test_platform_columns_are_body_velocities() -> None:
    """Columns 0-5 act in P: with the platform yawed 90°, ᴾṖ_x moves the tip along B's y."""
    xi = HYBRID.working_state.copy()
    xi[5] = np.pi / 2
    np.testing.assert_allclose(HYBRID.task_jacobian(xi)[:3, 0], [0, 1, 0], atol=1e-12)


def test_integrate_yaw_rate_is_exact() -> None:
    """A constant ω_z body rate for 1 s turns yaw by exactly ω (exponential map, not Euler sum)."""
    xi = HYBRID.working_state.copy()
    xi[3] = 0.1  # rolled platform: Euler-rate addition would be wrong here
    out = HYBRID.integrate(xi, [0, 0, 0, 0, 0, 0.3, 0, 0, 0], 1.0)
    R0 = HYBRID.end_effector(xi)[:3, :3] @ HYBRID.gangway.forward(xi[6:])[:3, :3].T
    R1 = HYBRID.end_effector(out)[:3, :3] @ HYBRID.gangway.forward(out[6:])[:3, :3].T
    np.testing.assert_allclose(so3_log(R0.T @ R1), [0, 0, 0.3], atol=1e-12)


def test_leg_lengths_and_limits_at_table5_states() -> None:
    """At the working state every leg is 3.2335 m and within limits; a telescope 4 m longer is
    not."""
    np.testing.assert_allclose(HYBRID.leg_lengths(HYBRID.working_state), 3.2335, atol=5e-5)
    assert HYBRID.within_limits(HYBRID.working_state)
    assert not HYBRID.within_limits(HYBRID.working_state + np.r_[0, 0, 0, 0, 0, 0, 0, 0, 4.0])


def test_bad_state_shape() -> None:
    """A state of the wrong shape or not finite raises ValueError naming the problem."""
    with pytest.raises(ValueError, match=r"xi must have shape \(\.\.\., 9\)"):
        HYBRID.end_effector(np.zeros(8))
    with pytest.raises(ValueError, match="finite"):
        HYBRID.task_jacobian(np.full(9, np.inf))


def test_batched_equals_single(rng: np.random.Generator) -> None:
    """Every method accepts a leading batch axis and gives the per-sample results."""
    xs = random_hybrid_states(rng, 5)
    batch = HYBRID.task_jacobian(xs)
    for x, J in zip(xs, batch, strict=True):
        np.testing.assert_array_equal(HYBRID.task_jacobian(x), J)

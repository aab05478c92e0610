"""The Newton-Raphson lanes (twin/mechanisms/newton.py) every mechanism's forward kinematics runs,
and the Stewart platform's own lane, held to checks that share none of their code: numpy's
LAPACK solves, central finite differences and hand-made cases of each outcome."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import random_hybrid_states
from twin.errors import ConvergenceError
from twin.mechanisms import HybridBoardingSystem, Upr4, Upu3Up, platforms
from twin.mechanisms.newton import (
    CONVERGED,
    NOT_FINITE,
    SINGULAR,
    STEPPED,
    least_squares_lane,
    newton_step_lane,
    solve_lane,
)

STEWART = HybridBoardingSystem().stewart


def test_solve_lane_is_lapack_at_every_size(rng: np.random.Generator) -> None:
    """n × n for n = 1 … 6 (the Stewart's 6 × 6 included): `np.linalg.solve` to rounding; the
    square least-squares step is the solve itself."""
    for n in range(1, 7):
        for _ in range(20):
            A, b = rng.normal(size=(n, n)), rng.normal(size=n)
            x = np.zeros(n)
            assert solve_lane(np.c_[A, b], x)
            np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-9, atol=1e-12)
            y = np.zeros(n)
            assert least_squares_lane(A, b, n, np.zeros((n, n + 1)), y)
            np.testing.assert_allclose(y, x, rtol=1e-9, atol=1e-12)


def test_newton_step_outcomes() -> None:
    """A non-finite residual and a singular J stop without stepping; a small residual with a
    large step converges only without a step test."""
    J, M, step = np.eye(3), np.zeros((3, 4)), np.zeros(3)
    x = np.ones(3)
    assert (
        newton_step_lane(np.array([0.0, np.nan, 0.0]), J, 3, 1.0, np.inf, M, step, x) == NOT_FINITE
    )
    assert newton_step_lane(np.ones(3), np.zeros((3, 3)), 3, 1.0, np.inf, M, step, x) == SINGULAR
    np.testing.assert_array_equal(x, 1.0)  # untouched
    r = np.full(3, 0.5)  # |r| ≤ tol 1, |Δ| = 0.5 > step_tol 0.1
    assert newton_step_lane(r, J, 3, 1.0, 0.1, M, step, x) == STEPPED
    np.testing.assert_array_equal(x, 0.5)
    assert newton_step_lane(r, J, 3, 1.0, np.inf, M, step, x) == CONVERGED
    np.testing.assert_array_equal(x, 0.0)
    assert newton_step_lane(r, J, 3, 0.1, np.inf, M, step, x) == STEPPED


def test_stewart_pose_jacobian_is_the_central_difference(rng: np.random.Generator) -> None:
    """∂l/∂[x, y, z, roll, pitch, yaw] of `stewart_kinematics_lane` by central differences of
    the leg lengths."""
    h = 1e-6
    for pose in random_hybrid_states(rng, 20)[:, :6]:
        J = STEWART.pose_jacobian(pose)
        for k in range(6):
            dp = np.eye(6)[k] * h
            fd = (STEWART.leg_lengths(pose + dp) - STEWART.leg_lengths(pose - dp)) / (2 * h)
            np.testing.assert_allclose(J[:, k], fd, atol=1e-7)


def test_forward_solves_each_lane_on_its_own(rng: np.random.Generator) -> None:
    """A batch whose lanes start near and far: each converges in its own number of steps (the
    near ones in fewer), and every lane's lengths are met to tol."""
    upu = Upu3Up()
    low, high = upu.state_limits
    states = low + rng.uniform(0.2, 0.8, (6, 3)) * (high - low)
    lengths = upu.leg_lengths(*states.T)
    guesses = np.where(np.arange(6)[:, None] < 3, states + 1e-3, 0.0)
    result = platforms.forward(upu.pack(), lengths, guesses, 1e-10, 30, np.inf)
    assert result.converged and result.solved.shape == (6,) and np.all(result.solved)
    np.testing.assert_allclose(upu.leg_lengths(*result.x.T), lengths, rtol=0, atol=1e-10)
    near = platforms.forward(upu.pack(), lengths[:3], guesses[:3], 1e-10, 30, np.inf)
    assert near.iterations < result.iterations


def test_one_lane_failing_fails_the_batch() -> None:
    """One lane of lengths no state meets makes the batch's forward raise, the others' roots
    notwithstanding; its flag alone is down."""
    upr = Upr4()
    good = upr.leg_lengths(0.5, 0.05, -0.05)
    lengths = np.stack([good, [0.9, 0.9, 0.9, 0.91], good])
    result = platforms.forward(upr.pack(), lengths, np.array([0.5, 0.0, 0.0]), 1e-10, 30, 1e-10)
    np.testing.assert_array_equal(result.solved, [True, False, True])
    with pytest.raises(ConvergenceError):
        level = STEWART.leg_lengths([0, 0, 3.3, 0, 0, 0])
        far = [[0, 0, 3.3, 0, 0, 0], [0, 0, 2.0, 0.5, 0, 0]]
        STEWART.forward(np.stack([level, level]), guess=far, max_iter=2)

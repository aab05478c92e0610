"""The small platforms' lane functions (twin/mechanisms/platforms.py), the engine's kinematics.

The mechanism objects and the engine's kernel both run these; here they are held to checks
that share none of their code: the closed-vector leg equations written out, central finite
differences, round trips, and numpy's LAPACK solves.
"""

from __future__ import annotations

import numpy as np
import pytest

from twin.mechanisms import Upr4, Upu3Up
from twin.mechanisms import platforms as lanes
from twin.mechanisms.newton import least_squares_lane, solve_lane

MECHANISMS = {"upu3up": Upu3Up, "upr4": Upr4}


def random_states(name: str, rng: np.random.Generator, n: int) -> np.ndarray:
    """n states (n, 3) well inside the mechanism's state box (Upr4: around its home height)."""
    low, high = MECHANISMS[name]().state_limits
    if name == "upr4":
        low, high = np.array([0.45, -0.3, -0.3]), np.array([0.6, 0.3, 0.3])
    return rng.uniform(0.8 * low + 0.2 * high, 0.2 * low + 0.8 * high, size=(n, 3))


def closed_vector_lengths(name: str, state: np.ndarray) -> np.ndarray:
    """Leg lengths written out from the papers, apart from the package's code: seed 001 eq
    (26) hinges with R = Rx(α)·Ry(β) and O1 = (l + z) R e_z (eqs (11), (13), (16)-(18));
    seed 002 eqs (1)-(2) squares with R = Ry(pitch)·Rx(roll), P = (0, 0, z) (eqs (15)-(18))."""
    z, a, b = state
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    if name == "upu3up":
        Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
        d, l = 990.0, 1040.0
        r3 = np.sqrt(3.0)
        hinges = np.array([[r3 / 3 * d, 0, 0], [-r3 / 6 * d, d / 2, 0], [-r3 / 6 * d, -d / 2, 0]])
        R = Rx @ Ry
        centre = (l + z) * R[:, 2]
        return np.linalg.norm(hinges @ R.T + centre - hinges, axis=-1)
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    signs = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]], dtype=float)
    top = np.c_[signs * 0.2 / 2, np.zeros(4)]
    base = np.c_[signs * 1.25 / 2, np.zeros(4)]
    return np.linalg.norm(top @ (Ry @ Rx).T + np.array([0.0, 0.0, z]) - base, axis=-1)


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_leg_lengths_are_the_closed_vector_equations(name: str, rng: np.random.Generator) -> None:
    """`platform_kinematics` gives the papers' leg lengths, written out independently."""
    geometry = MECHANISMS[name]().pack()
    states = random_states(name, rng, 50)
    expected = np.array([closed_vector_lengths(name, s) for s in states])
    np.testing.assert_allclose(lanes.leg_lengths(geometry, states), expected, rtol=1e-13)


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_jacobian_equals_central_differences(name: str, rng: np.random.Generator) -> None:
    """∂l/∂state of `platform_kinematics` equals central differences of its lengths."""
    geometry = MECHANISMS[name]().pack()
    h = np.array([1e-4, 1e-7, 1e-7]) * (1.0 if name == "upu3up" else 1e-2)
    for state in random_states(name, rng, 10):
        steps = np.diag(h)
        forward = lanes.leg_lengths(geometry, state + steps)  # (3, n)
        backward = lanes.leg_lengths(geometry, state - steps)
        expected = ((forward - backward) / (2 * h[:, None])).T
        scale = np.abs(expected).max()
        np.testing.assert_allclose(lanes.jacobian(geometry, state), expected, atol=1e-6 * scale)


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_fit_inverts_leg_lengths(name: str, rng: np.random.Generator) -> None:
    """`platform_fit` finds the state of its own lengths from the working state."""
    mechanism = MECHANISMS[name]()
    geometry = mechanism.pack()
    states = random_states(name, rng, 40)
    found, ok = lanes.fit(geometry, lanes.leg_lengths(geometry, states), mechanism.working_state)
    assert ok.all()
    np.testing.assert_allclose(found, states, atol=1e-9)


def test_fit_fails_on_lengths_outside_the_stroke() -> None:
    """The Upu3Up's fit refuses lengths beyond its stroke, as `Upu3Up.forward` does."""
    mechanism = Upu3Up()
    lengths = np.array([[mechanism.leg_max + 1.0, 1040.0, 1040.0], [1040.0, 1040.0, 1040.0]])
    _, ok = lanes.fit(mechanism.pack(), lengths, np.zeros(3))
    np.testing.assert_array_equal(ok, [False, True])


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_compiled_batch_and_plain_python_agree(name: str, rng: np.random.Generator) -> None:
    """The compiled batch loops give the plain-Python loop's numbers (the interpreted engine)."""
    mechanism = MECHANISMS[name]()
    geometry = mechanism.pack()
    states = random_states(name, rng, 20)
    n = int(geometry[0]["n_legs"])
    plain_lengths, plain_J = np.zeros((20, lanes.MAX_LEGS)), np.zeros((20, lanes.MAX_LEGS, 3))
    lanes.kinematics_lanes(states, geometry, plain_lengths, plain_J, True)
    lengths = lanes.leg_lengths(geometry, states)
    np.testing.assert_allclose(lengths, plain_lengths[:, :n], rtol=1e-14)
    np.testing.assert_allclose(lanes.jacobian(geometry, states), plain_J[:, :n], rtol=1e-12)
    x, ok = np.zeros((20, 3)), np.zeros(20, dtype=np.bool_)
    lanes.fit_lanes(plain_lengths[:, :n].copy(), states + 0.01, geometry, x, ok)
    compiled_x, compiled_ok = lanes.fit(geometry, plain_lengths[:, :n], states + 0.01)
    np.testing.assert_array_equal(compiled_ok, ok)
    np.testing.assert_allclose(compiled_x, x, atol=1e-12)


def test_solves_match_lapack(rng: np.random.Generator) -> None:
    """`solve_lane` (3 × 3) is `np.linalg.solve`, `least_squares_lane` (4 × 3) `np.linalg.lstsq`, to
    rounding; a singular system is refused."""
    for _ in range(50):
        A, b = rng.normal(size=(3, 3)), rng.normal(size=3)
        x = np.zeros(3)
        assert solve_lane(np.c_[A, b], x)
        np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-9, atol=1e-12)
        J, r = rng.normal(size=(4, 3)), rng.normal(size=4)
        assert least_squares_lane(J, r, 4, np.zeros((3, 4)), x)
        np.testing.assert_allclose(x, np.linalg.lstsq(J, r, rcond=None)[0], rtol=1e-9, atol=1e-12)
    singular = np.array([[1.0, 2.0, 3.0, 1.0], [2.0, 4.0, 6.0, 2.0], [0.0, 0.0, 1.0, 3.0]])
    x = np.full(3, 7.0)
    assert not solve_lane(singular, x)
    np.testing.assert_array_equal(x, 7.0)  # untouched

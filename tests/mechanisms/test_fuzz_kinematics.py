"""Property-based fuzzing of the kinematics of the three mechanisms (issue 8).

Random in-limit states give finite poses, Jacobians and manipulability and FK(IK(x)) = x;
random leg lengths inside the stroke, reachable or not, make forward kinematics either
converge to a pose whose legs have those lengths or raise a TwinError, in a bounded number
of iterations (no hang); bad input raises a ValueError that names the argument.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import event, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tests.figures import fuzz
from twin.errors import TwinError
from twin.mechanisms import HybridBoardingSystem, Upr4, Upu3Up
from twin.planners import HYBRID_RATE_LIMITS

H = HybridBoardingSystem()
STEWART, GANGWAY = H.stewart, H.gangway
UPU, UPR = Upu3Up(), Upr4()
SHRINK = np.linspace(1.0, 0.0, 41)[:, None]  # tried in turn until the state is feasible
FK_ROUND_TRIP = 1e-8  # [m, rad | mm, rad] FK(IK(x)) = x
FK_RESIDUAL = 1e-6  # [m | mm] IK(FK(L)) = L when FK converges


def finite(low: float, high: float) -> st.SearchStrategy[float]:
    return st.floats(low, high, allow_nan=False, allow_infinity=False)


def in_box(low: np.ndarray, high: np.ndarray) -> st.SearchStrategy[np.ndarray]:
    """Points of the box [low, high], corners and faces included."""
    unit = arrays(np.float64, np.shape(low), elements=finite(0.0, 1.0))
    return unit.map(lambda u: low + u * (high - low))


def pulled_in(box: np.ndarray, centre: np.ndarray, feasible: Callable) -> np.ndarray:
    """The first of centre + s (box − centre), s = 1, 0.975, …, 0, that is `feasible`."""
    candidates = centre + SHRINK * (box - centre)
    return candidates[np.argmax(feasible(candidates))]


def hybrid_states() -> st.SearchStrategy[np.ndarray]:
    """xi (9,) inside Table 6 and every leg inside Table 1: a point of the Table 6 box, its
    pose pulled towards the working pose until the legs fit; gangway joints anywhere."""
    w = H.working_state

    def inside(xi: np.ndarray) -> np.ndarray:
        pose = pulled_in(xi[:6], w[:6], lambda p: STEWART.within_limits(STEWART.leg_lengths(p)))
        return np.r_[pose, xi[6:]]

    return in_box(H.lower, H.upper).map(inside)


def upu3up_states() -> st.SearchStrategy[np.ndarray]:
    """(z, α, β) (3,) [mm, rad, rad] anywhere in `state_limits`."""
    return in_box(*UPU.state_limits)


def upr4_states() -> st.SearchStrategy[np.ndarray]:
    """(z, roll, pitch) (3,) [m, rad, rad] violating no limit: a point of `state_limits`
    pulled towards the home pose until `feasible`."""
    return in_box(*UPR.state_limits).map(
        lambda x: pulled_in(x, UPR.working_state, lambda s: UPR.feasible(*s.T))
    )


def assert_rigid(T: np.ndarray) -> None:
    """A finite homogeneous transform (4, 4) with a proper rotation block."""
    assert np.all(np.isfinite(T))
    R = T[:3, :3]
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_array_equal(T[3], [0.0, 0.0, 0.0, 1.0])


def assert_forward_converges_or_raises(
    forward: Callable[[], np.ndarray], inverse: Callable[[np.ndarray], np.ndarray], lengths
) -> str:
    """FK either returns a finite state whose IK gives `lengths` back, or raises a
    TwinError; returns which, for `hypothesis.event`."""
    try:
        state = forward()
    except TwinError as error:
        return type(error).__name__
    assert np.all(np.isfinite(state))
    np.testing.assert_allclose(inverse(state), lengths, rtol=0, atol=FK_RESIDUAL)
    return "converged"


@fuzz(300)
@given(xi=hybrid_states())
def test_stewart_inverse_then_forward_returns_the_pose(xi: np.ndarray) -> None:
    """Legs inside the stroke, finite J_P and manipulability, FK(IK(pose)) = pose."""
    pose = xi[:6]
    lengths = STEWART.leg_lengths(pose, check=True)
    assert np.all(np.isfinite(lengths)) and STEWART.within_limits(lengths)
    assert np.all(np.isfinite(STEWART.jacobian(pose)))
    assert np.all(np.isfinite(STEWART.pose_jacobian(pose)))
    assert np.isfinite(STEWART.manipulability(pose)) and STEWART.manipulability(pose) >= 0
    np.testing.assert_allclose(STEWART.forward(lengths), pose, rtol=0, atol=FK_ROUND_TRIP)


@fuzz(300)
@given(
    lengths=arrays(np.float64, 6, elements=finite(STEWART.leg_min, STEWART.leg_max)),
    guess=st.none() | hybrid_states().map(lambda xi: xi[:6]),
    max_iter=st.integers(0, 30),
)
def test_stewart_forward_of_any_stroke_lengths_converges_or_raises(lengths, guess, max_iter):
    """Any six lengths in the stroke, any in-limit guess, any iteration budget: a pose with
    those legs (to 1e-6 m) or a TwinError, never a wrong pose or a hang."""
    outcome = assert_forward_converges_or_raises(
        lambda: STEWART.forward(lengths, guess, max_iter=max_iter), STEWART.leg_lengths, lengths
    )
    event(outcome)


@fuzz(200)
@given(q=in_box(GANGWAY.lower, GANGWAY.upper))
def test_gangway_inverse_then_forward_returns_the_joints(q: np.ndarray) -> None:
    """ᴾT_E is rigid, J_s finite, and the analytic inverse of the tip position is q."""
    T = GANGWAY.forward(q)
    assert_rigid(T)
    J = GANGWAY.jacobian(q)
    assert J.shape == (6, 3) and np.all(np.isfinite(J))
    assert np.linalg.matrix_rank(J) == 3  # no gangway singularity inside Table 6
    np.testing.assert_allclose(GANGWAY.inverse(T[:3, 3]), q, rtol=0, atol=1e-9)
    assert np.isfinite(GANGWAY.cylinder_length(q[1]))
    assert GANGWAY.luff_from_cylinder(GANGWAY.cylinder_length(q[1])) == pytest.approx(
        q[1], abs=1e-9
    )


@fuzz(200)
@given(xi=hybrid_states())
def test_hybrid_kinematics_are_finite(xi: np.ndarray) -> None:
    """End effector rigid, tip pose, J_task and manipulability finite; J_task's platform
    block [[R, −[Rp]×R], [0, R]] has determinant det(R)² = 1, so it never loses rank."""
    assert H.within_limits(xi)
    T = H.end_effector(xi)
    assert_rigid(T)
    assert np.all(np.isfinite(H.tip_pose(xi)))
    J = H.task_jacobian(xi)
    assert J.shape == (6, 9) and np.all(np.isfinite(J))
    assert np.linalg.det(J[:, :6]) == pytest.approx(1.0, abs=1e-9)
    m = H.manipulability(xi)
    assert np.isfinite(m) and m > 0


@fuzz(200)
@given(
    xi=hybrid_states(),
    unit=arrays(np.float64, 9, elements=finite(-1.0, 1.0)),
    dt=finite(0.005, 0.2),
)
def test_hybrid_integrate_is_finite_and_reversible(xi, unit, dt) -> None:
    """A rate-limited step is finite, and stepping back with −v returns to xi."""
    v = unit * HYBRID_RATE_LIMITS
    moved = H.integrate(xi, v, dt)
    assert moved.shape == (9,) and np.all(np.isfinite(moved))
    np.testing.assert_allclose(H.integrate(moved, -v, dt), xi, rtol=0, atol=1e-9)


@fuzz(200)
@given(state=upu3up_states())
def test_upu3up_inverse_then_forward_returns_the_state(state: np.ndarray) -> None:
    """Limbs inside their stroke, finite eq (24) Jacobian and poses, FK(IK(x)) = x."""
    lengths = UPU.leg_lengths(*state, check=True)
    assert np.all(np.isfinite(lengths))
    J = UPU.jacobian(*state)
    assert np.all(np.isfinite(J)) and abs(np.linalg.det(J)) > 0
    for out in (UPU.ideal_pose(*state), UPU.coupled_displacement(*state), UPU.platform_pose(state)):
        assert np.all(np.isfinite(out))
    np.testing.assert_allclose(UPU.forward(lengths), state, rtol=0, atol=FK_ROUND_TRIP)


@fuzz(300)
@given(
    lengths=arrays(np.float64, 3, elements=finite(UPU.leg_min, UPU.leg_max)),
    guess=st.none() | upu3up_states(),
    max_iter=st.integers(0, 30),
)
def test_upu3up_forward_of_any_stroke_lengths_converges_or_raises(lengths, guess, max_iter):
    """Any three lengths in the stroke: a state with those limbs (to 1e-6 mm) or a
    TwinError (ConvergenceError, UnreachableError beyond the state limits)."""
    outcome = assert_forward_converges_or_raises(
        lambda: UPU.forward(lengths, guess, max_iter=max_iter),
        lambda x: UPU.leg_lengths(*x),
        lengths,
    )
    event(outcome)


@fuzz(200)
@given(state=upr4_states(), rates=arrays(np.float64, 3, elements=finite(-1.0, 1.0)))
def test_upr4_inverse_then_forward_returns_the_state(state, rates) -> None:
    """Feasible states: limbs inside the stroke, finite Jacobian, joint angles and limb
    velocities (the limb lengths' central difference along ẋ), FK(IK(x)) = x."""
    lengths = UPR.leg_lengths(*state, check=True)
    assert np.all(np.isfinite(lengths))
    J = UPR.jacobian(*state)
    assert np.all(np.isfinite(J)) and np.linalg.matrix_rank(J) == 3
    angles = UPR.joint_angles(*state)
    assert all(np.all(np.isfinite(a)) for a in (angles.u_roll, angles.u_pitch, angles.r))
    velocities = UPR.limb_velocities(*state, *rates)
    h = 1e-7  # central difference of the limb lengths along the rates (eq (22) is l̇ = J ẋ)
    ahead, behind = UPR.leg_lengths(*(state + h * rates)), UPR.leg_lengths(*(state - h * rates))
    np.testing.assert_allclose(velocities, (ahead - behind) / (2 * h), atol=1e-7)
    np.testing.assert_allclose(UPR.forward(lengths), state, rtol=0, atol=FK_ROUND_TRIP)


@fuzz(200)
@given(
    lengths=arrays(np.float64, 4, elements=finite(UPR.stroke_min, UPR.stroke_max))
    | upr4_states().map(lambda s: UPR.leg_lengths(*s)),
    guess=st.none() | upr4_states(),
    max_iter=st.integers(0, 30),
)
def test_upr4_forward_of_any_stroke_lengths_converges_or_raises(lengths, guess, max_iter):
    """Any four lengths in the stroke (mostly inconsistent) or those of a feasible state:
    a state with those limbs (to 1e-6 m) or a TwinError."""
    outcome = assert_forward_converges_or_raises(
        lambda: UPR.forward(lengths, guess, max_iter=max_iter),
        lambda x: UPR.leg_lengths(*x),
        lengths,
    )
    event(outcome)


NONFINITE = st.sampled_from([np.nan, np.inf, -np.inf])
_XI = H.working_state


def _with(base: np.ndarray, index: int, value: float) -> np.ndarray:
    out = np.array(base, dtype=float)
    out[index] = value
    return out


# (name the message starts with, call with the bad value, bad values)
BAD_MECHANISM: list[tuple[str, Callable[[Any], Any], st.SearchStrategy]] = [
    ("pose", lambda v: STEWART.leg_lengths(_with(_XI[:6], 3, v)), NONFINITE),
    ("pose", lambda v: STEWART.leg_lengths(_with(_XI[:6], 2, v), check=True), finite(3.7, 1e3)),
    (
        "lengths",
        lambda v: STEWART.forward(_with(np.full(6, 3.0), 1, v)),
        NONFINITE | finite(-1e3, 2.579) | finite(4.181, 1e3),
    ),
    ("guess", lambda v: STEWART.forward(np.full(6, 3.0), _with(_XI[:6], 0, v)), NONFINITE),
    ("q", lambda v: GANGWAY.forward(_with(_XI[6:], 1, v)), NONFINITE),
    ("position", lambda v: GANGWAY.inverse([10.0, v, 3.0]), NONFINITE),
    ("position", lambda v: GANGWAY.inverse([v, 0.0, 3.0]), finite(17.0, 1e3)),
    ("xi", lambda v: H.end_effector(_with(_XI, 8, v)), NONFINITE),
    ("xi", lambda v: H.task_jacobian(_with(_XI, 7, v)), NONFINITE),
    ("xi", lambda v: H.manipulability(_with(_XI, 0, v)), NONFINITE),
    ("velocity", lambda v: H.integrate(_XI, _with(np.zeros(9), 4, v), 0.05), NONFINITE),
    ("dt", lambda v: H.integrate(_XI, np.ones(9), v), NONFINITE),
    ("z", lambda v: UPU.leg_lengths(v, 0.0, 0.0), NONFINITE),
    ("alpha", lambda v: UPU.jacobian(0.0, v, 0.0), NONFINITE),
    ("beta", lambda v: UPU.ideal_pose(0.0, 0.0, v), NONFINITE),
    (
        "lengths",
        lambda v: UPU.forward([1040.0, v, 1040.0]),
        NONFINITE | finite(-1e4, 619.9) | finite(1460.1, 1e5),
    ),
    ("guess", lambda v: UPU.forward([1040.0] * 3, [0.0, v, 0.0]), NONFINITE),
    ("state", lambda v: UPU.leg_lengths(v, 0.0, 0.0, check=True), finite(150.1, 400.0)),
    ("z", lambda v: UPR.leg_lengths(v, 0.0, 0.0), NONFINITE),
    ("roll", lambda v: UPR.jacobian(0.5, v, 0.0), NONFINITE),
    ("pitch", lambda v: UPR.joint_angles(0.5, 0.0, v), NONFINITE),
    ("z_dot", lambda v: UPR.limb_velocities(0.5, 0.0, 0.0, v, 0.0, 0.0), NONFINITE),
    (
        "lengths",
        lambda v: UPR.forward([0.8, 0.8, v, 0.8]),
        NONFINITE | finite(-10.0, 0.7224) | finite(1.1226, 10.0),
    ),
]


@fuzz(300)
@given(data=st.data())
def test_bad_mechanism_input_raises_a_value_error_naming_it(data: st.DataObject) -> None:
    """NaN, inf, lengths beyond the stroke or states beyond the limits: a ValueError whose
    message starts with the argument's name."""
    name, call, bad = data.draw(st.sampled_from(BAD_MECHANISM), label="argument")
    value = data.draw(bad, label=name)
    with pytest.raises(ValueError, match=rf"^{re.escape(name)}\b"):
        call(value)

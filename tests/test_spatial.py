"""`twin.spatial` against scipy's `Rotation` as an independent oracle: Z-Y-X roll-pitch-yaw,
rotation vectors, quaternions, rigid transforms, and the lanes equal to the batch functions."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from twin import spatial

finite = st.floats(-3.0, 3.0, allow_nan=False)
angles = arrays(np.float64, (3,), elements=finite)
#: pitch inside (−π/2, π/2), where roll-pitch-yaw is one-to-one
rpys = st.tuples(st.floats(-3.1, 3.1), st.floats(-1.5, 1.5), st.floats(-3.1, 3.1)).map(np.array)


@given(rpys)
def test_rpy_to_matrix_is_scipys_extrinsic_xyz(rpy: np.ndarray) -> None:
    """R = Rz(yaw) Ry(pitch) Rx(roll) is scipy's extrinsic 'xyz' (intrinsic 'ZYX') Euler
    rotation, and the lane writes the same matrix."""
    want = Rotation.from_euler("xyz", rpy).as_matrix()
    np.testing.assert_allclose(spatial.rpy_to_matrix(rpy), want, rtol=0, atol=1e-14)
    lane = np.empty((3, 3))
    spatial.rpy_to_matrix_lane(rpy[0], rpy[1], rpy[2], lane)
    np.testing.assert_allclose(lane, want, rtol=0, atol=1e-14)


@given(rpys)
def test_matrix_to_rpy_inverts_it_and_agrees_with_scipy(rpy: np.ndarray) -> None:
    """matrix_to_rpy (batch and lane) recovers the angles scipy reads off the same matrix."""
    R = Rotation.from_euler("xyz", rpy)
    want = R.as_euler("xyz")
    np.testing.assert_allclose(spatial.matrix_to_rpy(R.as_matrix()), want, rtol=0, atol=1e-9)
    lane = np.empty(3)
    spatial.matrix_to_rpy_lane(R.as_matrix(), lane)
    np.testing.assert_allclose(lane, want, rtol=0, atol=1e-9)


@given(arrays(np.float64, (3,), elements=st.floats(-3.0, 3.0)))
def test_so3_exp_and_log_are_scipys_rotation_vector(w: np.ndarray) -> None:
    """exp of a rotation vector is scipy's from_rotvec (batch and lane); log gives back the
    vector of angle ≤ π that scipy's as_rotvec gives."""
    want = Rotation.from_rotvec(w).as_matrix()
    np.testing.assert_allclose(spatial.so3_exp(w), want, rtol=0, atol=1e-13)
    lane = np.empty((3, 3))
    spatial.so3_exp_lane(w[0], w[1], w[2], lane)
    np.testing.assert_allclose(lane, want, rtol=0, atol=1e-13)
    rotvec = Rotation.from_matrix(want).as_rotvec()
    if np.linalg.norm(rotvec) < np.pi - 1e-6:  # at π the sign of the axis is either
        np.testing.assert_allclose(spatial.so3_log(want), rotvec, rtol=0, atol=1e-9)
        out = np.empty(3)
        spatial.so3_log_lane(want, out)
        np.testing.assert_allclose(out, rotvec, rtol=0, atol=1e-9)


@given(rpys)
def test_quaternion_is_scipys_up_to_sign(rpy: np.ndarray) -> None:
    """matrix_to_wxyz is scipy's quaternion (scalar first), with w ≥ 0."""
    R = Rotation.from_euler("xyz", rpy)
    x, y, z, w = R.as_quat()
    want = np.array([w, x, y, z]) * (1.0 if w >= 0 else -1.0)
    got = spatial.matrix_to_wxyz(R.as_matrix())
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


@given(rpys)
def test_the_rate_matrix_maps_angle_rates_to_the_angular_velocity(rpy: np.ndarray) -> None:
    """ω = E(rpy) d(rpy)/dt in the base frame: a central difference of scipy's rotations,
    log(R(t + h) R(t − h)ᵀ) / 2h, equals E times the angle rates."""
    rate, h = np.array([0.3, -0.2, 0.5]), 1e-6
    ahead = Rotation.from_euler("xyz", rpy + h * rate)
    behind = Rotation.from_euler("xyz", rpy - h * rate)
    omega = (ahead * behind.inv()).as_rotvec() / (2 * h)
    np.testing.assert_allclose(spatial.rpy_rate_matrix(rpy) @ rate, omega, rtol=0, atol=1e-7)


@given(rpys, arrays(np.float64, (3,), elements=finite))
def test_the_rates_lane_inverts_the_rate_matrix(rpy: np.ndarray, omega: np.ndarray) -> None:
    """rpy_rates_lane gives the angle rates whose E(rpy) image is ω (E⁻¹ ω)."""
    rates = np.array(spatial.rpy_rates_lane(rpy[1], rpy[2], *omega))
    np.testing.assert_allclose(spatial.rpy_rate_matrix(rpy) @ rates, omega, rtol=0, atol=1e-9)


@settings(max_examples=50)
@given(rpys, arrays(np.float64, (3,), elements=finite))
def test_transforms_compose_invert_and_round_trip(rpy: np.ndarray, p: np.ndarray) -> None:
    """pose → transform → pose round-trips; T T⁻¹ = I; se3_log inverts se3_exp; the lane of
    se3_log gives the batch function's twist."""
    pose = np.r_[p, rpy]
    T = spatial.pose_to_transform(pose)
    np.testing.assert_allclose(T[:3, :3], Rotation.from_euler("xyz", rpy).as_matrix(),
                               rtol=0, atol=1e-14)  # fmt: skip
    np.testing.assert_allclose(spatial.transform_to_pose(T), pose, rtol=0, atol=1e-9)
    np.testing.assert_allclose(T @ spatial.invert_transform(T), np.eye(4), rtol=0, atol=1e-12)
    twist = spatial.se3_log(T)
    np.testing.assert_allclose(spatial.se3_exp(twist), T, rtol=0, atol=1e-9)
    out = np.empty(6)
    spatial.se3_log_lane(T[:3, :3], T[:3, 3], out)
    np.testing.assert_allclose(out, twist, rtol=0, atol=1e-9)


def test_batches_are_each_element() -> None:
    """A (4, 5, 3) batch of angles gives each element's matrix and back."""
    rng = np.random.default_rng(7)
    rpy = rng.uniform([-3, -1.5, -3], [3, 1.5, 3], size=(4, 5, 3))
    R = spatial.rpy_to_matrix(rpy)
    assert R.shape == (4, 5, 3, 3)
    for idx in np.ndindex(4, 5):
        np.testing.assert_array_equal(R[idx], spatial.rpy_to_matrix(rpy[idx]))
    np.testing.assert_allclose(spatial.matrix_to_rpy(R), rpy, rtol=0, atol=1e-12)


@pytest.mark.parametrize("angle", [np.pi, np.pi - 1e-7])
def test_log_near_a_half_turn_keeps_the_angle(angle: float) -> None:
    """At and just below π, log(R) has norm the angle and exp(log R) = R, to the 1e-8 that
    arccos of a cosine near −1 resolves (√ε: the angle comes from the trace)."""
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    R = Rotation.from_rotvec(angle * axis).as_matrix()
    w = spatial.so3_log(R)
    assert np.linalg.norm(w) == pytest.approx(angle, abs=1e-8)
    np.testing.assert_allclose(spatial.so3_exp(w), R, rtol=0, atol=1e-8)


@given(rpys)
def test_the_tilt_is_the_angle_of_the_body_z_axis_from_z_up(rpy: np.ndarray) -> None:
    """tilt_lane (and TILT over arrays) of R e_z is scipy's rotation angle between R e_z and
    e_z: the smallest rotation that takes one to the other."""
    axis = Rotation.from_euler("xyz", rpy).as_matrix()[:, 2]
    want = Rotation.align_vectors([axis], [[0.0, 0.0, 1.0]])[0].magnitude()
    assert abs(spatial.tilt_lane(*axis) - want) <= 1e-9
    assert abs(float(spatial.TILT(*axis)) - want) <= 1e-9


def exact_v_inverse_coefficient(theta: float) -> Fraction:
    """d(θ) = (1 − (θ/2)cot(θ/2))/θ² in exact rationals, from x cot x's Bernoulli series
    (15 terms: converged to far below a double's ulp for θ ≤ 2)."""
    bernoulli = [Fraction(1, 6), Fraction(-1, 30), Fraction(1, 42), Fraction(-1, 30),
                 Fraction(5, 66), Fraction(-691, 2730), Fraction(7, 6), Fraction(-3617, 510),
                 Fraction(43867, 798), Fraction(-174611, 330), Fraction(854513, 138),
                 Fraction(-236364091, 2730), Fraction(8553103, 6),
                 Fraction(-23749461029, 870), Fraction(8615841276005, 14322)]  # fmt: skip
    t = Fraction(theta)
    series = sum(
        (-1) ** n * b * t ** (2 * n) / math.factorial(2 * n)
        for n, b in enumerate(bernoulli, start=1)
    )
    return -series / t**2


def test_the_v_inverse_coefficient_is_accurate_at_every_angle() -> None:
    """d(θ) of se3_log's V⁻¹ is within 5e-13 (relative) of its exact value from 1e-8 to 2 rad,
    either side of the series' switch (the old closed form lost 1e-7 just above 1e-6 rad)."""
    for theta in np.logspace(-8, np.log10(2.0), 600):
        exact = exact_v_inverse_coefficient(float(theta))
        got = spatial.v_inverse_coefficient(float(theta))
        assert abs(Fraction(got) - exact) / exact < 5e-13, theta


@pytest.mark.parametrize("angle", [1e-7, 1e-6, 3e-6, 1e-5, 1e-4, 1e-3, 1e-2, 0.1])
def test_se3_log_inverts_se3_exp_at_small_angles(angle: float) -> None:
    """A metre's translation with a small rotation: exp(log T) = T to 1e-13, by the batch
    function and the lane alike (the old switch at 1e-6 rad gave 8e-8 m at 1e-5 rad)."""
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    T = spatial.se3_exp(np.r_[0.6, -0.7, 0.4, angle * axis])
    twist = spatial.se3_log(T)
    np.testing.assert_allclose(spatial.se3_exp(twist), T, rtol=0, atol=1e-13)
    out = np.empty(6)
    spatial.se3_log_lane(T[:3, :3], T[:3, 3], out)
    np.testing.assert_allclose(spatial.se3_exp(out), T, rtol=0, atol=1e-13)


def test_the_rodrigues_coefficients_are_accurate_at_every_angle() -> None:
    """a, b, c of so3_exp / se3_exp are within 1e-13 (relative) of their exact values (Taylor
    series in exact rationals) from 1e-9 to 1 rad: b no longer loses ε/θ² to 1 − cos θ."""
    for theta in np.logspace(-9, 0, 400):
        t = Fraction(float(theta))
        exact = [sum((-1) ** n * t ** (2 * n) / math.factorial(2 * n + k) for n in range(12))
                 for k in (1, 2, 3)]  # fmt: skip
        for got, want in zip(spatial.rodrigues_coefficients(float(theta)), exact, strict=True):
            assert abs(Fraction(got) - want) / want < 1e-13, theta

"""Vessel motion through RAOs and the pose of a mechanism base (twin/vessel/motion.py)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import TwinError
from twin.sea.components import G, WaveComponents
from twin.spatial import rpy_to_matrix
from twin.vessel import (
    DOFS,
    MOUNTS,
    base_pose,
    encounter_frequency,
    equilibrium_to_world,
    interpolate_raos,
    load_raos,
    vessel_motion,
)

SOV = load_raos("sov")
HEAVE = DOFS.index("heave")


def random_sea(seed: int, n: int = 40) -> WaveComponents:
    """A short-crested sea: n components, 0.3-1.5 rad/s, all directions."""
    rng = np.random.default_rng(seed)
    return WaveComponents(
        omega=rng.uniform(0.3, 1.5, n),
        amplitude=rng.uniform(0.0, 0.3, n),
        phase=rng.uniform(0.0, 2 * np.pi, n),
        direction=rng.uniform(0.0, 2 * np.pi, n),
    )


def regular(omega: float, amplitude: float, direction: float, phase: float = 0.0):
    """One regular wave."""
    return WaveComponents(
        np.array([omega]), np.array([amplitude]), np.array([phase]), np.array([direction])
    )


def test_motion_is_reproducible_and_streams_without_a_jump() -> None:
    """Same inputs → same record; chunks of the time axis join into the full record."""
    sea, t = random_sea(0), np.arange(0.0, 100.0, 0.05)
    full = vessel_motion(sea, SOV, t, heading=0.3, speed=2.0)
    np.testing.assert_array_equal(full, vessel_motion(sea, SOV, t, heading=0.3, speed=2.0))
    chunks = [vessel_motion(sea, SOV, c, heading=0.3, speed=2.0) for c in np.array_split(t, 7)]
    np.testing.assert_allclose(np.concatenate(chunks), full, atol=1e-12)
    assert full.shape == (t.size, 6)


def test_motion_is_linear_in_the_waves() -> None:
    """Doubling every amplitude doubles the motion; two seas superpose."""
    a, b, t = random_sea(1), random_sea(2), np.linspace(0.0, 60.0, 301)
    double = WaveComponents(a.omega, 2 * a.amplitude, a.phase, a.direction)
    np.testing.assert_allclose(
        vessel_motion(double, SOV, t), 2 * vessel_motion(a, SOV, t), atol=1e-12
    )
    both = WaveComponents(
        *(np.r_[getattr(a, f), getattr(b, f)] for f in ("omega", "amplitude", "phase", "direction"))
    )
    np.testing.assert_allclose(
        vessel_motion(both, SOV, t), vessel_motion(a, SOV, t) + vessel_motion(b, SOV, t), atol=1e-12
    )


def test_regular_wave_response_is_the_rao() -> None:
    """x(t) = Re(H a e^{iε} e^{-iωt}) at U = 0 (Capytaine's phase convention)."""
    omega, a, eps, beta = 0.7, 1.5, 0.4, np.radians(120.0)
    t = np.linspace(0.0, 30.0, 200)
    H = interpolate_raos(SOV, omega, beta)
    expected = (H[None, :] * a * np.exp(1j * (eps - omega * t))[:, None]).real
    np.testing.assert_allclose(
        vessel_motion(regular(omega, a, beta, eps), SOV, t), expected, atol=1e-12
    )


def test_heading_sets_the_relative_direction() -> None:
    """A wave towards world direction μ meets a vessel heading μ + π head on: no sway/roll/yaw."""
    mu = np.radians(37.0)
    motion = vessel_motion(regular(0.8, 1.0, mu), SOV, np.linspace(0, 40, 100), heading=mu + np.pi)
    lateral = np.abs(motion[:, [1, 3, 5]]).max()
    assert lateral < 1e-6 * np.abs(motion[:, HEAVE]).max()


def test_encounter_frequency_signs() -> None:
    """ω_e = ω − kU cos β: lower in following seas (β = 0), higher in head seas (β = π)."""
    omega, U = 0.8, 5.0
    k = omega**2 / G
    assert encounter_frequency(omega, 0.0, U) == pytest.approx(omega - k * U)
    assert encounter_frequency(omega, np.pi, U) == pytest.approx(omega + k * U)
    assert encounter_frequency(omega, np.pi / 2, U) == pytest.approx(omega)


def test_following_sea_response_repeats_at_the_encounter_period() -> None:
    """Following seas at U = ω/(2k): the motion repeats every 2π/ω_e = 2 × 2π/ω, not every 2π/ω."""
    omega = 0.8
    speed = omega / (2 * omega**2 / G)
    omega_e = encounter_frequency(omega, 0.0, speed)
    assert omega_e == pytest.approx(omega / 2)
    wave = regular(omega, 1.0, 0.0)
    t = np.linspace(0.0, 50.0, 101)
    x = vessel_motion(wave, SOV, t, speed=speed)[:, HEAVE]
    np.testing.assert_allclose(
        vessel_motion(wave, SOV, t + 2 * np.pi / omega_e, speed=speed)[:, HEAVE], x, atol=1e-12
    )
    assert (
        np.abs(vessel_motion(wave, SOV, t + 2 * np.pi / omega, speed=speed)[:, HEAVE] - x).max()
        > 0.1
    )
    H = interpolate_raos(SOV, omega_e, 0.0)[HEAVE]
    np.testing.assert_allclose(x, (H * np.exp(-1j * omega_e * t)).real, atol=1e-12)


def test_overtaken_wave_uses_the_conjugate_rao() -> None:
    """ω_e < 0 (vessel overtakes a following wave): response H(−ω) = conj H(|ω|), still real."""
    omega = 0.8
    speed = 2 * omega / (omega**2 / G)  # ω_e = −ω
    t = np.linspace(0.0, 30.0, 61)
    x = vessel_motion(regular(omega, 1.0, 0.0), SOV, t, speed=speed)
    H = interpolate_raos(SOV, omega, 0.0)
    np.testing.assert_allclose(
        x, (np.conj(H)[None] * np.exp(1j * omega * t)[:, None]).real, atol=1e-12
    )


def test_pure_roll_moves_an_offset_base_by_R_r_minus_r() -> None:
    """Roll φ about the centre of motion moves the base at r to Rx(φ) r and tilts it by φ."""
    phi = np.radians([-8.0, 0.0, 5.0])
    motion = np.zeros((3, 6))
    motion[:, 3] = phi
    r = np.array(MOUNTS["hybrid"].lever_arm)
    pose = MOUNTS["hybrid"].pose(motion)
    R = rpy_to_matrix(motion[:, 3:])
    np.testing.assert_allclose(pose[:, :3] - r, (R @ r) - r, atol=1e-12)
    assert pose[0, 1] - r[1] == pytest.approx(np.cos(phi[0]) * r[1] - np.sin(phi[0]) * r[2] - r[1])
    mount = rpy_to_matrix(np.array([0.0, 0.0, MOUNTS["hybrid"].yaw]))
    np.testing.assert_allclose(rpy_to_matrix(pose[:, 3:]), R @ mount, atol=1e-12)


def test_base_at_rest_sits_at_its_lever_arm() -> None:
    """Zero motion: base pose = (r, 0, 0, mount yaw)."""
    pose = base_pose(np.zeros((1, 6)), [1.0, -2.0, 3.0], -np.pi / 2)
    np.testing.assert_allclose(pose[0], [1.0, -2.0, 3.0, 0.0, 0.0, -np.pi / 2], atol=1e-15)


def test_translation_and_small_rotation_add_to_first_order() -> None:
    """Base displacement ≈ vessel translation + ω × r for small motions (rigid-body kinematics)."""
    motion = np.array([[0.3, -0.2, 0.5, 0.01, -0.02, 0.015]])
    r = np.array([10.0, -5.0, 8.0])
    pose = base_pose(motion, r)
    linear = motion[0, :3] + np.cross(motion[0, 3:], r)
    np.testing.assert_allclose(pose[0, :3] - r, linear, atol=5e-3)


def test_equilibrium_frame_travels_along_the_heading() -> None:
    """A pose at rest in the equilibrium frame moves at U along ψ in the world, yawed by ψ."""
    t = np.array([0.0, 10.0])
    world = equilibrium_to_world(np.zeros((2, 6)), t, heading=np.pi / 6, speed=3.0)
    np.testing.assert_allclose(world[1, :3], [30 * np.cos(np.pi / 6), 30 * np.sin(np.pi / 6), 0.0])
    np.testing.assert_allclose(world[:, 5], np.pi / 6)


def test_presets_name_shipped_vessels() -> None:
    """Each mount preset's vessel has an RAO table; the hybrid gangway points to starboard."""
    for mount in MOUNTS.values():
        load_raos(mount.vessel)
    assert MOUNTS["hybrid"].yaw == pytest.approx(-np.pi / 2)


def test_bad_inputs_raise_twin_error() -> None:
    """NaN or 2-D times, a NaN heading and a wrong lever arm are refused by name."""
    sea = random_sea(3)
    with pytest.raises(TwinError, match="t must be finite"):
        vessel_motion(sea, SOV, [0.0, np.nan])
    with pytest.raises(TwinError, match="t must be 1-D"):
        vessel_motion(sea, SOV, np.zeros((2, 2)))
    with pytest.raises(TwinError, match="heading must be finite"):
        vessel_motion(sea, SOV, [0.0], heading=np.nan)
    with pytest.raises(TwinError, match=r"lever_arm must have shape \(\.\.\., 3\)"):
        base_pose(np.zeros((1, 6)), [1.0, 2.0])

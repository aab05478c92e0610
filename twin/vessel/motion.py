r"""Vessel motion from the sea through RAOs, and the pose of a mechanism base on the vessel.

Frames (all z up, SPEC erratum 12):

- *world*: the sea's inertial frame, the one `WaveComponents` directions refer to.
- *equilibrium frame*: inertial, translating with the vessel's mean velocity, x along its mean
  heading ψ, y to port, origin at the mean position of the centre of motion; it coincides with
  the world frame rotated by ψ about z and passes the world origin at t = 0. Linear seakeeping
  motions are small displacements in this frame, and a mechanism base mounted on the vessel
  has its mean pose fixed in it. `equilibrium_to_world` places either in the world.
- *vessel frame*: fixed to the hull (x bow, y port, z up), origin at the centre of motion.

A wave travelling towards world direction μ meets the vessel at the relative direction
β = μ − ψ (0 following seas, π head seas). With forward speed U along the heading, the
vessel sees it at the encounter frequency :math:`\omega_e = \omega - k U \cos\beta`
(deep water k = ω²/g): following seas (cos β > 0) are met more slowly, head seas faster. The
RAO is evaluated at |ω_e| and β — the zero-speed RAO at the encounter frequency, the usual
approximation when only zero-speed hydrodynamics are tabulated — and the phase advances at
ω_e. Where ω_e < 0 (a following wave overtaken by the vessel) the response uses
:math:`H(-\omega) = \overline{H(\omega)}`, which holds for any real linear system.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twin.errors import TwinError
from twin.sea.components import G, WaveComponents
from twin.spatial import pose_to_transform, transform_to_pose
from twin.validation import as_array
from twin.vessel.rao import RaoTable, interpolate_raos

_BLOCK = 1 << 22  # complex entries per time block of the (samples × components) phase matrix


def encounter_frequency(omega: ArrayLike, wave_direction: ArrayLike, speed: float) -> np.ndarray:
    r"""ω_e = ω − k U cos β [rad/s], deep water k = ω²/g.

    Args:
        omega: (...) [rad/s] wave frequencies.
        wave_direction: (...) [rad] relative direction β (0 following, π head seas).
        speed: [m/s] forward speed U along the heading.
    """
    omega = np.asarray(omega, dtype=float)
    return omega - omega**2 / G * speed * np.cos(wave_direction)


def response_amplitudes(
    components: WaveComponents, raos: RaoTable, heading: float = 0.0, speed: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Each component's encounter frequency and complex response, the terms `vessel_motion` sums.

    Args:
        components: the sea, directions in the world frame.
        raos: the vessel's RAO table.
        heading: [rad] ψ as in `vessel_motion`.
        speed: [m/s] U as in `vessel_motion`.

    Returns:
        omega_e (K,) [rad/s] and amplitude (K, 6) complex [m, rad] with
        x_j(t) = Σ_i Re(amplitude_ij e^{-i ω_e,i t}).
    """
    heading = float(as_array(heading, "heading"))
    speed = float(as_array(speed, "speed"))
    beta = components.direction - heading
    omega_e = encounter_frequency(components.omega, beta, speed)
    H = interpolate_raos(raos, np.abs(omega_e), beta)  # (K, 6)
    H = np.where((omega_e < 0)[:, None], np.conj(H), H)
    return omega_e, (components.amplitude * np.exp(1j * components.phase))[:, None] * H


def vessel_motion(
    components: WaveComponents,
    raos: RaoTable,
    t: ArrayLike,
    heading: float = 0.0,
    speed: float = 0.0,
) -> np.ndarray:
    r"""6-DOF motion of the centre of motion, linear superposition of the components' responses.

    :math:`x_j(t) = \sum_i \Re\big(H_j(|\omega_{e,i}|, \beta_i)^{(*)}\, a_i e^{i\varepsilon_i}
    e^{-i\omega_{e,i} t}\big)` with β_i = μ_i − ψ and the conjugate (*) where ω_e < 0
    (module docstring). Deterministic: the same inputs give the same record, and any set of
    times (e.g. successive chunks of a live loop) joins without a jump.

    Args:
        components: the sea, directions in the world frame.
        raos: the vessel's RAO table.
        t: (N,) [s] times.
        heading: [rad] ψ, the direction the bow points in the world frame, from +x CCW.
        speed: [m/s] U, forward speed along the heading.

    Returns:
        motion: (N, 6) [m, rad] surge, sway, heave, roll, pitch, yaw in the equilibrium frame
            (z up, x along the heading); small angles, read as Z-Y-X angles by `base_pose`.
    """
    t = as_array(t, "t")
    if t.ndim != 1:
        raise TwinError(f"t must be 1-D (N,) [s], got shape {t.shape}")
    omega_e, amplitude = response_amplitudes(components, raos, heading, speed)
    return superpose(t, omega_e, amplitude)


def superpose(t: np.ndarray, omega_e: np.ndarray, amplitude: np.ndarray) -> np.ndarray:
    """x_d(t) = Re Σ_j H_jd e^{−iω_j t} (`vessel_motion`), (N, 6) [m, rad], from the response
    terms of `response_amplitudes`: t (N,) [s], omega_e (K,) [rad/s], amplitude (K, 6)."""
    rows = max(1, _BLOCK // max(1, omega_e.size))  # bounds the (rows, K) phasor table
    blocks = [
        (np.exp(-1j * np.outer(t[s : s + rows], omega_e)) @ amplitude).real
        for s in range(0, t.size, rows)
    ]
    return np.concatenate(blocks) if blocks else np.zeros((0, 6))


def base_pose(motion: ArrayLike, lever_arm: ArrayLike, mount_yaw: float = 0.0) -> np.ndarray:
    """Pose of a mechanism base fixed on the vessel, in the equilibrium frame.

    T_eq_base(t) = T_eq_vessel(t) · T_vessel_base: the position is the vessel's translation
    plus R(t) r, so rotations move an offset base by (R(t) − I) r on top of its mean position r.

    Args:
        motion: (N, 6) [m, rad] vessel motion from `vessel_motion`.
        lever_arm: (3,) [m] r, base origin in the vessel frame (x bow, y port, z up) from the
            centre of motion.
        mount_yaw: [rad] base x-axis from the vessel's bow, about z up (−π/2: base x to
            starboard, seed 000 §3.1).

    Returns:
        pose: (N, 6) [m, rad] base `[x, y, z, roll, pitch, yaw]`, R = Rz·Ry·Rx.
    """
    motion = as_array(motion, "motion", (6,))
    lever_arm = as_array(lever_arm, "lever_arm", (3,))
    mount = np.r_[lever_arm, 0.0, 0.0, float(as_array(mount_yaw, "mount_yaw"))]
    return transform_to_pose(pose_to_transform(motion) @ pose_to_transform(mount))


def equilibrium_to_world(
    pose: ArrayLike, t: ArrayLike, heading: float = 0.0, speed: float = 0.0
) -> np.ndarray:
    """Poses (N, 6) in the equilibrium frame → world frame, e.g. to draw the hull on the sea.

    The equilibrium frame is rotated by ψ about z and its origin is at U t (cos ψ, sin ψ, 0).

    Args:
        pose: (N, 6) [m, rad] `[x, y, z, roll, pitch, yaw]` in the equilibrium frame.
        t: (N,) [s] the times of the poses.
        heading: [rad] ψ as in `vessel_motion`.
        speed: [m/s] U as in `vessel_motion`.
    """
    pose = as_array(pose, "pose", (6,))
    t = as_array(t, "t")
    heading = float(as_array(heading, "heading"))
    origin = float(as_array(speed, "speed")) * t[:, None] * [np.cos(heading), np.sin(heading), 0.0]
    frame = np.concatenate([origin, np.zeros_like(origin)], -1)
    frame[:, 5] = heading
    return transform_to_pose(pose_to_transform(frame) @ pose_to_transform(pose))


@dataclass(frozen=True)
class Mount:
    """Where a mechanism base sits on its vessel.

    Attributes:
        vessel: name of the vessel's RAO table (`load_raos`).
        lever_arm: (3,) [m] base origin in the vessel frame from the centre of motion.
        yaw: [rad] base x-axis from the bow, about z up.
        description: what is mounted and why there.
    """

    vessel: str
    lever_arm: tuple[float, float, float]
    yaw: float
    description: str

    def pose(self, motion: ArrayLike) -> np.ndarray:
        """`base_pose(motion, self.lever_arm, self.yaw)`, (N, 6) [m, rad]."""
        return base_pose(motion, self.lever_arm, self.yaw)


MOUNTS: dict[str, Mount] = {
    "hybrid": Mount(
        vessel="sov",
        # Midships (least pitch-induced heave), 5.5 m to starboard of the centreline (2.8 m
        # inboard of the side), Stewart base 10 m above the waterline: the working-state tip,
        # 5.58 m above the base (SPEC check values), then meets a transition-piece landing at
        # ≈ 15.6 m. Our choice; the papers do not place the system on a hull.
        lever_arm=(0.0, -5.5, 10.0),
        # Seed 000 §3.1: base x = sensor y (starboard), base y = sensor x (bow), z up.
        yaw=-np.pi / 2,
        description="hybrid boarding system (seed 000) on the walk-to-work SOV",
    ),
    "upr4": Mount(
        vessel="asv",
        # Seed 002 puts its origin O at the centre of the base platform between the floats;
        # its height (0.5 m above the waterline, on the cross rods) and x to the bow are ours.
        lever_arm=(0.0, 0.0, 0.5),
        yaw=0.0,
        description="4-UPR UAV landing platform (seed 002) on the twin-float ASV",
    ),
    "upu3up": Mount(
        vessel="sov",
        # Our choice (seed 001 names no ship or place): a cargo platform on the SOV's aft deck.
        lever_arm=(-20.0, 0.0, 4.0),
        yaw=0.0,
        description="3UPU_UP cargo platform (seed 001) on the SOV deck",
    ),
}

"""The mechanism base's inertial motion for a scenario: sea → vessel RAOs → mount."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np

from twin.sea.components import WaveComponents
from twin.sim.scenario import Scenario
from twin.spatial import pose_to_transform
from twin.vessel import MOUNTS, Mount, RaoTable, load_raos
from twin.vessel.motion import response_amplitudes


@dataclass(frozen=True)
class BaseSamples:
    """Inertial base motion at a batch of times.

    Attributes:
        t: (N,) [s].
        pose: (N, 6) [m, rad] `[x, y, z, roll, pitch, yaw]`, z up, R = Rz·Ry·Rx.
        transform: (N, 4, 4) ᴵT_B.
    """

    t: np.ndarray
    pose: np.ndarray
    transform: np.ndarray


class BaseMotion:
    """Base motion of a mechanism on its vessel in a given sea.

    Args:
        components: the sea (inertial frame; the vessel's bow points along +x, so a wave
            direction is also its direction relative to the bow, π = head seas).
        mount: where the base sits on which vessel.
        vessel: RAO table name, overriding the mount's.
        speed: [m/s] forward speed.
    """

    def __init__(
        self,
        components: WaveComponents,
        mount: Mount,
        vessel: str | None = None,
        speed: float = 0.0,
    ) -> None:
        self.components = components
        self.mount = mount
        self.raos = raos_named(vessel or mount.vessel)
        self.speed = speed
        # the terms vessel_motion sums, interpolated from the RAO table once per sea
        self.omega_e, self.amplitude = response_amplitudes(components, self.raos, 0.0, speed)

    @classmethod
    def of(cls, scenario: Scenario) -> BaseMotion:
        """The base motion of a scenario: its sea, its mechanism's mount, its vessel."""
        return cls(
            scenario.components(),
            mount_for(scenario.mechanism),
            vessel=scenario.vessel,
            speed=scenario.forward_speed,
        )

    def poses(self, t: np.ndarray) -> np.ndarray:
        """(N, 6) inertial base poses at times t (N,) [s] (`twin.vessel.vessel_motion`)."""
        t = np.asarray(t, dtype=float)
        if t.size > 2 and np.allclose(np.diff(t), t[1] - t[0], rtol=0.0, atol=1e-12):
            motion = uniform_motion(self.omega_e, self.amplitude, t[0], t[1] - t[0], t.size)
        else:
            motion = (np.exp(-1j * np.outer(t, self.omega_e)) @ self.amplitude).real
        return self.mount.pose(motion)

    def sample(self, t: np.ndarray) -> BaseSamples:
        """Poses and transforms at times t (N,) [s]."""
        t = np.asarray(t, dtype=float)
        poses = self.poses(t)
        return BaseSamples(t, poses, pose_to_transform(poses))


@cache
def raos_named(name: str) -> RaoTable:
    """An RAO table by shipped name or path, read once per process (a NetCDF read costs ms)."""
    return load_raos(name)


def uniform_motion(
    omega_e: np.ndarray, amplitude: np.ndarray, t0: float, dt: float, n: int
) -> np.ndarray:
    """`vessel_motion` at t = t0 + k dt, k = 0 … n − 1, (n, 6) [m, rad].

    e^{−iω(t0 + k dt)} = e^{−iω t0} e^{−iω b dt} e^{−iω aB dt} with k = aB + b, so only
    (A + B) × K complex exponentials are evaluated instead of n × K, and the real part of the
    sum is A real matrix products (B, 2K) @ (2K, 6), stacked rather than one large product (a
    multi-threaded BLAS call on a busy machine costs ten times the arithmetic).
    """
    fine = math.isqrt(max(n - 1, 0)) + 1  # B
    coarse = -(-n // fine)  # A
    shifted = np.exp(-1j * omega_e * t0)[:, None] * amplitude  # (K, 6)
    e_fine = np.exp(-1j * np.outer(np.arange(fine) * dt, omega_e))  # (B, K)
    e_coarse = np.exp(-1j * np.outer(np.arange(coarse) * (fine * dt), omega_e))  # (A, K)
    X = e_coarse[:, :, None] * shifted  # (A, K, 6)
    lhs = np.concatenate([e_fine.real, -e_fine.imag], 1)  # (B, 2K)
    return (lhs @ np.concatenate([X.real, X.imag], 1)).reshape(-1, 6)[:n]


def mount_for(mechanism: str) -> Mount:
    """The mechanism's standard mount (twin.vessel.MOUNTS)."""
    return MOUNTS[mechanism]

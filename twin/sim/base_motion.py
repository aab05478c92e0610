"""The mechanism base's inertial motion for a scenario: sea → vessel RAOs → mount.

Samples come with their time derivative (central differences of the analytic motion, which
can be evaluated at any time), as planners need the desired twist, not just the pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.sea.components import WaveComponents
from twin.spatial import pose_to_transform, so3_log
from twin.vessel import MOUNTS, Mount, load_raos, vessel_motion

#: [s] half-step of the central difference for the base twist; the motion is smooth on this
#: scale (wave periods ≥ 1 s), so the truncation error is ~(h ω)² ≈ 1e-5 of the rate.
TWIST_STEP = 1e-3


@dataclass(frozen=True)
class BaseSamples:
    """Inertial base motion at a batch of times.

    Attributes:
        t: (N,) [s].
        pose: (N, 6) [m, rad] `[x, y, z, roll, pitch, yaw]`, z up, R = Rz·Ry·Rx.
        transform: (N, 4, 4) ᴵT_B.
        velocity: (N, 3) [m/s] ᴵṗ_B.
        angular_velocity: (N, 3) [rad/s] ᴵω_B (spatial, in the inertial frame).
    """

    t: np.ndarray
    pose: np.ndarray
    transform: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray


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
        self.raos = load_raos(vessel or mount.vessel)
        self.speed = speed

    def poses(self, t: np.ndarray) -> np.ndarray:
        """(N, 6) inertial base poses at times t (N,) [s]."""
        motion = vessel_motion(self.components, self.raos, t, heading=0.0, speed=self.speed)
        return self.mount.pose(motion)

    def sample(self, t: np.ndarray) -> BaseSamples:
        """Poses and central-difference rates at times t (N,) [s]."""
        t = np.asarray(t, dtype=float)
        poses = self.poses(np.concatenate([t, t - TWIST_STEP, t + TWIST_STEP]))
        T, T_minus, T_plus = np.split(pose_to_transform(poses), 3)
        velocity = (T_plus[:, :3, 3] - T_minus[:, :3, 3]) / (2 * TWIST_STEP)
        rotation = T_plus[:, :3, :3] @ np.swapaxes(T_minus[:, :3, :3], -1, -2)
        omega = so3_log(rotation) / (2 * TWIST_STEP)
        return BaseSamples(t, poses[: t.size], T, velocity, omega)


def mount_for(mechanism: str) -> Mount:
    """The mechanism's standard mount (twin.vessel.MOUNTS)."""
    return MOUNTS[mechanism]

"""The mechanism base's inertial motion for a scenario: sea → vessel RAOs → mount."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.sea.components import WaveComponents
from twin.sim.scenario import Scenario
from twin.spatial import pose_to_transform
from twin.vessel import MOUNTS, Mount, load_raos, vessel_motion


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
        self.raos = load_raos(vessel or mount.vessel)
        self.speed = speed

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
        """(N, 6) inertial base poses at times t (N,) [s]."""
        motion = vessel_motion(self.components, self.raos, t, heading=0.0, speed=self.speed)
        return self.mount.pose(motion)

    def sample(self, t: np.ndarray) -> BaseSamples:
        """Poses and transforms at times t (N,) [s]."""
        t = np.asarray(t, dtype=float)
        poses = self.poses(t)
        return BaseSamples(t, poses, pose_to_transform(poses))


def mount_for(mechanism: str) -> Mount:
    """The mechanism's standard mount (twin.vessel.MOUNTS)."""
    return MOUNTS[mechanism]

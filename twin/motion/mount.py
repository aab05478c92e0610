"""Measured motion moved from the sensor's point to a mechanism's mount, by the rigid-body
kinematics the RAO path uses (`twin.vessel.motion.base_pose`): the hull is one rigid body, so
one rotation R(t) and the translation of any one point fix every point's motion.

A sensor at r_S (vessel frame, from the centre of motion) that reports its displacement d_S
and the hull's angles gives the centre of motion's translation p_V = d_S − (R − I) r_S (since
`base_pose` places r_S at p_V + R r_S = r_S + d_S); the mount then follows as `base_pose` of
that motion at its own lever arm, as the RAO path places it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from twin.spatial import rpy_to_matrix
from twin.validation import as_array
from twin.vessel.motion import base_pose


def vessel_motion_from(sensor_motion: ArrayLike, sensor_position: ArrayLike) -> np.ndarray:
    """The centre of motion's motion (N, 6) [m, rad] from a sensor's (N, 6): its displacement
    [m] and the hull's roll, pitch, yaw [rad] (the twin's convention, `Sensor.to_vessel`), the
    sensor at `sensor_position` (3,) [m] in the vessel frame. A channel the sensor does not
    give (NaN) is taken as 0: an MRU without surge and sway is read as a hull that does not
    translate sideways at its point.

    Raises:
        TwinError: an infinite value, or shapes other than (..., 6) and (3,)."""
    raw = np.asarray(sensor_motion, dtype=float)
    motion = as_array(np.where(np.isnan(raw), 0.0, raw), "sensor motion", (6,))
    r = as_array(sensor_position, "sensor position", (3,))
    R = rpy_to_matrix(motion[..., 3:])
    out = motion.copy()
    out[..., :3] = motion[..., :3] - (R @ r - r)
    return out


def motion_at(
    sensor_motion: ArrayLike,
    sensor_position: ArrayLike,
    lever_arm: ArrayLike,
    mount_yaw: float = 0.0,
) -> np.ndarray:
    """The mount's base pose (N, 6) [m, rad] in the equilibrium frame, as
    `twin.vessel.motion.base_pose` gives it on the RAO path, from a sensor's motion (N, 6)
    at `sensor_position` (3,) [m]; lever_arm (3,) [m] and mount_yaw [rad] the mount's
    (`twin.vessel.MOUNTS`)."""
    return base_pose(vessel_motion_from(sensor_motion, sensor_position), lever_arm, mount_yaw)

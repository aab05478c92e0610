"""The sensor-to-mount transfer (`twin.motion.mount`) against the RAO path: the same hull
motion, measured at a sensor on the hull and moved to a mount, equals the RAO path's base pose
at that mount to 1e-9."""

from __future__ import annotations

import numpy as np
import pytest

from twin.motion.mount import motion_at, vessel_motion_from
from twin.sea.synthesis import wave_components
from twin.sim.base_motion import raos_named
from twin.vessel import MOUNTS
from twin.vessel.motion import base_pose, vessel_motion


@pytest.fixture(scope="module")
def hull() -> np.ndarray:
    """A minute of the shipped vessel's motion in a 3 m, 9 s sea from 30° off the bow."""
    sea = wave_components(3.0, 9.0, "jonswap", np.radians(150.0), None, 4, 200)
    return vessel_motion(sea, raos_named("sov"), np.arange(0.0, 60.0, 0.1))


@pytest.mark.parametrize("mechanism", sorted(MOUNTS))
@pytest.mark.parametrize("sensor", [(0.0, 0.0, 0.0), (12.0, -3.5, 6.0), (-30.0, 8.0, 15.0)])
def test_the_mount_moves_as_the_rao_path_places_it(hull: np.ndarray, mechanism: str,
                                                   sensor: tuple[float, float, float]) -> None:
    """A sensor at r_S reports its point's displacement and the hull's angles (what the RAO
    path's `base_pose` puts at r_S, less r_S); moved to each mechanism's mount it is the RAO
    path's base pose there to 1e-9 m and rad."""
    mount = MOUNTS[mechanism]
    at_sensor = base_pose(hull, sensor)
    measured = np.c_[at_sensor[:, :3] - np.asarray(sensor), at_sensor[:, 3:]]
    got = motion_at(measured, sensor, mount.lever_arm, mount.yaw)
    want = base_pose(hull, mount.lever_arm, mount.yaw)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    np.testing.assert_allclose(vessel_motion_from(measured, sensor), hull, rtol=0, atol=1e-9)
    assert np.ptp(got[:, 2]) > 0.5  # the sea moves the mount: the comparison means something


def test_a_sensor_without_surge_and_sway_is_read_as_none() -> None:
    """NaN channels (a heave-roll-pitch MRU) count as 0; an infinite value is refused."""
    rows = np.array([[np.nan, np.nan, 0.3, 0.02, -0.01, np.nan]])
    filled = np.array([[0.0, 0.0, 0.3, 0.02, -0.01, 0.0]])
    np.testing.assert_array_equal(vessel_motion_from(rows, (1.0, 2.0, 3.0)),
                                  vessel_motion_from(filled, (1.0, 2.0, 3.0)))  # fmt: skip
    with pytest.raises(ValueError, match="sensor motion"):
        vessel_motion_from(np.array([[np.inf, 0, 0, 0, 0, 0]]), (0.0, 0.0, 0.0))

"""The z-down ↔ z-up vessel-frame conversion (twin/vessel/frames.py, SPEC erratum 12)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.spatial import rpy_to_matrix
from twin.vessel import (
    MOUNTS,
    direction_from_z_down,
    pose_from_z_down,
    pose_to_z_down,
    rotation_from_z_down,
    vector_from_z_down,
)


def test_axes_map_bow_starboard_down_to_bow_port_up() -> None:
    """Bow stays bow, starboard becomes −y, down becomes −z."""
    np.testing.assert_array_equal(vector_from_z_down(np.eye(3)), np.diag([1.0, -1.0, -1.0]))


@pytest.mark.parametrize("seed", range(5))
def test_pose_conversion_is_exact_for_finite_angles(seed: int) -> None:
    """Flipping pitch and yaw equals C R C for Z-Y-X angles of any size, not only small ones."""
    pose = np.random.default_rng(seed).uniform(-1.2, 1.2, (20, 6))
    expected = rotation_from_z_down(rpy_to_matrix(pose[:, 3:]))
    np.testing.assert_allclose(rpy_to_matrix(pose_from_z_down(pose)[:, 3:]), expected, atol=1e-12)
    np.testing.assert_allclose(pose_from_z_down(pose)[:, :3], vector_from_z_down(pose[:, :3]))


def test_conversion_is_its_own_inverse() -> None:
    """z-down → z-up → z-down returns the input."""
    pose = np.random.default_rng(0).normal(size=(10, 6))
    np.testing.assert_array_equal(pose_to_z_down(pose_from_z_down(pose)), pose)


def test_direction_towards_starboard_is_minus_y() -> None:
    """90° from the bow towards starboard (z down) is 270° from the bow towards port (z up)."""
    np.testing.assert_allclose(
        direction_from_z_down([0.0, np.pi / 2, np.pi]), [0, 1.5 * np.pi, np.pi]
    )


def test_hybrid_mount_yaw_follows_seed_000_base_axes() -> None:
    """Base x = sensor y (starboard), y = sensor x (bow), z up (seed 000 §3.1) is Rz(mount yaw)."""
    base_axes_z_down = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]).T  # columns
    R = vector_from_z_down(base_axes_z_down.T).T
    np.testing.assert_allclose(
        R, rpy_to_matrix(np.array([0.0, 0.0, MOUNTS["hybrid"].yaw])), atol=1e-15
    )

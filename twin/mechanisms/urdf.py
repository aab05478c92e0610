"""URDF joint names and the map from a mechanism state to the full URDF configuration.

URDF cannot express closed loops, so each parallel mechanism is a tree (seed 002 §5, the
"virtual chain"): the platform hangs from the base on six virtual joints
`platform_x, platform_y, platform_z` (prismatic) then `platform_yaw, platform_pitch,
platform_roll` (revolute z, y, x, so R = Rz·Ry·Rx), and every leg is its own base-attached
chain `leg{i}_u1` (revolute x), `leg{i}_u2` (revolute y), `leg{i}_stroke` (prismatic z, the
absolute hinge-to-hinge length), in a U-joint frame whose z is the leg's direction at the
working state (`home_frames`: U angles are deviations from home), ending in the link
`leg{i}_rod` at the platform hinge. The hybrid system adds `slew`, `luff` and `telescope`
on the platform, ending in `gangway_tip`. `joint_configuration` fills every joint so that
the drawn legs meet the platform hinges.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from twin.mechanisms.legs import LegLayout, legs, universal_angles, universal_frames
from twin.spatial import pose_to_transform

PLATFORM_JOINTS = (
    "platform_x",
    "platform_y",
    "platform_z",
    "platform_yaw",
    "platform_pitch",
    "platform_roll",
)
GANGWAY_JOINTS = ("slew", "luff", "telescope")
# pose index of each virtual-chain joint: pose is [x, y, z, roll, pitch, yaw]
_POSE_INDEX = (0, 1, 2, 5, 4, 3)


def leg_joint_names(i: int) -> tuple[str, str, str]:
    """URDF joints of leg i (1-based): U-joint x, U-joint y, prismatic stroke."""
    return (f"leg{i}_u1", f"leg{i}_u2", f"leg{i}_stroke")


def joint_names(mechanism: Any) -> tuple[str, ...]:
    """Every movable URDF joint of `mechanism`, in a fixed order."""
    names = list(PLATFORM_JOINTS)
    for i in range(1, mechanism.layout.n_legs + 1):
        names.extend(leg_joint_names(i))
    if hasattr(mechanism, "gangway"):
        names.extend(GANGWAY_JOINTS)
    return tuple(names)


def home_frames(mechanism: Any) -> np.ndarray:
    """U-joint frames (n, 3, 3) centred on the legs' directions at `working_state`."""
    layout: LegLayout = mechanism.layout
    pose = mechanism.platform_pose(mechanism.working_state)
    return universal_frames(legs(layout, pose_to_transform(pose)).units)


def joint_configuration(mechanism: Any, state: ArrayLike) -> dict[str, np.ndarray]:
    """URDF joint values for mechanism states (..., k), keyed by joint name.

    Args:
        mechanism: a registry mechanism (`layout`, `platform_pose`, optional `gangway`).
        state: (..., k) the mechanism's own state (xi for the hybrid system).

    Returns:
        name → (...,) [m | rad]; `float(v)` of each gives a yourdfpy/viser `cfg` entry.
    """
    pose = mechanism.platform_pose(state)
    layout = mechanism.layout
    leg_state = legs(layout, pose_to_transform(pose))
    angles = universal_angles(leg_state.units, home_frames(mechanism))
    cfg = {name: pose[..., k] for name, k in zip(PLATFORM_JOINTS, _POSE_INDEX, strict=True)}
    for i in range(layout.n_legs):
        u1, u2, stroke = leg_joint_names(i + 1)
        cfg[u1], cfg[u2], cfg[stroke] = (
            angles[..., i, 0],
            angles[..., i, 1],
            leg_state.lengths[..., i],
        )
    if hasattr(mechanism, "gangway"):
        q = np.asarray(state, float)[..., 6:]
        for k, name in enumerate(GANGWAY_JOINTS):
            cfg[name] = q[..., k]
    return cfg

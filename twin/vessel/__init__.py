"""Vessel layer: hulls, RAO tables, 6-DOF vessel motion and the pose of a mechanism base.

Frames: z up everywhere (x bow, y port in the vessel frame); `twin.vessel.frames` is the one
place that converts the papers' z-down vessel frame (SPEC erratum 12).
"""

from __future__ import annotations

from twin.vessel.frames import (
    POSE_SIGNS,
    Z_DOWN_TO_Z_UP,
    direction_from_z_down,
    direction_to_z_down,
    pose_from_z_down,
    pose_to_z_down,
    rotation_from_z_down,
    rotation_to_z_down,
    vector_from_z_down,
    vector_to_z_down,
)
from twin.vessel.hulls import HULLS, Hull, displaced_volume, get_hull, wetted_surface
from twin.vessel.motion import (
    MOUNTS,
    Mount,
    base_pose,
    encounter_frequency,
    equilibrium_to_world,
    vessel_motion,
)
from twin.vessel.rao import (
    DOFS,
    RaoTable,
    available_raos,
    interpolate_raos,
    load_raos,
    raos_from_dataset,
    raos_to_dataset,
    write_raos,
)

__all__ = [
    "DOFS",
    "HULLS",
    "MOUNTS",
    "POSE_SIGNS",
    "Z_DOWN_TO_Z_UP",
    "Hull",
    "Mount",
    "RaoTable",
    "available_raos",
    "base_pose",
    "direction_from_z_down",
    "direction_to_z_down",
    "displaced_volume",
    "encounter_frequency",
    "equilibrium_to_world",
    "get_hull",
    "interpolate_raos",
    "load_raos",
    "pose_from_z_down",
    "pose_to_z_down",
    "raos_from_dataset",
    "raos_to_dataset",
    "rotation_from_z_down",
    "rotation_to_z_down",
    "vector_from_z_down",
    "vector_to_z_down",
    "vessel_motion",
    "wetted_surface",
    "write_raos",
]

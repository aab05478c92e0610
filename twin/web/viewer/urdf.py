"""The mechanism's URDF in the scene: painted parts (`painted_urdf`) and `LiveUrdf`, whose update
sets only what each joint moves.
"""

from __future__ import annotations

from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
import viser
import yourdfpy
from viser.extras import ViserUrdf

from twin.spatial import matrix_to_wxyz

#: [-] the URDF parts' PBR material: painted steel. Their `<color>` alone reaches the browser
#: as vertex colours with no material, which three.js draws as rough full metal (glTF's
#: default): lit by the environment map alone, black in "light" graphics. Mostly diffuse, they
#: read under any light.
PAINT_METALLIC = 0.2
PAINT_ROUGHNESS = 0.55


def quaternion_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a ⊗ b for wxyz quaternions (..., 4)."""
    w1, v1, w2, v2 = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([w1 * w2 - np.sum(v1 * v2, -1, keepdims=True),
                           w1 * v2 + w2 * v1 + np.cross(v1, v2)], -1)  # fmt: skip


def paint(scene: trimesh.Scene) -> None:
    """Give each mesh of a URDF's scene (coloured by its link's `<color>`) a PBR material of
    that colour, `PAINT_METALLIC` and `PAINT_ROUGHNESS`, in place.

    A `<color>` is a display colour, as RViz shows it (sRGB); glTF's base colour factor is
    linear, so it is converted (IEC 61966-2-1), or every part would show paler than its URDF
    says (the platform's orange 0.85, 0.55, 0.15 as cream).
    """
    for mesh in scene.geometry.values():
        srgb = np.asarray(mesh.visual.main_color, dtype=float) / 255.0
        colour = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
        colour[3] = srgb[3]  # alpha is not a colour
        material = trimesh.visual.material.PBRMaterial(
            baseColorFactor=colour, metallicFactor=PAINT_METALLIC, roughnessFactor=PAINT_ROUGHNESS
        )
        mesh.visual = trimesh.visual.TextureVisuals(material=material)


def painted_urdf(path: Path) -> yourdfpy.URDF:
    """The URDF at `path` with its meshes (loaded as ViserUrdf loads them), `paint`ed."""
    urdf = yourdfpy.URDF.load(
        path, load_meshes=True, build_scene_graph=True,
        filename_handler=partial(yourdfpy.filename_handler_magic, dir=path.parent),
    )  # fmt: skip
    paint(urdf.scene)
    return urdf


class LiveUrdf(ViserUrdf):
    """`ViserUrdf` of the URDF at `path`, painted (`painted_urdf`), whose `update_cfg` sets
    only what each joint moves (`kwargs` go to ViserUrdf).

    ViserUrdf's own update runs yourdfpy's scene-graph forward kinematics and re-assigns both
    halves of every joint frame's pose: most of a frame's budget for the hybrid system's 28
    joints. A joint frame's pose in its parent is the joint origin times the joint's own
    motion, so a revolute joint only turns its frame (wxyz = q_origin ⊗ q(axis, θ)) and a
    prismatic joint only slides it (position = p_origin + R_origin axis d): one vectorised
    computation and one property per joint. (ViserUrdf's docstring invites copying or
    modifying it for finer control; loading and node naming stay ViserUrdf's.) The first call
    poses every frame, fixed joints included, through ViserUrdf; URDFs with mimic joints keep
    its update throughout.
    """

    def __init__(
        self, target: viser.ViserServer, path: Path, root_node_name: str, **kwargs: Any
    ) -> None:
        super().__init__(target, painted_urdf(path), root_node_name=root_node_name, **kwargs)
        index = {name: k for k, name in enumerate(self.get_actuated_joint_names())}
        joints = list(self._urdf.joint_map.values())
        frames = self._joint_frames[: len(joints)]  # the visual tree's, in joint_map order
        self._posed = False
        self._fast = all(j.mimic is None for j in joints)
        turn = [k for k, j in enumerate(joints) if j.type in ("revolute", "continuous")]
        slide = [k for k, j in enumerate(joints) if j.type == "prismatic"]
        origin = np.stack([np.eye(4) if j.origin is None else j.origin for j in joints])
        axis = np.stack([np.asarray(j.axis, float) for j in joints])
        self._turn = ([frames[k] for k in turn], [index[joints[k].name] for k in turn])
        self._turn_origin = matrix_to_wxyz(origin[turn, :3, :3])
        self._turn_axis = axis[turn]
        self._slide = ([frames[k] for k in slide], [index[joints[k].name] for k in slide])
        self._slide_origin = origin[slide, :3, 3]
        self._slide_direction = (origin[slide, :3, :3] @ axis[slide, :, None])[..., 0]

    def update_cfg(self, configuration: np.ndarray) -> None:
        """Pose the joint frames for joint values in `get_actuated_joint_names()` order."""
        if not (self._posed and self._fast):
            super().update_cfg(configuration)
            self._posed = True
            return
        frames, index = self._turn
        half = 0.5 * configuration[index]
        turn = np.concatenate([np.cos(half)[:, None], self._turn_axis * np.sin(half)[:, None]], -1)
        for frame, wxyz in zip(frames, quaternion_product(self._turn_origin, turn), strict=True):
            frame.wxyz = wxyz
        frames, index = self._slide
        positions = self._slide_origin + self._slide_direction * configuration[index][:, None]
        for frame, position in zip(frames, positions, strict=True):
            frame.position = position

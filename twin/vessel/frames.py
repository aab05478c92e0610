r"""The one place that converts the papers' z-down vessel frame to our z-up frames and back.

The papers (seed 000 §3.1, after [26]) use a vessel frame with x to the bow, y to starboard and
z down; inside the twin every frame is right-handed with z up, so the vessel frame is x bow,
y port, z up (SPEC erratum 12). The two differ by a half turn about x,
:math:`C = \mathrm{diag}(1, -1, -1) = C^\top = C^{-1}`, so every conversion here is its own
inverse and the `*_to_z_down` names are the same functions as `*_from_z_down`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

Z_DOWN_TO_Z_UP = np.diag([1.0, -1.0, -1.0])  # C: v_up = C v_down

# C Rz(ψ) Ry(θ) Rx(φ) C = Rz(-ψ) Ry(-θ) Rx(φ): the Z-Y-X angles map exactly, not only for small
# angles, so a pose and a 6-DOF motion [surge, sway, heave, roll, pitch, yaw] flip these signs.
POSE_SIGNS = np.array([1.0, -1.0, -1.0, 1.0, -1.0, -1.0])


def vector_from_z_down(v: ArrayLike) -> np.ndarray:
    """C v: a position or free vector (..., 3), (bow, starboard, down) → (bow, port, up)."""
    return np.asarray(v, dtype=float) * np.diag(Z_DOWN_TO_Z_UP)


def rotation_from_z_down(R: ArrayLike) -> np.ndarray:
    """C R C: a rotation matrix (..., 3, 3) expressed in the z-down frame, re-expressed z-up."""
    return Z_DOWN_TO_Z_UP @ np.asarray(R, dtype=float) @ Z_DOWN_TO_Z_UP


def pose_from_z_down(pose: ArrayLike) -> np.ndarray:
    """`[x, y, z, roll, pitch, yaw]` (..., 6) [m, rad], Z-Y-X angles, z-down → z-up (exact)."""
    return np.asarray(pose, dtype=float) * POSE_SIGNS


def direction_from_z_down(angle: ArrayLike) -> np.ndarray:
    """A horizontal direction (...,) [rad] measured from x towards y, z-down → z-up, in [0, 2π).

    From the bow towards starboard in the papers' frame is from the bow towards −y (clockwise
    seen from above) in ours.
    """
    return np.mod(-np.asarray(angle, dtype=float), 2 * np.pi)


vector_to_z_down = vector_from_z_down
rotation_to_z_down = rotation_from_z_down
pose_to_z_down = pose_from_z_down
direction_to_z_down = direction_from_z_down

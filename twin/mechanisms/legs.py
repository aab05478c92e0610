"""What every parallel mechanism shares: legs between base and platform hinges.

A parallel mechanism here is a base, a platform and straight legs, leg i running from the
base hinge B_i (base frame) to the platform hinge P_i (platform frame). Inverse kinematics
is then the same closed-vector equation for all three mechanisms (seed 000 eqs (4)-(5),
seed 001 eq (16), seed 002 eq (15)): l_i = ᴮR_P ᴾP_i + ᴮO_P - ᴮB_i.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class LegLayout:
    """Hinge geometry and stroke of a parallel mechanism, in metres.

    This is also what the URDF generator draws: each leg a base-attached chain
    (universal joint, then a prismatic joint) ending on the platform hinge.

    Attributes:
        base_hinges: (n, 3) [m] B_i in the base frame.
        platform_hinges: (n, 3) [m] P_i in the platform frame.
        length_min: (n,) [m] shortest hinge-to-hinge length.
        length_max: (n,) [m] longest hinge-to-hinge length.
        actuated: (n,) which legs carry an actuator (a passive guide limb does not).
    """

    base_hinges: np.ndarray
    platform_hinges: np.ndarray
    length_min: np.ndarray
    length_max: np.ndarray
    actuated: tuple[bool, ...] = field(default=())

    def __post_init__(self) -> None:
        n = np.shape(self.base_hinges)[0]
        if not self.actuated:
            object.__setattr__(self, "actuated", (True,) * n)
        for name in ("base_hinges", "platform_hinges", "length_min", "length_max"):
            array = np.array(getattr(self, name), dtype=float)
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    @property
    def n_legs(self) -> int:
        return self.base_hinges.shape[0]


@dataclass(frozen=True)
class LegState:
    """Legs of a batch of platform poses.

    Attributes:
        vectors: (..., n, 3) [m] l_i = ᴮP_i - ᴮB_i in the base frame.
        lengths: (..., n) [m] |l_i|.
        units: (..., n, 3) n_i = l_i / |l_i|.
        arms: (..., n, 3) [m] ᴮR_P ᴾP_i, platform origin → hinge, in the base frame.
    """

    vectors: np.ndarray
    lengths: np.ndarray
    units: np.ndarray
    arms: np.ndarray


def legs(layout: LegLayout, transform: np.ndarray) -> LegState:
    """Leg vectors for platform transforms ᴮT_P (..., 4, 4); seed 000 eqs (4)-(5)."""
    R = transform[..., None, :3, :3]
    arms = (R @ layout.platform_hinges[..., None])[..., 0]  # (..., n, 3)
    vectors = arms + transform[..., None, :3, 3] - layout.base_hinges
    lengths = np.linalg.norm(vectors, axis=-1)
    return LegState(vectors, lengths, vectors / lengths[..., None], arms)


def twist_jacobian(state: LegState) -> np.ndarray:
    """J with l̇ = J [v_O; ω], v_O the platform-origin velocity and ω the angular velocity,
    both in the base frame; rows [n_iᵀ, (ᴮR_P ᴾP_i × n_i)ᵀ], (..., n, 6).

    seed 000 eq (8) prints the moment arm as ᴮP_i, which is right for the spatial twist
    (velocity of the body point at the base origin); for the origin velocity it is the
    arm ᴮR_P ᴾP_i. The two differ by a unit-determinant shear, so manipulability is the
    same (docs/decisions.md).
    """
    return np.concatenate([state.units, np.cross(state.arms, state.units)], -1)


def universal_frames(home_units: np.ndarray) -> np.ndarray:
    """U-joint frames (n, 3, 3) centred on the home leg directions (n, 3).

    z along the home direction s⁰, x = s⁰ × e_z (horizontal; e_x for a vertical leg),
    y = z × x, as seed 002 §2.1 sets its U joints: the angles are then zero at home, and a
    joint limit reads as a deviation from home.
    """
    z = home_units / np.linalg.norm(home_units, axis=-1, keepdims=True)
    x = np.cross(z, [0.0, 0.0, 1.0])
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    x = np.where(norm > 1e-9, x / np.where(norm > 1e-9, norm, 1.0), [1.0, 0.0, 0.0])
    return np.stack([x, np.cross(z, x), z], -1)


def universal_angles(units: np.ndarray, frames: np.ndarray | None = None) -> np.ndarray:
    """U-joint angles (a, b) with F Rx(a) Ry(b) e_z = n for unit leg directions (..., n, 3).

    The URDF legs are revolute-x, revolute-y, prismatic-z chains in the frame F of each leg
    (`universal_frames`; identity if None); this is their inverse. Returns (..., n, 2) [rad].
    """
    if frames is not None:
        units = (np.swapaxes(frames, -1, -2) @ units[..., None])[..., 0]
    b = np.arcsin(np.clip(units[..., 0], -1.0, 1.0))
    a = np.arctan2(-units[..., 1], units[..., 2])
    return np.stack([a, b], -1)

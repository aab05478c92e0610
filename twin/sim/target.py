"""The compensation task: a body that holds its inertial pose while the base moves.

Seed 000 §5.1: the desired base-frame motion is the inverse of the measured base motion. With
the held pose ᴵT* fixed at t = 0, the desired pose in the base frame is ᴮT_d = ᴵT_B⁻¹ ᴵT*, and
its rates in B follow from the base's: ᴮω_d = −Rᵀ ᴵω_B, ᴮṗ_d = −Rᵀ (ᴵṗ_B + ᴵω_B × (p* − p_B)).
"""

from __future__ import annotations

import numpy as np

from twin.planners.target import TipTarget
from twin.sim.base_motion import BaseSamples
from twin.spatial import invert_transform


def held_target(held: np.ndarray, base: BaseSamples, k: int) -> TipTarget:
    """Desired pose and twist in B at sample k for the inertial pose `held` (4, 4)."""
    T_B = base.transform[k]
    Rt = T_B[:3, :3].T
    w = base.angular_velocity[k]
    v = -Rt @ (base.velocity[k] + np.cross(w, held[:3, 3] - T_B[:3, 3]))
    return TipTarget(transform=invert_transform(T_B) @ held, twist=np.r_[v, -Rt @ w])


def tilt(R: np.ndarray, axis: int = 2) -> np.ndarray:
    """Angle [rad] between a body axis (column `axis` of R (..., 3, 3)) and inertial z up."""
    return np.arccos(np.clip(R[..., 2, axis], -1.0, 1.0))

"""A check shared by the leg and Stewart tests: leg-length rates by central differences."""

from __future__ import annotations

import numpy as np

from twin.mechanisms.legs import LegLayout, legs
from twin.spatial import so3_exp


def length_rates_by_differences(layout: LegLayout, T: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """(n, 6) [m/m | m/rad]: central differences of `legs(layout, T).lengths` along each unit
    twist [v; ω] in B (the origin moved by v h, the rotation by exp(ω h) on the left), the
    independent check of the twist rows l̇ = J [v; ω] (seed 000 eq (8))."""
    columns = []
    for twist in np.eye(6):
        moved = []
        for sign in (1.0, -1.0):
            Tm = T.copy()
            Tm[:3, :3] = so3_exp(sign * h * twist[3:]) @ T[:3, :3]
            Tm[:3, 3] += sign * h * twist[:3]
            moved.append(legs(layout, Tm).lengths)
        columns.append((moved[0] - moved[1]) / (2 * h))
    return np.stack(columns, axis=1)

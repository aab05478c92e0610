"""Compass conventions of site data ↔ `Scenario.heading`.

Site data speak compass degrees, clockwise from true north:

- the wave direction θ is where the waves come **from** (NDBC's MWD, ERA5's mwd);
- the vessel heading ψ is where the bow points.

`Scenario.heading` β is what the sea and vessel code compute with, read from their numbers
(`twin.sea.synthesis.wave_components` takes it as the direction the components travel
**towards**; `twin.vessel.motion` applies β = μ − ψ in a frame with x to the bow and y to port,
angles counter-clockwise seen from above, docs/vessel.md): β is the direction the waves travel
towards, counter-clockwise from the bow. 0° following seas, 180° head seas, 90° waves travelling
to **port** (coming from starboard), 270° waves travelling to starboard (coming from port).
tests/site/test_heading.py checks this on the engine itself: a long regular wave at β = 90°
sways the vessel towards +y (port) under its crests, and at β = 0° surges it forward
(docs/frames.md, "Wave directions").

The travel direction is θ + 180° in compass terms; measured from the bow it is θ + 180° − ψ
clockwise, so counter-clockwise:

    β = ψ − θ − 180°        (mod 360°)
    θ = ψ − β − 180°        (mod 360°)
    ψ = θ + β + 180°        (mod 360°)

Waves from the north, bow to the north: β = 180° (head seas). Waves from the north, bow to the
east: the waves come from the port side and travel to starboard, β = 270°.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def _mod(x: np.ndarray) -> np.ndarray | float:
    out = np.mod(x, 360.0)
    out = np.where(np.isclose(out, 360.0, rtol=0.0, atol=1e-9), 0.0, out)  # -1e-15 → 0, not 360
    return float(out) if out.ndim == 0 else out


def relative_heading(wave_from: ArrayLike, vessel_heading: ArrayLike) -> np.ndarray | float:
    """`Scenario.heading` β [deg, 0-360) of waves coming from compass `wave_from` [deg true]
    met by a vessel whose bow points to compass `vessel_heading` [deg true]."""
    theta = np.asarray(wave_from, dtype=float)
    psi = np.asarray(vessel_heading, dtype=float)
    return _mod(psi - theta - 180.0)


def wave_from(beta: ArrayLike, vessel_heading: ArrayLike) -> np.ndarray | float:
    """Compass direction [deg true, 0-360) the waves come from, given `Scenario.heading` β
    [deg] and the vessel's compass heading [deg true] (inverse of `relative_heading` in θ)."""
    b = np.asarray(beta, dtype=float)
    psi = np.asarray(vessel_heading, dtype=float)
    return _mod(psi - b - 180.0)


def vessel_heading_for(beta: ArrayLike, wave_from: ArrayLike) -> np.ndarray | float:
    """Compass heading [deg true, 0-360) that meets waves from compass `wave_from` [deg true] at
    `Scenario.heading` β [deg] (inverse of `relative_heading` in ψ): where the captain points
    the bow to hold a relative heading."""
    b = np.asarray(beta, dtype=float)
    theta = np.asarray(wave_from, dtype=float)
    return _mod(theta + b + 180.0)


def angular_distance(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """|a − b| on the circle [deg], 0-180."""
    d = np.mod(np.asarray(a, dtype=float) - np.asarray(b, dtype=float), 360.0)
    return np.minimum(d, 360.0 - d)

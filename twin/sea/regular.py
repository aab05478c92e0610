"""Regular-wave sets: a few monochromatic components, and seed 002 Table 2's wave states.

Seed 002 drives its ASV in Gazebo with the Virtual RobotX Gerstner wave field, one line of
Table 2 per wave state: number of waves, and per wave an amplitude [m], a period [s] and a
direction [x, y]. VRX can also fan one mean wave out into `number` components (scaled by
`scale`, rotated by `angle`); Table 2 lists every wave's own amplitude, period and direction,
so each listed wave is taken as one component. The paper gives no phases: all are 0, so
every crest passes the origin at t = 0.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike

from twin.errors import TwinError
from twin.sea.components import WaveComponents
from twin.sea.spectra import _checked


def regular_components(
    amplitude: ArrayLike,
    period: ArrayLike,
    direction: ArrayLike,
    phase: ArrayLike = 0.0,
) -> WaveComponents:
    """Deep-water regular waves from amplitude, period and an [x, y] travel direction.

    Args:
        amplitude: (k,) [m] amplitudes a_i ≥ 0 (half the crest-to-trough height).
        period: (k,) [s] periods T_i > 0; ω_i = 2π/T_i.
        direction: (k, 2) [-] vectors [x, y] the waves travel towards (seed 002 Table 2's
            "Direction [x,y]"); only their angle matters.
        phase: (k,) [rad] phases ε_i, broadcast.

    Returns:
        The k components.

    Raises:
        TwinError: a value out of range, a zero direction vector, or mismatched lengths.
    """
    amplitude = np.atleast_1d(_checked(amplitude, "amplitude", "m"))
    period = np.atleast_1d(_checked(period, "period", "s", low_open=True))
    direction = np.atleast_2d(_checked(direction, "direction", "", -np.inf))
    if direction.shape[-1] != 2 or np.any(np.hypot(*direction.T) == 0.0):
        raise TwinError(f"direction must be non-zero [x, y] vectors (k, 2), got {direction!r}")
    try:
        amplitude, period, phase, angle = np.broadcast_arrays(
            amplitude,
            period,
            _checked(phase, "phase", "rad", -np.inf),
            np.arctan2(direction[:, 1], direction[:, 0]),
        )
    except ValueError as exc:
        raise TwinError(f"amplitude, period, direction and phase lengths differ: {exc}") from exc
    return WaveComponents(2.0 * np.pi / period, amplitude, phase, angle)


REGULAR_PRESETS: MappingProxyType[str, WaveComponents] = MappingProxyType(
    {  # seed 002 Table 2 (η 98.23 %, 97.16 %, 94.84 % for the 4-UPR platform)
        "state1": regular_components([0.2], [3.0], [[1, 1]]),
        "state2": regular_components([0.2, 0.3], [5.0, 3.0], [[1, 0], [0, 1]]),
        "state3": regular_components([0.2, 0.3, 0.4], [7.0, 5.0, 3.0], [[1, 0], [0, 1], [1, 1]]),
    }
)

"""WMO sea-state code 0-9 (WMO code table 3700) and a representative (Hs, Tp) for each.

WMO code table 3700 (WMO-No. 306, Manual on Codes) gives each code a range of wave height,
read here as significant wave height Hs. It gives no period, so the representative sea of
each code is a fully developed Pierson–Moskowitz sea (seed 001 eq (28)):

* Hs is the middle of the code's range. Code 9 is open ("over 14 m"); it is closed at 19 m,
  the largest buoy-measured Hs WMO has certified (North Atlantic, 4 February 2013), giving
  16.5 m. Code 0 is Hs = 0.
* Tp = `fully_developed_tp(Hs)` = 5.0005·sqrt(Hs): the period at which the wind that raises
  this Hs has fully developed the sea, for which DNV-RP-C205 §3.5.5.5 gives JONSWAP γ = 1
  (`dnv_gamma`, the scenario's default γ). Real seas with the same Hs are younger (shorter Tp,
  JONSWAP γ > 1) or carry swell (longer Tp); pass Tp explicitly for those.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twin.sea.spectra import _checked, fully_developed_tp


@dataclass(frozen=True)
class SeaState:
    """One row of WMO code table 3700 with its representative sea.

    Attributes:
        code: WMO sea-state code 0-9.
        description: the WMO descriptive term.
        hs_min: [m] lower bound of the code's Hs range.
        hs_max: [m] upper bound (inf for code 9).
        hs: [m] representative significant wave height.
        tp: [s] representative peak period, fully developed PM sea.
    """

    code: int
    description: str
    hs_min: float
    hs_max: float
    hs: float
    tp: float


_WMO_3700 = (  # code, term, Hs range [m] (WMO code table 3700)
    (0, "calm (glassy)", 0.0, 0.0),
    (1, "calm (rippled)", 0.0, 0.1),
    (2, "smooth (wavelets)", 0.1, 0.5),
    (3, "slight", 0.5, 1.25),
    (4, "moderate", 1.25, 2.5),
    (5, "rough", 2.5, 4.0),
    (6, "very rough", 4.0, 6.0),
    (7, "high", 6.0, 9.0),
    (8, "very high", 9.0, 14.0),
    (9, "phenomenal", 14.0, np.inf),
)
HS_RECORD = 19.0  # [m] WMO-certified largest buoy Hs, closes code 9's open range
_HS = np.array([(lo + (hi if np.isfinite(hi) else HS_RECORD)) / 2 for _, _, lo, hi in _WMO_3700])
# Code 0 has Hs = 0 and no period: keep code 1's so the spectrum stays defined and only fades.
_TP = fully_developed_tp(np.maximum(_HS, _HS[1]))

WMO_SEA_STATES: tuple[SeaState, ...] = tuple(
    SeaState(code, term, lo, hi, float(hs), float(tp))
    for (code, term, lo, hi), hs, tp in zip(_WMO_3700, _HS, _TP, strict=True)
)


def sea_state_hs_tp(code: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Representative (Hs [m], Tp [s]) of a WMO sea-state code, integer or fractional.

    Integer codes give the table's values. A fractional code (a slider) interpolates Hs
    linearly between neighbouring codes and takes Tp = `fully_developed_tp(Hs)`, so every
    point on the slider is a fully developed sea.

    Args:
        code: [-] sea-state code(s) in [0, 9], any shape.

    Returns:
        hs [m] and tp [s], each the shape of `code`.

    Raises:
        TwinError: a code outside [0, 9] or NaN.
    """
    code = _checked(code, "sea-state code", "(WMO code table 3700)", 0.0, 9.0)
    hs = np.interp(code, np.arange(10), _HS)
    return hs, fully_developed_tp(np.maximum(hs, _HS[1]))


def sea_state_code(hs: ArrayLike) -> np.ndarray:
    """WMO code (int array) whose Hs range holds `hs` [m], ranges taken as (hs_min, hs_max].

    Raises:
        TwinError: `hs` negative or NaN.
    """
    hs = _checked(hs, "hs", "m")
    return np.searchsorted([s.hs_max for s in WMO_SEA_STATES[:-1]], hs, side="left")

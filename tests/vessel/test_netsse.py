"""Box-barge RAOs against the closed forms of Jensen, Mansour & Olsen (2004) in netsse.

The closed forms are strip-theory-like (2-D sectional damping, no 3-D end effects, heave and
pitch uncoupled, a shared dynamic factor); they agree with Capytaine in long and short waves
and differ near the heave/pitch resonance around λ ≈ L (docs/vessel.md, "Cross-check").
"""

from __future__ import annotations

import netsse.model.ship as ship  # installed by `make test` (Makefile: no-deps, Python 3.11)
import numpy as np
import pytest

from twin.vessel import DOFS, HULLS, load_raos

BARGE = load_raos("barge")
HEAD = int(np.argmin(np.abs(BARGE.wave_direction - np.pi)))
HULL = HULLS["barge"]


def peer(dof: str) -> np.ndarray:
    """netsse |RAO| at the table's frequencies, head seas (β = 180°), U = 0."""
    closed_form = {"heave": ship.heaveCF, "pitch": ship.pitchCF}[dof]
    args = (BARGE.omega, np.array([180.0]), 0.0, HULL.length, HULL.beam, HULL.draft)
    return closed_form(*args)[:, 0]


# (band [rad/s], heave tolerance [m/m], pitch tolerance [rad/m]); measured maxima 0.026/0.0006,
# 0.123/0.036 and 0.017/0.0014 (docs/vessel.md).
BANDS = [((0.0, 0.5), 0.03, 0.001), ((0.5, 1.2), 0.15, 0.045), ((1.2, 2.4), 0.03, 0.002)]


@pytest.mark.parametrize(("band", "heave_tol", "pitch_tol"), BANDS)
def test_barge_heave_and_pitch_match_closed_forms(band, heave_tol: float, pitch_tol: float) -> None:
    """|RAO| differences stay within the band's tolerance (tight in long and short waves)."""
    inside = (BARGE.omega >= band[0]) & (BARGE.omega < band[1])
    for dof, tol in (("heave", heave_tol), ("pitch", pitch_tol)):
        ours = np.abs(BARGE.values[inside, HEAD, DOFS.index(dof)])
        np.testing.assert_allclose(ours, peer(dof)[inside], rtol=0, atol=tol, err_msg=dof)


def test_pitch_peaks_near_the_closed_form_peak() -> None:
    """Both pitch RAOs peak where λ ≈ L (within 0.15 rad/s), ours higher (less 3-D damping)."""
    ours = np.abs(BARGE.values[:, HEAD, DOFS.index("pitch")])
    theirs = peer("pitch")
    assert abs(BARGE.omega[ours.argmax()] - BARGE.omega[theirs.argmax()]) < 0.15
    assert ours.max() > theirs.max()

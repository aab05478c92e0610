"""The wave-direction convention in numbers: `Scenario.heading` is where the waves travel
towards, counter-clockwise from the bow (x bow, y port, z up; docs/frames.md).

A long regular wave (period 25 s, 975 m long against the SOV's 70.5 m) is taken from the sea
`Scenario(heading=β)` synthesises and run through the SOV's RAO table (`vessel_motion`, as the
engine's base motion does). Such a wave carries the hull with its water: under a crest the
water moves the way the wave travels, and the hull lies on the wave's slope. So from
starboard (β = 90°) the crest reaches the starboard side first, the hull sways to port (+y)
and rolls port side up a quarter period after the crest; from port (β = 270°) the opposite.
If any description of `heading` mirrors the convention, these signs tell the numbers.
"""

from __future__ import annotations

import numpy as np
import pytest

from twin.sea.components import G, WaveComponents
from twin.sim import Scenario
from twin.sim.base_motion import raos_named
from twin.vessel.motion import vessel_motion

PERIOD = 25.0  # [s] long against the hull: the RAOs are near their long-wave limits
SURGE, SWAY, HEAVE, ROLL, PITCH = range(5)


def regular_wave(heading_deg: float) -> WaveComponents:
    """One unit-amplitude wave of period `PERIOD`, crest at the origin at t = 0, travelling
    the direction `Scenario(heading=heading_deg)` gives its sea."""
    sea = Scenario(heading=heading_deg, hs=1.0, tp=PERIOD, n_components=8).components()
    assert np.allclose(sea.direction, np.radians(heading_deg))  # long-crested: one direction
    return WaveComponents([2 * np.pi / PERIOD], [1.0], [0.0], sea.direction[:1])


def motion_quarter_period_after_crest(heading_deg: float) -> np.ndarray:
    """Vessel motion (6,) [m, rad] at t = T/4 after the crest passed the centre of motion."""
    t = np.array([0.0, PERIOD / 4])
    motion = vessel_motion(regular_wave(heading_deg), raos_named("sov"), t)
    assert motion[0, HEAVE] == pytest.approx(1.0, abs=0.05)  # the crest at t = 0: heave = a
    return motion[1]


@pytest.mark.parametrize(("heading", "towards_port"), [(90.0, 1.0), (270.0, -1.0)])
def test_beam_seas_sway_and_roll_the_way_the_waves_travel(heading: float, towards_port: float):
    """β = 90° (from starboard): sway to port, port side up; β = 270° (from port): mirrored.
    Both close to the long-wave limits, sway = a and roll = k·a."""
    m = motion_quarter_period_after_crest(heading)
    k = (2 * np.pi / PERIOD) ** 2 / G
    assert np.sign(m[SWAY]) == towards_port and abs(m[SWAY]) == pytest.approx(1.0, rel=0.1)
    assert np.sign(m[ROLL]) == towards_port and abs(m[ROLL]) == pytest.approx(k, rel=0.3)
    assert abs(m[SURGE]) < 0.05 and abs(m[PITCH]) < 0.1 * k


@pytest.mark.parametrize(("heading", "towards_bow"), [(0.0, 1.0), (180.0, -1.0)])
def test_head_and_following_seas_surge_the_way_the_waves_travel(heading: float, towards_bow):
    """β = 0° (following seas) surges the hull forward under the crest, β = 180° (head seas)
    aft; neither sways nor rolls the symmetric hull."""
    m = motion_quarter_period_after_crest(heading)
    assert np.sign(m[SURGE]) == towards_bow and abs(m[SURGE]) > 0.5
    assert abs(m[SWAY]) < 1e-6 and abs(m[ROLL]) < 1e-6


def test_the_papers_headings_come_from_the_sides_the_docs_name():
    """225° (`seed000`): waves from 45° off the port bow, so the crest lifts the port side
    first and the hull sways to starboard; 150° (`seed000_ss4`): from 30° off the starboard
    bow, sway to port."""
    assert motion_quarter_period_after_crest(225.0)[SWAY] < 0  # towards starboard (−y)
    assert motion_quarter_period_after_crest(150.0)[SWAY] > 0  # towards port (+y)


def test_the_heading_description_says_what_the_numbers_do():
    """The field's description names 90 as from starboard and travelling to port."""
    text = Scenario.model_fields["heading"].description
    assert "travel towards" in text and "90 = beam seas from starboard (travelling to port)" in text

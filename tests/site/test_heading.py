"""Compass ↔ `Scenario.heading`: the convention read from the engine's numbers, and the
conversion both ways on hand-made cases."""

from __future__ import annotations

import numpy as np
import pytest

from twin.sea.components import WaveComponents
from twin.sea.synthesis import evaluate_elevation
from twin.sim.scenario import Scenario
from twin.site.heading import angular_distance, relative_heading, vessel_heading_for, wave_from
from twin.vessel import MOUNTS, load_raos, vessel_motion


def long_wave_motion(beta_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, η at the centre of motion, vessel velocity (N, 6)) in a 21 s regular wave of 1 m
    travelling at `Scenario.heading` = beta_deg, as the engine builds it."""
    direction = Scenario(hs=1.0, tp=8.0, heading=beta_deg).components().direction
    assert np.allclose(direction, np.deg2rad(beta_deg))  # Scenario.heading goes in as is
    sea = WaveComponents(np.array([0.3]), np.array([1.0]), np.array([0.0]), direction[:1])
    t = np.arange(0.0, 210.0, 0.1)
    motion = vessel_motion(sea, load_raos(MOUNTS["hybrid"].vessel), t)
    return t, evaluate_elevation(sea, t), np.gradient(motion, t, axis=0)


@pytest.mark.parametrize(("beta", "axis", "sign"), [(0, 0, 1), (180, 0, -1), (90, 1, 1),
                                                    (270, 1, -1)])  # fmt: skip
def test_scenario_heading_is_where_waves_travel_counter_clockwise_from_the_bow(
    beta: float, axis: int, sign: int
) -> None:
    """In a wave much longer than the hull the vessel moves with the water: under a crest it
    is carried the way the wave travels. At β = 90° that is +y, to port (x bow, y port): so β
    is the direction waves travel *towards*, counter-clockwise from the bow, and β = 90° is a
    beam sea *from starboard* (issue 31 corrected the description, which said port)."""
    _, eta, velocity = long_wave_motion(beta)
    correlation = np.corrcoef(velocity[:, axis], eta)[0, 1]
    assert sign * correlation > 0.99


CASES = [  # (waves from, vessel heading, Scenario.heading): compass degrees, true
    (0.0, 0.0, 180.0),  # waves from the north, bow north: head seas
    (0.0, 180.0, 0.0),  # bow south: following seas
    (0.0, 90.0, 270.0),  # bow east: waves from port, travelling to starboard
    (0.0, 270.0, 90.0),  # bow west: waves from starboard, travelling to port
    (270.0, 0.0, 270.0),  # waves from the west, bow north: from port, travelling to starboard
    (90.0, 0.0, 90.0),  # waves from the east, bow north: from starboard, travelling to port
    (45.0, 45.0, 180.0),  # bow into the waves: head seas
    (350.0, 10.0, 200.0),  # waves 20° to port of the bow: travelling 160° clockwise from it
]


def test_hand_made_cases_both_ways() -> None:
    """Relative heading, wave direction and vessel heading each follow from the other two on
    hand-worked cases (the compass convention of docs/workability.md)."""
    for theta, psi, beta in CASES:
        assert relative_heading(theta, psi) == pytest.approx(beta), (theta, psi)
        assert wave_from(beta, psi) == pytest.approx(theta % 360.0), (beta, psi)
        assert vessel_heading_for(beta, theta) == pytest.approx(psi), (beta, theta)


def test_round_trips_on_arrays(rng: np.random.Generator) -> None:
    """On random arrays β lies in [0, 360) and each conversion inverts the others to 1e-9°."""
    theta = rng.uniform(0.0, 360.0, 200)
    psi = rng.uniform(0.0, 360.0, 200)
    beta = relative_heading(theta, psi)
    assert np.all((beta >= 0.0) & (beta < 360.0))
    assert np.max(angular_distance(wave_from(beta, psi), theta)) < 1e-9
    assert np.max(angular_distance(vessel_heading_for(beta, theta), psi)) < 1e-9


def test_angular_distance_wraps() -> None:
    """Angular distance is taken the short way round the circle (350° to 10° is 20°)."""
    assert angular_distance(350.0, 10.0) == pytest.approx(20.0)
    assert angular_distance(0.0, 180.0) == pytest.approx(180.0)

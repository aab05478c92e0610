"""The papers' runs as scenarios (twin.sim.presets): valid, and what the docstring says."""

from __future__ import annotations

import numpy as np
import pytest

from twin.mechanisms import HybridBoardingSystem
from twin.sea import REGULAR_PRESETS
from twin.sim import PAPER_PRESETS, Scenario, simulate


@pytest.mark.parametrize("name", sorted(PAPER_PRESETS))
def test_preset_validates(name: str) -> None:
    """Each preset survives a round trip through the scenario's validation unchanged."""
    preset = PAPER_PRESETS[name]
    assert Scenario.model_validate(preset.model_dump()) == preset


def test_seed000_is_the_reference_run() -> None:
    """Hybrid system, MTMP, SOV, WMO sea state 4, heading 150°, 200 s at 0.05 s (seed 000)."""
    s = PAPER_PRESETS["seed000"]
    assert (s.mechanism, s.planner, s.vessel) == ("hybrid", "mtmp", "sov")
    assert (s.sea_state, s.hs, s.tp, s.spectrum, s.heading) == (4.0, None, None, "jonswap", 150.0)
    assert (s.duration, s.dt, s.seed, s.initial_state) == (200.0, 0.05, 0, None)
    assert s.sea() == pytest.approx((1.875, 6.85), abs=5e-3)  # docs/sea.md's WMO table


def test_seed004_raises_the_platform_in_the_same_sea() -> None:
    """DWA, 50 s, platform 1.1 m above its lowest state, gangway 3.5 m out (seed 004 §4),
    in `seed000`'s sea."""
    s, reference = PAPER_PRESETS["seed004"], PAPER_PRESETS["seed000"]
    assert (s.mechanism, s.planner, s.vessel, s.duration, s.dt) == (
        "hybrid", "dwa", "sov", 50.0, 0.05
    )  # fmt: skip
    lowest = HybridBoardingSystem().initial_state
    np.testing.assert_allclose(s.initial_state, lowest + np.r_[0, 0, 1.1, 0, 0, 0, 0, 0, 3.5])
    assert s.model_dump(exclude={"planner", "duration", "initial_state"}) == reference.model_dump(
        exclude={"planner", "duration", "initial_state"}
    )


@pytest.mark.parametrize("state", ["state1", "state2", "state3"])
def test_seed002_runs_the_table_2_waves(state: str) -> None:
    """4-UPR, PID, ASV, 30 s in seed 002 Table 2's regular waves."""
    s = PAPER_PRESETS[f"seed002_{state}"]
    assert (s.mechanism, s.planner, s.vessel, s.duration) == ("upr4", "pid", "asv", 30.0)
    assert s.components() is REGULAR_PRESETS[state]


def test_presets_are_read_only() -> None:
    """The mapping cannot be changed; a changed run is a copy."""
    with pytest.raises(TypeError):
        PAPER_PRESETS["seed000"] = Scenario()  # type: ignore[index]
    short = PAPER_PRESETS["seed000"].model_copy(update={"duration": 1.0})
    assert (short.duration, PAPER_PRESETS["seed000"].duration) == (1.0, 200.0)


def test_seed004_runs() -> None:
    """The first 5 s of seed 004 run from the raised state, inside every limit, no faults."""
    result = simulate(PAPER_PRESETS["seed004"].model_copy(update={"duration": 5.0}))
    assert result.series["t"].shape == (101,)
    np.testing.assert_allclose(result.series["xi"][0], PAPER_PRESETS["seed004"].initial_state)
    assert result.metrics["violations"] == 0
    assert result.metrics["faults"] == 0

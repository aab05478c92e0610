"""The papers' runs as scenarios (twin.sim.presets): valid, what the docstring says, and
matched to the papers' own severity (scripts/calibrate_presets.py, issue 14's targets)."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from twin.mechanisms import HybridBoardingSystem
from twin.sea import REGULAR_PRESETS
from twin.sim import PAPER_PRESETS, Scenario, SimulationResult, simulate, simulate_many

#: sea seeds the papers' numbers are matched over (scripts/calibrate_presets.py)
SEEDS = range(10)
#: Seed 000 Table 7 leg maxima [m] and seed 004 §4's method 1 leg maximum [m].
TABLE7_LEGS = {"pi": 4.243, "wpi": 4.102}
SEED004_LEGS = 4.71


@cache
def runs(preset: str, planner: str) -> tuple[SimulationResult, ...]:
    """The preset with `planner` over `SEEDS`."""
    base = PAPER_PRESETS[preset]
    return tuple(
        simulate_many(base.model_copy(update={"planner": planner, "seed": s}) for s in SEEDS)
    )


def mean_legs_max(preset: str, planner: str) -> float:
    return float(np.mean([r.metrics["table7"]["legs_max"] for r in runs(preset, planner)]))


@pytest.mark.parametrize("name", sorted(PAPER_PRESETS))
def test_preset_validates(name: str) -> None:
    """Each preset survives a round trip through the scenario's validation unchanged."""
    preset = PAPER_PRESETS[name]
    assert Scenario.model_validate(preset.model_dump()) == preset


def test_seed000_is_the_reference_run_in_the_matched_sea() -> None:
    """Hybrid system, MTMP, SOV, JONSWAP Hs 1.038 m, Tp 6.85 s at heading 225°, 200 s at 0.05 s."""
    s = PAPER_PRESETS["seed000"]
    assert (s.mechanism, s.planner, s.vessel) == ("hybrid", "mtmp", "sov")
    assert (s.hs, s.tp, s.spectrum, s.heading, s.spreading) == (1.038, 6.85, "jonswap", 225.0, None)
    assert (s.duration, s.dt, s.seed, s.initial_state) == (200.0, 0.05, 0, None)
    assert s.sea() == (1.038, 6.85)


def test_sea_state_4_presets_keep_the_former_reference_sea() -> None:
    """`seed000_ss4` and `seed004_ss4` are `seed000` and `seed004` in WMO sea state 4 from
    150° (Hs 1.875 m, Tp 6.85 s, docs/sea.md's table)."""
    for name in ("seed000", "seed004"):
        ss4, matched = PAPER_PRESETS[f"{name}_ss4"], PAPER_PRESETS[name]
        assert (ss4.sea_state, ss4.hs, ss4.tp, ss4.heading) == (4.0, None, None, 150.0)
        assert ss4.sea() == pytest.approx((1.875, 6.85), abs=5e-3)
        sea = {"hs", "tp", "heading", "sea_state"}
        assert ss4.model_dump(exclude=sea) == matched.model_dump(exclude=sea)


def test_seed004_raises_the_platform_in_its_own_matched_sea() -> None:
    """DWA, 50 s, platform 1.1 m above its lowest state, gangway 3.5 m out (seed 004 §4), in
    `seed000`'s sea shape with its own wave height."""
    s, reference = PAPER_PRESETS["seed004"], PAPER_PRESETS["seed000"]
    assert (s.mechanism, s.planner, s.vessel, s.duration, s.dt) == (
        "hybrid", "dwa", "sov", 50.0, 0.05
    )  # fmt: skip
    lowest = HybridBoardingSystem().initial_state
    np.testing.assert_allclose(s.initial_state, lowest + np.r_[0, 0, 1.1, 0, 0, 0, 0, 0, 3.5])
    assert s.hs == 3.086
    differ = {"planner", "duration", "initial_state", "hs"}
    assert s.model_dump(exclude=differ) == reference.model_dump(exclude=differ)


@pytest.mark.parametrize("planner", ["pi", "wpi"])
def test_seed000_sea_gives_table_7_leg_maxima(planner: str) -> None:
    """Over sea seeds 0-9, PI's and WPI's mean leg maxima are within 5 % of Table 7's 4.243
    and 4.102 m (calibrated to 0.5 mm for PI; WPI's follows from the same sea)."""
    assert mean_legs_max("seed000", planner) == pytest.approx(TABLE7_LEGS[planner], rel=0.05)


def test_seed000_sea_drives_pi_q2_up_as_table_7() -> None:
    """Table 7: PI's q2 reaches 14.93° and only −2.11°; ours drifts the same way on every seed
    (the heading's choice), and its mean extremes are one-sided the same way."""
    table = [r.metrics["table7"] for r in runs("seed000", "pi")]
    assert all(r.metrics["joints"]["q2"]["drift"] > 0 for r in runs("seed000", "pi"))
    assert np.mean([t["q2_max"] for t in table]) > 5 * abs(np.mean([t["q2_min"] for t in table]))


def test_seed004_sea_gives_method_1_leg_maximum() -> None:
    """Over sea seeds 0-9, conventional method 1's mean leg maximum is within 5 % of 4.71 m."""
    assert mean_legs_max("seed004", "conv1") == pytest.approx(SEED004_LEGS, rel=0.05)


def test_seed000_sea_is_milder_than_sea_state_4() -> None:
    """The former reference sea is harsher than seed 000's trajectory: PI's legs reach over
    4.8 m on average there (issue 14: 5.01 m), not 4.243 m."""
    assert mean_legs_max("seed000_ss4", "pi") > 4.8


def test_mtmp_stays_inside_every_limit_in_the_matched_sea() -> None:
    """Seed 000 §5.3: MTMP keeps every joint and leg inside its limits, on at least 9 of the
    10 seeds, with the slew within ±2° (Table 7: −1.25 … 1.04°) and the platform's Euler yaw
    held (Algorithm 1, `yaw_hold` = 1)."""
    metrics = [r.metrics for r in runs("seed000", "mtmp")]
    assert sum(m["violations"] == 0 for m in metrics) >= 9
    for m in metrics:
        q1 = m["joints"]["q1"]
        assert max(abs(q1["min"]), abs(q1["max"])) <= 2.0
        yaw = m["joints"]["yaw"]
        assert max(abs(yaw["min"]), abs(yaw["max"])) <= 0.2


def test_body_rate_reading_lets_q1_wander_in_sea_state_4() -> None:
    """Algorithm 1 on the body yaw rate (`yaw_hold` = 0) lets the platform's Euler yaw drift
    and q1 follow it, past Table 7's range; the default holds both (issue 14: 9.65°)."""
    base = PAPER_PRESETS["seed000_ss4"]
    body, euler = simulate_many(
        [base.model_copy(update={"seed": 2, "yaw_hold": h}) for h in (0.0, 1.0)]
    )

    def q1_extent(m: dict) -> float:
        return max(abs(m["joints"]["q1"]["min"]), abs(m["joints"]["q1"]["max"]))

    assert q1_extent(body.metrics) > 5.0
    assert q1_extent(euler.metrics) < 2.0
    assert abs(euler.metrics["joints"]["yaw"]["drift"]) < 0.2
    assert abs(body.metrics["joints"]["yaw"]["drift"]) > 3.0


@pytest.mark.parametrize("state", ["state1", "state2", "state3"])
def test_seed002_runs_the_table_2_waves(state: str) -> None:
    """4-UPR, PID, ASV, 30 s at dt = 5 ms in seed 002 Table 2's regular waves."""
    s = PAPER_PRESETS[f"seed002_{state}"]
    assert (s.mechanism, s.planner, s.vessel, s.duration, s.dt) == (
        "upr4",
        "pid",
        "asv",
        30.0,
        0.005,
    )
    assert s.components() is REGULAR_PRESETS[state]


def test_presets_are_read_only() -> None:
    """The mapping cannot be changed; a changed run is a copy."""
    with pytest.raises(TypeError):
        PAPER_PRESETS["seed000"] = Scenario()  # type: ignore[index]
    short = PAPER_PRESETS["seed000"].model_copy(update={"duration": 1.0})
    assert (short.duration, PAPER_PRESETS["seed000"].duration) == (1.0, 200.0)


@pytest.mark.parametrize("name", ["seed004", "seed004_ss4"])
def test_seed004_runs(name: str) -> None:
    """The first 5 s of seed 004 run from the raised state, inside every limit, no faults."""
    result = simulate(PAPER_PRESETS[name].model_copy(update={"duration": 5.0}))
    assert result.series["t"].shape == (101,)
    np.testing.assert_allclose(result.series["xi"][0], PAPER_PRESETS[name].initial_state)
    assert result.metrics["violations"] == 0
    assert result.metrics["faults"] == 0


def test_hybrid_presets_pin_their_sea_against_the_defaults() -> None:
    """The calibrated presets keep JONSWAP γ = 3.3 and 200 components whatever the scenario
    defaults (DNV's γ from Tp/√Hs, 800 components), so batch reproductions do not move."""
    default = Scenario()
    assert default.gamma is None and default.n_components == 800
    for name, preset in PAPER_PRESETS.items():
        if preset.mechanism == "hybrid":
            assert (preset.gamma, preset.n_components) == (3.3, 200), name

"""Metric functions: drift, seed 002's efficacy η, and what counts as a limit violation."""

from __future__ import annotations

import numpy as np
import pytest

from twin.mechanisms import HybridBoardingSystem, Upr4, Upu3Up
from twin.planners.platform_model import ANGLE_TOL, LENGTH_TOL
from twin.sim import Simulation, simulate
from twin.sim.metrics import drift, efficacy


def test_drift_of_a_ramp_is_its_rise_and_of_a_sine_nearly_zero() -> None:
    """The drift of a ramp is its rise over the run, and of a sine nearly zero."""
    t = np.linspace(0, 100, 2001)
    ramp = np.stack([0.02 * t, np.sin(2 * np.pi * t / 7)], -1)
    d = drift(t, ramp)
    assert d[0] == pytest.approx(2.0)
    assert abs(d[1]) < 0.05


def test_efficacy_both_forms() -> None:
    """Seed 002 eq (29) and SPEC erratum 11: a top tilting half as much gives η = 50 %."""
    bottom = np.abs(np.sin(np.linspace(0.1, 10, 500))) + 0.01
    result = efficacy(0.5 * bottom, bottom)
    assert result["eta"] == pytest.approx(50.0)
    assert result["eta_printed"] == pytest.approx(50.0)
    perfect = efficacy(np.zeros_like(bottom), bottom)
    assert perfect["eta"] == pytest.approx(100.0)


def test_efficacy_printed_form_explodes_near_zero_tilt_but_stays_finite() -> None:
    """Dividing by α_bottom (erratum 11): tiny bottom tilt gives a huge, finite value."""
    bottom = np.array([1e-6, 0.1, 0.1])
    top = np.array([0.05, 0.05, 0.05])
    result = efficacy(top, bottom)
    assert result["eta_printed"] < -1e5 and np.isfinite(result["eta_printed"])
    assert efficacy(np.zeros(3), np.zeros(3)) == {"eta_printed": 0.0, "eta": 0.0}


def test_drift_and_efficacy_equal_their_numpy_statements() -> None:
    """`drift` and `efficacy` (the compiled reduction's `drift_lane` and `efficacy_sums`, which
    the hybrid system's metrics run too) equal the least-squares slope and the two η forms
    written in numpy, to rounding; a bottom never tilted gives 0."""
    rng = np.random.default_rng(4)
    t = np.arange(801) * 0.05
    x = np.stack([0.02 * t, np.sin(t), 3.0 + 1e-3 * rng.standard_normal(t.size)], -1)
    tc = t - t.mean()
    want = (tc @ (x - x.mean(axis=0))) / (tc @ tc) * (t[-1] - t[0])
    np.testing.assert_allclose(drift(t, x), want, rtol=1e-12, atol=1e-12 * np.ptp(x))
    top, bottom = 0.01 * rng.random(t.size), 0.05 * rng.random(t.size)
    bottom[::7] = 0.0
    tilted = bottom > 1e-9
    result = efficacy(top, bottom)
    printed = np.mean((bottom[tilted] - top[tilted]) / bottom[tilted])
    assert result["eta_printed"] == pytest.approx(100 * printed, rel=1e-12)
    assert result["eta"] == pytest.approx(100 * (1 - top.sum() / bottom.sum()), rel=1e-12)
    assert efficacy(top, np.zeros_like(bottom)) == {"eta_printed": 0.0, "eta": 0.0}


@pytest.mark.parametrize(
    "lanes",
    [
        [{"planner": "mtmp", "duration": 3.0}, {"planner": "pi", "duration": 1.5, "seed": 1},
         {"planner": "dwa", "duration": 2.2, "joint_limits": "hold", "seed": 2},
         {"planner": "wpi", "duration": 0.3, "sea_state": 7}],
        [{"mechanism": "upr4", "duration": 1.0}, {"mechanism": "upr4", "duration": 0.4,
                                                  "planner": "ik", "joint_limits": "hold"}],
    ],
    ids=["hybrid", "upr4"],
)  # fmt: skip
def test_every_lanes_metrics_at_once_are_each_lanes_alone(lanes: list[dict]) -> None:
    """`results()` reduces the metrics of lanes of different durations in one call: each equals
    the lane's `result(i)` and the scenario simulated alone, fault counts included."""
    together = Simulation([{"sea_state": 6, **lane} for lane in lanes])
    together.run()
    results = together.results()
    for i, lane in enumerate(lanes):
        assert len(results[i].series["t"]) == round(lane["duration"] / 0.05) + 1
        assert results[i].metrics == together.result(i).metrics
        assert results[i].metrics == simulate({"sea_state": 6, **lane}).metrics


# -------------------------------------------------------- clamped samples count (record mode)

SEA_STATE_9 = {"sea_state": 9, "duration": 5.0, "seed": 0}


def run_both(scenario: dict) -> tuple[dict, dict, dict]:
    """(series, record-mode metrics, hold-mode metrics) of `scenario` at sea state 9."""
    record = simulate({**SEA_STATE_9, **scenario, "joint_limits": "record"})
    hold = simulate({**SEA_STATE_9, **scenario, "joint_limits": "hold"})
    return record.series, record.metrics, hold.metrics


def test_upu3up_clamped_samples_are_violations_in_record_mode() -> None:
    """The 3UPU_UP at sea state 9: the demand is clamped to the ±150 mm / ±20° box on nearly
    every step and the top sits on it; each such sample counts in `record` mode (issue 14: 0
    counted while 98 of 100 steps sat clamped), none in `hold` mode, where they are held."""
    series, record, hold = run_both({"mechanism": "upu3up", "planner": "pid"})
    m = Upu3Up()
    low, high = m.state_limits
    tol = np.array([LENGTH_TOL, ANGLE_TOL, ANGLE_TOL])
    state = series["state"]
    on_box = np.any((state <= low + tol) | (state >= high - tol), axis=1)
    beyond = np.any((state < low - tol) | (state > high + tol), axis=1)
    legs = series["legs"]
    on_stroke = np.any((legs <= m.leg_min + LENGTH_TOL) | (legs >= m.leg_max - LENGTH_TOL), axis=1)
    clamped = series["clipped"] > 0
    assert clamped.sum() >= 90  # of 101 samples
    assert on_box.sum() > 0 and not beyond.any()
    assert record["violations"] == int(np.sum(clamped | on_box | on_stroke))
    assert record["limit_violations"]["clamped"] == clamped.sum()
    assert record["limit_violations"]["state"] == on_box.sum()
    assert hold["violations"] == 0 and hold["fault_counts"]["joint_limit"] == clamped.sum()


def test_upr4_samples_at_its_end_stops_are_violations_in_record_mode() -> None:
    """The 4-UPR near full stroke (z = 0.84 m) at sea state 9: its actuators stop at 1.1225 m
    and the demand is clamped there; both count in `record` mode. In `hold` mode nothing
    does: the stroke is judged on the actuators, which never pass their stops, not on the
    legs of the least-squares state fitted to them (four legs, three DOFs), which reach past
    the stroke by millimetres there."""
    series, record, hold = run_both(
        {"mechanism": "upr4", "planner": "pid", "initial_state": [0.84, 0.0, 0.0]}
    )
    m = Upr4()
    at_end = np.any(series["legs"] >= m.stroke_max - 1e-9, axis=1)
    clamped = series["clipped"] > 0
    assert at_end.sum() > 10 and clamped.sum() > 10
    assert record["violations"] >= int(np.sum(at_end | clamped))
    assert record["limit_violations"]["stroke_max"] >= at_end.sum()
    assert record["limit_violations"]["clamped"] == clamped.sum()
    assert series["legs"].max() <= m.stroke_max
    fitted = m.leg_lengths(*series["state"].T)
    assert fitted.max() > m.stroke_max + 1e-4  # what the state's legs alone would count
    assert hold["limit_violations"]["stroke_max"] == 0 and hold["violations"] == 0


def test_hybrid_record_mode_counts_every_sample_at_or_past_a_limit() -> None:
    """The hybrid system at sea state 9 with MTMP: `record` mode clamps nothing (every step
    whole), and counts each sample with a virtual joint on or past its Table 6 limit or a leg
    past its stroke; `hold` mode stops them on the limits instead (held steps)."""
    series, record, hold = run_both({"mechanism": "hybrid", "planner": "mtmp"})
    H = HybridBoardingSystem()
    xi, legs = series["xi"], series["legs"]
    joints = np.any((xi <= H.lower + 1e-9) | (xi >= H.upper - 1e-9), axis=1)
    s = H.stewart
    bad_legs = np.any((legs < s.leg_min - 5e-4) | (legs > s.leg_max + 5e-4), axis=1)
    assert np.all(series["limit_scale"] == 1.0)  # nothing clamped in record mode
    assert record["violations"] == int(np.sum(joints | bad_legs)) > 50
    assert hold["violations"] == 0 and hold["fault_counts"]["joint_limit"] > 50

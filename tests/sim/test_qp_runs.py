"""The `qp` planner in the one engine: issue 15's targets on 200 s runs, lanes of every family
side by side, the interpreted engine, the closest feasible rates flagged, sweeps.

The targets (issue 15), measured on sea seeds 0-9, heading 150°, `record` mode:

- WMO sea state 4: no violation on any seed, tip position error ≤ 1 mm after 1 s, and the
  tip orientation error's maximum, averaged over the seeds, at most half of DWA's;
- Hs 3.0 m, Tp 8 s: no violation on any seed, tip position error ≤ 1 cm (after 1 s).
"""

from __future__ import annotations

from functools import cache

import numpy as np

from tests.figures import record
from twin.mechanisms import HybridBoardingSystem
from twin.runs.sweep import run_chunk
from twin.sim import Simulation, simulate, simulate_many

H = HybridBoardingSystem()
SEEDS = range(10)


@cache
def runs(planner: str, **sea: float) -> list:
    return simulate_many([{"planner": planner, "seed": s, "heading": 150.0, **sea} for s in SEEDS])


def position_error_after(result: object, t: float = 1.0) -> float:
    """[m] the largest tip position error from t on."""
    late = result.series["t"] >= t - 1e-9
    return float(np.linalg.norm(result.series["tip_error"][late, :3], axis=1).max())


def test_sea_state_4_targets() -> None:
    """At WMO 4 the QP keeps every limit on 10 seeds, the tip within 1 mm, and at most half
    DWA's tip orientation error."""
    qp, dwa = runs("qp", sea_state=4.0), runs("dwa", sea_state=4.0)
    violations = [r.metrics["violations"] for r in qp]
    errors = [position_error_after(r) for r in qp]
    turn = np.mean([r.metrics["tip_orientation_error_max"] for r in qp])
    turn_dwa = np.mean([r.metrics["tip_orientation_error_max"] for r in dwa])
    record("qp_sea_state_4", violations=violations, position_error_max_mm=1e3 * max(errors),
           orientation_error_max_mean_deg=turn, dwa_deg=turn_dwa)  # fmt: skip
    assert violations == [0] * 10
    assert max(errors) <= 1e-3
    assert turn <= turn_dwa / 2


def test_hs_3_tp_8_targets() -> None:
    """At Hs 3 m, Tp 8 s the QP keeps every limit on 10 seeds and the tip within 10 mm."""
    qp = runs("qp", hs=3.0, tp=8.0)
    violations = [r.metrics["violations"] for r in qp]
    errors = [position_error_after(r) for r in qp]
    record("qp_hs3_tp8", violations=violations, position_error_max_mm=1e3 * max(errors))
    assert violations == [0] * 10
    assert max(errors) <= 1e-2


def test_lanes_of_every_family_run_side_by_side() -> None:
    """One Simulation of MTMP, qp (record and hold), DWA and qp on another sea: each lane as
    its own run, to the last bit; each lane records its own family's diagnostics."""
    lanes = [
        {"planner": "mtmp", "seed": 1},
        {"planner": "qp", "seed": 1},
        {"planner": "dwa", "seed": 2},
        {"planner": "qp", "seed": 3, "joint_limits": "hold", "sea_state": 6.0},
    ]
    lanes = [{**lane, "duration": 20.0} for lane in lanes]
    together = Simulation(lanes)
    together.run()
    for i, lane in enumerate(lanes):
        alone = simulate(lane)
        got = together.result(i)
        np.testing.assert_array_equal(got.series["xi"], alone.series["xi"])
        assert got.metrics == alone.metrics
        assert ("qp_level" in got.series) == (lane["planner"] == "qp")
        assert ("weights" in got.series) == (lane["planner"] == "mtmp")
        assert ("position_share" in got.series) == (lane["planner"] == "dwa")


def test_the_interpreted_engine_gives_the_same_numbers() -> None:
    """The QP run in plain Python gives the compiled run's states to 1e-9 and the same active
    levels."""
    scenario = {"planner": "qp", "sea_state": 6.0, "duration": 5.0, "joint_limits": "hold"}
    compiled = simulate(scenario)
    plain = simulate(scenario, engine="python")
    np.testing.assert_allclose(plain.series["xi"], compiled.series["xi"], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(plain.series["qp_level"], compiled.series["qp_level"])


def test_a_start_past_the_stroke_takes_the_closest_feasible_rates() -> None:
    """Raised and rolled until legs are 0.2-0.3 m past their stroke: no rates meet every limit,
    the first steps solve level 2 (flagged INFEASIBLE, counted in the metrics), the legs come
    back inside within a second and stay there."""
    xi = H.working_state.copy()
    xi[2], xi[3] = 3.595, 0.3
    result = simulate({"planner": "qp", "duration": 10.0, "initial_state": list(xi)})
    levels = result.series["qp_level"]
    infeasible = int(np.count_nonzero(levels[1:] == 2))
    assert 0 < infeasible <= 5 and np.all(levels[10:] < 2)
    assert result.metrics["fault_counts"]["infeasible"] == infeasible
    assert result.metrics["faults"] == 0  # nothing was held
    late = result.series["t"] >= 1.0
    legs = result.series["legs"][late]
    assert legs.max() <= H.stewart.leg_max and legs.min() >= H.stewart.leg_min


def test_a_sweep_runs_qp() -> None:
    """A sweep chunk runs the QP planner and reports its row (operable at Hs 1 m)."""
    rows = run_chunk([{"planner": "qp", "hs": 1.0, "tp": 7.0, "seed": 0, "duration": 20.0,
                       "heading": 180.0, "beta": 0.7, "k_e": 25.0, "k_c": 9.0,
                       "mechanism": "hybrid", "dt": 0.05}], 0.05)  # fmt: skip
    assert rows[0]["planner"] == "qp" and rows[0]["operable"]


def test_the_step_needs_no_guard() -> None:
    """In `hold` mode, the qp planner at sea state 7 from near its limits never has a step
    shortened: its own limits are met before the guard looks."""
    start = H.working_state + 0.6 * np.r_[0, 0, 0, 0, 0, 1, 1, 1, 0] * (H.upper - H.working_state)
    result = simulate({"planner": "qp", "sea_state": 7.0, "duration": 30.0,
                       "joint_limits": "hold", "initial_state": list(start)})  # fmt: skip
    assert result.metrics["fault_counts"]["joint_limit"] == 0
    assert result.metrics["violations"] == 0
    assert result.series["qp_active"].max() > 0


def test_the_knobs_range_ends_keep_the_limits() -> None:
    """At the ends of the knobs' ranges (the least regularisation, no orientation or secondary
    term; the most of each) and the coarsest dt in sea state 9 of the default sea, no step
    needs its limits relaxed and none is passed: the engine's solver meets level 1 however the
    terms are weighted, including where the peer solver (DAQP) failed."""
    ends = [
        {"qp_damping": 1e-4, "w_orientation": 0.0, "w_secondary": 0.0},
        {"qp_damping": 1.0, "w_orientation": 100.0, "w_secondary": 1.0, "limit_gain": 1.0},
        {"qp_damping": 1e-4, "beta": 1.0, "l": 4.0, "k_e": 200.0},
    ]
    # the default sea (DNV γ, 800 components), no sea pinned. The one "infeasible step" once
    # counted at the least-regularised end was the peer solver's failure, not the QP's: DAQP
    # gave up on a level-1 Hessian of condition 3.9e10 that the engine's own solver
    # (Goldfarb–Idnani, issue 29) solves, its constraints met to 9e-15 with an LP margin of
    # 0.73; the step was feasible all along
    results = simulate_many([{"planner": "qp", "sea_state": 9.0, "dt": 0.2, "duration": 40.0,
                              **knobs} for knobs in ends])  # fmt: skip
    for knobs, result in zip(ends, results, strict=True):
        assert result.metrics["fault_counts"]["infeasible"] == 0, knobs
        assert result.metrics["violations"] == 0, knobs

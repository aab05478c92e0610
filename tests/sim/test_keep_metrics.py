"""Lanes that keep only what is asked (issue 28 item 6): `Simulation(keep="metrics")` reduces every
mechanism's metrics chunk by chunk (`twin.sim.metrics.HybridReduction`, `PlatformReduction`), to
the bits of the whole-series reduction, with memory that does not grow with the run's length."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from twin.errors import TwinError
from twin.sim import simulate_many
from twin.sim.engine import Simulation
from twin.sim.kernels import metrics as kernel
from twin.sim.lanes import HybridLanes
from twin.sim.metrics import HybridReduction, hybrid_metrics_lanes

from .kernels.test_metrics_kernel import assert_matches_oracle

#: hybrid lanes of every planner family, both joint-limit modes and different durations, in a
#: sea rough enough that limits are reached (violations and fault counts are not all zero)
LANES = [
    {"planner": "mtmp", "duration": 6.0, "seed": 3},
    {"planner": "pi", "duration": 4.35, "seed": 1, "joint_limits": "hold"},
    {"planner": "dwa", "duration": 5.2, "seed": 2},
    {"planner": "qp", "duration": 0.3, "seed": 4},
]


def held_bytes(simulation: Simulation) -> int:
    """[bytes] the arrays a Simulation keeps between chunks: its history and its sums."""
    kept = sum(values.nbytes for values in simulation.history.data.values())
    if simulation._reduction is not None:
        kept += simulation._reduction.acc.nbytes
    return kept


def test_chunk_by_chunk_metrics_are_the_whole_series_metrics_to_the_bit() -> None:
    """Stepped in uneven pieces (a chunk boundary inside the settling samples and everywhere
    else), the reduced lanes' metrics, fault counts included, equal the full series' exactly,
    and those are the numpy formulas' (`assert_matches_oracle`, 1e-12)."""
    scenarios = [{"sea_state": 7, **lane} for lane in LANES]
    full = Simulation(scenarios)
    full.run()
    want = full.results()
    reduced = Simulation(scenarios, keep="metrics")
    for size in [3, 5, 1, 17, 64, 7]:
        reduced.advance(size)
    while not reduced.done:
        reduced.advance(29)
    got = reduced.results()
    assert sum(r.metrics["violations"] for r in want) > 0  # a comparison that can differ
    for lane, (g, w) in enumerate(zip(got, want, strict=True)):
        assert g.series == {}
        assert g.metrics == w.metrics, LANES[lane]
        assert_matches_oracle(
            {k: v for k, v in w.metrics.items()
             if k not in ("faults", "fault_counts", "tracking_diverged")},  # the engine's
            w.series,
            w.scenario.joint_limits,
        )


@pytest.mark.parametrize("mechanism", ["hybrid", "upu3up", "upr4"])
def test_simulate_many_keeping_metrics_gives_the_same_metrics_without_series(
    mechanism: str,
) -> None:
    """`simulate_many(keep="metrics")`: the metrics of `simulate_many()`, series empty, and the
    history of one sample alone."""
    scenarios = [{"mechanism": mechanism, "sea_state": 6, "duration": 3.0, "seed": s}
                 for s in range(3)]  # fmt: skip
    full = simulate_many(scenarios)
    reduced = simulate_many(scenarios, keep="metrics")
    for r, f in zip(reduced, full, strict=True):
        assert r.series == {} and len(f.series["t"]) == 61
        assert r.metrics == f.metrics
    simulation = Simulation(scenarios, keep="metrics")
    simulation.run()
    assert {values.shape[1] for values in simulation.history.data.values()} == {1}


@pytest.mark.parametrize("mechanism", ["hybrid", "upu3up", "upr4"])
def test_memory_kept_does_not_grow_with_the_run(mechanism: str) -> None:
    """A reduced run of 2,000 s keeps the arrays of one of 200 s, byte for byte; a run keeping its
    series keeps ten times more (the comparison can fail)."""
    kept = {}
    for duration in (200.0, 2000.0):
        for keep in ("series", "metrics"):
            scenario = {"mechanism": mechanism, "sea_state": 5, "duration": duration}
            simulation = Simulation(scenario, keep=keep)
            simulation.run()
            kept[duration, keep] = held_bytes(simulation)
    assert kept[200.0, "metrics"] == kept[2000.0, "metrics"]
    assert kept[2000.0, "series"] > 9 * kept[200.0, "series"] > 100 * kept[200.0, "metrics"]


def test_a_reduction_takes_samples_in_order_and_gives_metrics_at_the_end() -> None:
    """`HybridReduction` refuses samples out of order and metrics before every lane's end; fed
    a series in two pieces it equals `hybrid_metrics_lanes` of it."""
    simulation = Simulation({"sea_state": 6, "duration": 2.0})
    simulation.run()
    data = {key: simulation.history.data[key] for key in kernel.REDUCED}
    T = data["t"].shape[1]
    reduction = HybridReduction(simulation.mechanism, np.array([T]), ["record"], False)
    with pytest.raises(ValueError, match="samples from 5 on"):
        reduction.add({key: v[:, 5:] for key, v in data.items()}, 5)
    reduction.add({key: v[:, :12] for key, v in data.items()}, 0)
    with pytest.raises(ValueError, match=f"have \\[12\\] of \\[{T}\\] samples"):
        reduction.results()
    reduction.add({key: v[:, 12:] for key, v in data.items()}, 12)
    want = hybrid_metrics_lanes(data, np.array([T]), simulation.mechanism, ["record"], True)
    assert reduction.results() == want


def test_keep_is_checked() -> None:
    """An unknown keep, a ring with keep="metrics", results before the end and a new duration
    while reducing are each refused, saying what is allowed."""
    with pytest.raises(TwinError, match=r"keep: unknown 'all'; allowed: \['series', 'metrics'\]"):
        Simulation({"duration": 1.0}, keep="all")
    with pytest.raises(TwinError, match="history_limit"):
        Simulation({"duration": 1.0}, history_limit=100, keep="metrics")
    simulation = Simulation({"duration": 1.0}, keep="metrics")
    simulation.advance(5)
    with pytest.raises(TwinError, match="at step 5 of 20"):
        simulation.results()
    with pytest.raises(TwinError, match="duration cannot change"):
        simulation.update({"duration": 2.0})
    simulation.update({"hs": 1.0})  # a sea change is fine
    simulation.run()
    assert simulation.result().metrics["violations"] >= 0


def test_hybrid_lanes_keeping_metrics_skip_the_records_pass(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """keep="metrics" on the hybrid system records each sample as it reduces it
    (`HybridLanes.reduce`): the chunk's records pass (`HybridLanes.records`) never runs, and
    the newest sample the history keeps is the one a kept series ends with."""
    calls = {"records": 0, "reduce": 0}
    records, reduce = HybridLanes.records, HybridLanes.reduce

    def counted(name: str, method: Any) -> Any:
        def call(*args: Any, **kwargs: Any) -> Any:
            calls[name] += 1
            return method(*args, **kwargs)

        return call

    monkeypatch.setattr(HybridLanes, "records", counted("records", records))
    monkeypatch.setattr(HybridLanes, "reduce", counted("reduce", reduce))
    scenarios = [{"sea_state": 6, "seed": s, **lane} for s, lane in enumerate(LANES)]
    reduced = Simulation(scenarios, keep="metrics")
    while not reduced.done:
        reduced.advance(23)
    assert calls == {"records": 0, "reduce": -(-reduced.n_steps // 23)}
    full = Simulation(scenarios)
    full.run()
    for lane in range(len(LANES)):
        got, want = reduced.latest(lane), full.latest(lane)
        assert got.keys() == want.keys()
        for key, values in want.items():
            np.testing.assert_array_equal(got[key], values, err_msg=key)


def test_a_non_finite_record_is_held_as_a_kept_series_holds_it() -> None:
    """A target row that turns a sample's record non-finite (its tip error), or a state that is
    not finite: the reduced lanes fall back to recording the chunk and holding the sample
    (`hold_nonfinite`), so their metrics and fault counts still equal a kept series'."""

    def spoil(simulation: Simulation, row: int, column: int) -> None:
        run = simulation.lanes.run

        def spoiled(*args: Any, **kwargs: Any) -> None:
            run(*args, **kwargs)
            xs, targets = args[1], args[2]
            if simulation.k == 20:  # the chunk of steps 21 …
                (xs if column < 0 else targets)[1, row, abs(column)] = np.nan

        simulation.lanes.run = spoiled  # type: ignore[method-assign]

    scenarios = [{"sea_state": 6, "seed": s, **lane} for s, lane in enumerate(LANES[:3])]
    for column in (0, -8):  # a target's rotation; a state's d3
        full = Simulation(scenarios)
        reduced = Simulation(scenarios, keep="metrics")
        for simulation in (full, reduced):
            spoil(simulation, 4, column)
            for size in (20, 30, 1000):
                simulation.advance(size)
        want, got = full.results(), reduced.results()
        assert want[1].metrics["fault_counts"]["planner"] > 0  # the sample was held
        for g, w in zip(got, want, strict=True):
            assert g.metrics == w.metrics


def test_keeping_and_reducing_share_one_compiled_records_runner() -> None:
    """The records runner keeps a series or reduces it as it records (`hybrid_record_lane`)
    with the same argument types: a run keeping its metrics adds no compiled signature to
    those a run keeping its series made (one compile of the inlined record, not two)."""
    pytest.importorskip("numba")
    from twin.sim.kernels.records import compiled_records

    runner = compiled_records(False)  # one lane: the serial runner, which every form calls
    scenario = {"planner": "mtmp", "sea_state": 6, "duration": 0.5}
    Simulation(scenario).run()
    kept = set(runner.signatures)
    assert kept  # the series run recorded through it
    Simulation(scenario, keep="metrics").run()
    assert set(runner.signatures) == kept

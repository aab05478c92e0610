"""Operability sweeps and the one executor they run on: Dask equals in-process, calm seas are
operable, bad requests are named; the executor runs sweeps, runs (with progress and a budget)
and scripts' maps on the same workers, and closes at once."""

from __future__ import annotations

import gc
import json
import time

import numpy as np
import pytest
from distributed import Client, Security

from tests.timing import scaled
from twin.runs.executor import BudgetExceeded, Executor, map_unordered, unpack_series
from twin.runs.sweep import (
    MAX_CELLS,
    MAX_RUNS,
    SweepSpec,
    SweepStopped,
    heatmap_png,
    run_sweep,
)
from twin.sim import simulate

SMALL = {"hs": [0.0, 2.5], "tp": [7.0], "planner": ["mtmp", "pi"], "seeds": 2, "duration": 3.0}
#: the longest run a scenario may be: 200 000 steps on the finest sea
LONGEST = {"mechanism": "hybrid", "n_components": 2048, "dt": 0.005, "duration": 1000.0}


def steps_of(fields: dict) -> tuple[str, int]:
    """A script's job (as scripts/reproduce.py maps them): a run's steps, by name."""
    fields = dict(fields)
    name = fields.pop("name")
    return name, len(simulate(fields).series["t"]) - 1


def test_one_executor_runs_sweeps_runs_and_maps() -> None:
    """A two-worker LocalCluster, started once: a sweep gives the same table as in process; a
    run reports its progress and comes back packed, equal to `simulate`; a script's map runs
    there too; its workers froze their start-up objects; its scheduler takes no client without
    the cluster's TLS key; a run over its budget fails saying so; zero steps are refused; and
    closing it while a long run is in hand takes seconds."""
    seen: list[tuple[int, int]] = []
    local = run_sweep(
        SMALL, scheduler="in-process", progress=False, chunk_size=3,
        on_progress=lambda done, total: seen.append((done, total)),
    )  # fmt: skip
    assert seen == [(3, 8), (6, 8), (8, 8)]
    executor = Executor.start(n_workers=2)
    try:
        assert executor.info()["workers"] == 2 and executor.where == "local cluster"
        address = executor.client.scheduler.address
        assert address.startswith("tls://127.0.0.1:"), address
        # each worker froze its start-up objects (the kernels) once they were loaded
        frozen = executor.client.run(gc.get_freeze_count)
        assert len(frozen) == 2 and min(frozen.values()) > 10_000, frozen
        # a client in plain TCP, and one over TLS with a key of its own, are both turned away
        for stranger, security in ((address.replace("tls://", "tcp://"), None),
                                   (address, Security.temporary())):  # fmt: skip
            with pytest.raises((OSError, TimeoutError)):
                Client(stranger, timeout=2, set_as_default=False, security=security)
        cluster = run_sweep(SMALL, executor=executor, chunk_size=2, progress=False)
        assert cluster.scheduler == "local cluster"
        assert len(cluster.runs) == len(local.runs) == 8
        columns = ["runs", "operable_runs", "operability", "violations_max"]
        assert cluster.table[columns].equals(local.table[columns])
        np.testing.assert_allclose(
            cluster.table["tip_position_error_max"], local.table["tip_position_error_max"],
            rtol=1e-9,
        )  # fmt: skip

        reports: list[dict] = []
        executor.subscribe(reports.append)
        scenario = {"sea_state": 3, "duration": 5.0}
        output = executor.run(scenario, name="run-1").result()
        expected = simulate(scenario)
        assert output.metrics == expected.metrics and output.steps == 100
        np.testing.assert_array_equal(unpack_series(output.series)["xi"], expected.series["xi"])
        deadline = time.monotonic() + scaled(5)
        while not reports and time.monotonic() < deadline:
            time.sleep(0.05)
        assert reports[0]["name"] == "run-1" and reports[0]["status"] == "running"

        jobs = [{"name": f"job-{i}", "mechanism": "upr4", "duration": 0.5 * (i + 1)}
                for i in range(4)]  # fmt: skip
        assert sorted(executor.map_unordered(steps_of, jobs)) == [
            ("job-0", 10), ("job-1", 20), ("job-2", 30), ("job-3", 40)
        ]  # fmt: skip

        with pytest.raises(BudgetExceeded, match=r"wall-clock budget of 0\.05 s"):
            executor.run(LONGEST, name="long", budget=0.05).result()
        with pytest.raises(ValueError, match="zero steps"):
            executor.run({"duration": 0.01}, name="zero").result()

        busy = executor.run(LONGEST, name="busy")
        time.sleep(0.5)
    finally:
        start = time.monotonic()
        executor.close()
        closed = time.monotonic() - start
    assert busy.cancelled() or not busy.done() or busy.status != "finished"
    assert closed < scaled(5.0), closed


def test_a_sweep_stops_when_told() -> None:
    """A sweep told to stop raises SweepStopped, and the executor still runs a full sweep
    afterwards."""
    with Executor.start("in-process") as executor:
        with pytest.raises(SweepStopped):
            run_sweep(SMALL, executor=executor, chunk_size=1, progress=False, stop=lambda: True)
        assert run_sweep(SMALL, executor=executor, progress=False).table["runs"].sum() == 8


def test_map_unordered_starts_and_closes_its_own_executor() -> None:
    """map_unordered with a scheduler name runs every job on its own executor and returns each
    result."""
    jobs = [{"name": "a", "duration": 0.5}, {"name": "b", "duration": 1.0}]
    assert sorted(map_unordered(steps_of, jobs, scheduler="in-process")) == [("a", 10), ("b", 20)]


def test_calm_sea_is_fully_operable_with_mtmp() -> None:
    """Hs = 0 and WMO 1 (Hs ≤ 0.1 m): every MTMP run holds the tip, no limit touched."""
    spec = SweepSpec(hs=[0.0, 0.1], tp=[3.0, 6.0], planner=["mtmp"], seeds=2, duration=10.0)
    result = run_sweep(spec, scheduler="in-process", progress=False)
    assert (result.table["operability"] == 1.0).all()
    assert result.runs["operable"].all() and len(result.runs) == 8


def test_table_and_heatmap_export(tmp_path) -> None:
    """The table is JSON-ready with the threshold stated; the heatmap is a PNG."""
    result = run_sweep({**SMALL, "planner": ["mtmp"], "seeds": 1}, scheduler="in-process",
                       progress=False)  # fmt: skip
    data = json.loads(json.dumps(result.to_dict()))
    assert data["tip_error_threshold"] == 0.05 and "0.05 m" in data["criterion"]
    assert len(data["cells"]) == 2 and {"hs", "tp", "operability"} <= data["cells"][0].keys()
    path = heatmap_png(result, tmp_path / "operability.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"hs": []}, "hs: empty axis"),
        ({"planner": []}, "planner: empty axis"),
        ({"tp": [float("nan")]}, "tp"),
        ({"beta": [0.5, 1.5]}, "beta"),
        ({"k_e": [25.0, 25.0]}, "k_e: repeated"),
        ({"planner": ["pid"]}, "planner"),
        ({"hs": list(np.linspace(0, 5, 80)), "tp": list(np.linspace(4, 12, 80))},
         f"allowed at most {MAX_CELLS}"),
        ({"hs": list(np.linspace(0, 5, 50)), "tp": list(np.linspace(4, 12, 50)), "seeds": 10},
         f"allowed at most {MAX_RUNS}"),
        ({"seeds": 0}, "seeds"),
        ({"tip_error_threshold": float("nan")}, "tip_error_threshold"),
        ({"scenario": {"hs": 1.0}}, "scenario"),
        ({"scenario": {"gamma": 50.0}}, "gamma"),
        ({"duration": 0.01}, "zero steps"),
        ({"planner": [""]}, "planner"),
    ],
)  # fmt: skip
def test_bad_requests_name_the_field(fields: dict, message: str) -> None:
    """A bad SweepSpec raises ValueError naming the field at fault."""
    with pytest.raises(ValueError, match=message):
        SweepSpec(**fields)


def test_bad_scheduler_is_named() -> None:
    """An unknown scheduler raises ValueError naming the scheduler."""
    with pytest.raises(ValueError, match="scheduler"):
        run_sweep(SMALL, scheduler="localhost:8786", progress=False)


def test_a_sweep_around_a_scenario_centres_its_sea_and_runs_any_mechanism(tmp_path) -> None:
    """`spec_around` (the viewer's Operability folder) spans Hs × Tp with the scenario's own
    sea in the middle and keeps its planner and knobs; a small platform's sweep runs; the
    heatmap rings a sea given to it."""
    from twin.runs.sweep import spec_around
    from twin.sim.scenario import Scenario

    scenario = Scenario(mechanism="upr4", sea_state=3, kp=90.0, joint_limits="hold")
    spec = spec_around(scenario, seeds=1, duration=2.0)
    hs, tp = scenario.sea()
    assert spec.mechanism == "upr4" and spec.planner == ["pid"]
    assert (spec.hs[2], spec.tp[1]) == (hs, tp)
    assert (len(spec.hs), len(spec.tp)) == (5, 3)
    assert spec.scenario["kp"] == 90.0 and spec.scenario["joint_limits"] == "hold"
    result = run_sweep(spec, scheduler="in-process", progress=False)
    assert len(result.table) == 15 and set(result.runs["planner"]) == {"pid"}
    ringed = heatmap_png(result, tmp_path / "ringed.png", mark=(hs, tp)).read_bytes()
    plain = heatmap_png(result, tmp_path / "plain.png").read_bytes()
    assert ringed[:4] == b"\x89PNG" and ringed != plain
    with pytest.raises(ValueError, match="planner"):
        SweepSpec(mechanism="upr4", planner=["mtmp"])


@pytest.mark.parametrize(
    ("fields", "points", "span", "expected_hs", "expected_tp"),
    [
        # 7 × 5 cells over ± 30 % and ± 1 s around Hs 2 m, Tp 8 s
        ({"hs": 2.0, "tp": 8.0}, (7, 5), (0.3, 1.0),
         [1.4, 1.6, 1.8, 2.0, 2.2, 2.4, 2.6], [7.0, 7.5, 8.0, 8.5, 9.0]),
        # Tp near its lowest allowed value: clipped to 1 s, the values clipped onto it once
        ({"hs": 1.0, "tp": 2.0}, (3, 7), (0.5, 5.0),
         [0.5, 1.0, 1.5], [1.0, 2.0, 3.67, 5.33, 7.0]),
        # a calm sea: Hs from 0 over the width of the grid around a 1 m sea
        ({"hs": 0.0, "tp": 6.0}, (5, 3), (0.9, 2.0),
         [0.0, 0.45, 0.9, 1.35, 1.8], [4.0, 6.0, 8.0]),
        # even counts: the lower of the two middle values becomes the current one
        ({"hs": 1.0, "tp": 8.0}, (4, 2), (0.6, 3.0), [0.4, 1.0, 1.2, 1.6], [8.0, 11.0]),
    ],
)  # fmt: skip
def test_spec_around_takes_its_grid_from_points_and_spans(
    fields: dict, points: tuple, span: tuple, expected_hs: list, expected_tp: list
) -> None:
    """`spec_around`'s counts and spans (the viewer's Operability sliders) set the axes; the
    scenario's own Hs and Tp are cells exactly, Tp stays within the allowed periods."""
    from twin.runs.sweep import spec_around
    from twin.sim.scenario import TP_RANGE, Scenario

    scenario = Scenario(**fields)
    hs, tp = scenario.sea()
    spec = spec_around(scenario, hs_points=points[0], tp_points=points[1], hs_span=span[0],
                       tp_span=span[1], seeds=3, duration=20.0)  # fmt: skip
    assert spec.hs == pytest.approx(expected_hs) and spec.tp == pytest.approx(expected_tp)
    assert hs in spec.hs and tp in spec.tp  # exactly, not just near
    assert TP_RANGE[0] <= min(spec.tp) and max(spec.tp) <= TP_RANGE[1]
    assert (spec.seeds, spec.duration) == (3, 20.0)


def test_spec_around_defaults_are_the_old_grid() -> None:
    """No counts or spans given: 5 Hs over 0.5 … 1.5 × Hs, 3 Tp over ± 2 s, as before."""
    from twin.runs.sweep import spec_around
    from twin.sim.scenario import Scenario

    spec = spec_around(Scenario(hs=2.0, tp=8.0))
    assert spec.hs == [1.0, 1.5, 2.0, 2.5, 3.0] and spec.tp == [6.0, 8.0, 10.0]
    calm = spec_around(Scenario(hs=0.0, tp=8.0))
    assert calm.hs == [0.0, 0.25, 0.5, 0.75, 1.0]


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"hs_points": 1}, "hs_points: got 1, allowed a whole number 2 … 11"),
        ({"tp_points": 12}, "tp_points: got 12, allowed a whole number 2 … 11"),
        ({"hs_points": 4.0}, "hs_points: got 4.0, allowed a whole number"),
        ({"tp_points": True}, "tp_points: got True"),
        ({"hs_span": 0.0}, "hs_span: got 0.0, allowed 0 < hs_span < 1"),
        ({"hs_span": 1.0}, "hs_span: got 1.0, allowed 0 < hs_span < 1"),
        ({"hs_span": -0.2}, "hs_span: got -0.2"),
        ({"hs_span": float("nan")}, "hs_span: got nan"),
        ({"tp_span": 0.0}, "tp_span: got 0.0, allowed 0 < tp_span ≤ 10 s"),
        ({"tp_span": 10.5}, "tp_span: got 10.5, allowed 0 < tp_span ≤ 10 s"),
        ({"tp_span": float("inf")}, "tp_span: got inf"),
        ({"tp_span": "2"}, "tp_span: got '2'"),
    ],
)
def test_spec_around_names_a_bad_grid_argument(arguments: dict, message: str) -> None:
    """spec_around with a bad grid argument raises TwinError naming it."""
    from twin.errors import TwinError
    from twin.runs.sweep import spec_around
    from twin.sim.scenario import Scenario

    with pytest.raises(TwinError, match=message.replace("(", r"\(")):
        spec_around(Scenario(hs=1.0, tp=8.0), **arguments)

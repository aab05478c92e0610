"""Operability sweeps: Dask equals in-process, calm seas are operable, bad requests are named."""

from __future__ import annotations

import json

import numpy as np
import pytest

from twin.sim.sweep import MAX_CELLS, MAX_RUNS, SweepSpec, heatmap_png, run_sweep

SMALL = {"hs": [0.0, 2.5], "tp": [7.0], "planner": ["mtmp", "pi"], "seeds": 2, "duration": 3.0}


def test_local_cluster_equals_in_process() -> None:
    """A two-worker LocalCluster gives the same table as the same sweep run in this process."""
    seen: list[tuple[int, int]] = []
    local = run_sweep(
        SMALL, scheduler="in-process", progress=False, chunk_size=3,
        on_progress=lambda done, total: seen.append((done, total)),
    )  # fmt: skip
    assert seen == [(3, 8), (6, 8), (8, 8)]
    cluster = run_sweep(SMALL, n_workers=2, chunk_size=2, progress=False)
    assert cluster.scheduler == "local cluster"
    assert len(cluster.runs) == len(local.runs) == 8
    columns = ["runs", "operable_runs", "operability", "violations_max"]
    assert cluster.table[columns].equals(local.table[columns])
    np.testing.assert_allclose(
        cluster.table["tip_position_error_max"], local.table["tip_position_error_max"], rtol=1e-9
    )


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
    ],
)  # fmt: skip
def test_bad_requests_name_the_field(fields: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SweepSpec(**fields)


def test_bad_scheduler_is_named() -> None:
    with pytest.raises(ValueError, match="scheduler"):
        run_sweep(SMALL, scheduler="localhost:8786", progress=False)

"""REST API through httpx: contracts, runs equal simulate(), persistence, live patches, auth,
and the attacks of issue 13 (Host spoofing, refused requests that must change nothing, the
run budget, a store file that vanishes, long steps, token guessing)."""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
from fastapi.testclient import TestClient

from tests.figures import record
from tests.web.support import SAME_ORIGIN, TOKEN, access, wait_for
from twin.mechanisms import MECHANISMS
from twin.planners import PLANNERS, PlannerParameters
from twin.runs.executor import IN_PROCESS, Executor
from twin.sea.sea_states import WMO_SEA_STATES
from twin.sim import Scenario, simulate
from twin.sim.live import LiveSession
from twin.sim.result import flat_columns
from twin.web import JobRunner, RunStore, create_app
from twin.web.access import MIN_TOKEN, Access

SHORT = {"mechanism": "hybrid", "planner": "mtmp", "sea_state": 3, "duration": 2.0}
#: synchronous cap of the test app: 100 steps (5 s at dt 0.05), so a 10 s run becomes a job
SYNC_STEPS = 100
#: the longest run a scenario may be: 200 000 steps on the finest sea
LONGEST = {"mechanism": "upr4", "planner": "pid", "n_components": 2048, "dt": 0.005,
           "duration": 1000.0}  # fmt: skip


@pytest.fixture(scope="module")
def executor() -> Iterator[Executor]:
    """One in-process executor (a Dask worker thread) for every app of this module."""
    with Executor.start(IN_PROCESS) as executor:
        yield executor


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RunStore]:
    with RunStore(tmp_path_factory.mktemp("data") / "runs.sqlite") as store:
        yield store


@pytest.fixture(scope="module")
def client(store: RunStore, executor: Executor) -> Iterator[TestClient]:
    """An app with its runners on the executor (the lifespan), shared by the run tests."""
    app = create_app(
        LiveSession({"sea_state": 3}), store, access=access(), executor=executor,
        jobs=JobRunner(store, sync_max_steps=SYNC_STEPS), viewer_port=8080,
    )  # fmt: skip
    with TestClient(app) as client:
        yield client


@pytest.fixture(scope="module")
def done_run(client: TestClient) -> dict[str, Any]:
    response = client.post("/api/runs", json=SHORT)
    assert response.status_code == 201, response.text
    return response.json()


@pytest.fixture
def live() -> LiveSession:
    """A session that is not started: only requests move it, so snapshots are comparable."""
    return LiveSession({"sea_state": 3})


def live_client(live: LiveSession, tmp_path: Path, token: str | None = None) -> TestClient:
    # No `with`: the lifespan (executor, runners) is not needed by the live endpoints.
    return TestClient(create_app(live, RunStore(tmp_path / "runs.sqlite"), access=access(token)))


def wait_finished(client: TestClient, path: str, timeout: float = 60.0) -> dict[str, Any]:
    """GET `path` (a run or a sweep) until it is done or failed; its last answer."""
    answer: dict[str, Any] = {}

    def finished() -> bool:
        nonlocal answer
        answer = client.get(path).json()
        return answer["status"] in ("done", "failed")

    assert wait_for(finished, timeout, poll=0.1), f"{path} not done after {timeout} s: {answer}"
    return answer


# -- registries ---------------------------------------------------------------------------------


def test_openapi_lists_exactly_the_api_paths(client: TestClient) -> None:
    """The OpenAPI document lists exactly the API's paths: none missing, none extra."""
    paths = client.get("/openapi.json").json()["paths"]
    assert set(paths) == {
        "/api/health", "/api/mechanisms", "/api/planners", "/api/sea-states", "/api/runs",
        "/api/runs/{run_id}", "/api/runs/{run_id}/series", "/api/live", "/api/live/reset",
        "/api/live/pause", "/api/live/play", "/api/live/step", "/api/live/replay",
        "/api/sweeps", "/api/sweeps/{sweep_id}", "/api/sweeps/{sweep_id}/heatmap.png",
        "/api/runs/{run_id}/cancel", "/api/sweeps/{sweep_id}/cancel",
        "/api/runs/{run_id}/pin", "/api/sweeps/{sweep_id}/pin",
        "/api/workability", "/api/workability/records", "/api/workability/{job_id}",
        "/api/workability/{job_id}/{plot}.png", "/api/workability/{job_id}/cancel",
        "/api/workability/{job_id}/rows.csv",
        "/api/onboard", "/api/onboard/{job_id}", "/api/onboard/{job_id}/timeline.png",
        "/api/motion-logs", "/api/motion-logs/file", "/api/motion-logs/{log_id}",
    }  # fmt: skip
    assert client.get("/docs").status_code == 200


def test_health(client: TestClient, executor: Executor) -> None:
    """Health reports "ok", the version, the viewer's port and the executor as started."""
    health = client.get("/api/health").json()
    assert {k: health[k] for k in ("status", "version", "viewer_port")} == {
        "status": "ok",
        "version": "0.1.0",
        "viewer_port": 8080,
    }
    assert health["executor"] == {
        "scheduler": "in-process", "workers": 1, "started": executor.started
    }


def test_landing_page_links_viewer_docs_and_live(client: TestClient) -> None:
    """The landing page is HTML linking the docs, the live session, runs, replay and the 3D view."""
    response = client.get("/")
    assert response.status_code == 200 and response.headers["content-type"].startswith("text/html")
    for needle in ('href="/docs"', 'href="/redoc"', "/api/live", "/api/runs", "viewer_port",
                   "watch in 3D", "/api/live/replay"):
        assert needle in response.text


def test_mechanisms_name_their_planners(client: TestClient) -> None:
    """Each mechanism lists the registry's planners for it and a default among them."""
    mechanisms = {m["name"]: m for m in client.get("/api/mechanisms").json()}
    assert list(mechanisms) == list(MECHANISMS)
    assert mechanisms["hybrid"]["state_size"] == 9
    for name, m in mechanisms.items():
        assert m["planners"] == [p for p, s in PLANNERS.items() if name in s.mechanisms]
        assert m["default_planner"] in m["planners"]


def test_planners_carry_ranges_and_defaults_of_planner_parameters(client: TestClient) -> None:
    """Each planner's parameters carry the ranges and defaults of `PlannerParameters`, with a
    source and title."""
    planners = {p["name"]: p for p in client.get("/api/planners").json()}
    assert list(planners) == list(PLANNERS)
    mtmp = planners["mtmp"]
    assert mtmp["mechanisms"] == ["hybrid"] and mtmp["default_for"] == ["hybrid"]
    assert list(mtmp["parameters"]) == list(PLANNERS["mtmp"].parameters)
    beta = mtmp["parameters"]["beta"]
    assert (beta["minimum"], beta["maximum"], beta["default"]) == (0.0, 1.0, 0.7)
    assert mtmp["parameters"]["sigma"]["minimum"] == 0.1
    defaults = PlannerParameters()
    for planner in planners.values():
        assert planner["source"] and planner["title"]
        for name, schema in planner["parameters"].items():
            assert schema["default"] == getattr(defaults, name)


def test_sea_states_are_the_wmo_table(client: TestClient) -> None:
    """The sea states are the WMO table, codes 0-9, the open top class without an upper Hs."""
    states = client.get("/api/sea-states").json()
    assert [s["code"] for s in states] == list(range(10))
    for got, want in zip(states, WMO_SEA_STATES, strict=True):
        assert (got["hs"], got["tp"], got["description"]) == (want.hs, want.tp, want.description)
    assert states[9]["hs_max"] is None  # "over 14 m": open, and JSON has no inf


# -- runs ---------------------------------------------------------------------------------------


def test_a_short_run_answers_when_done_with_simulates_metrics(
    client: TestClient, done_run: dict[str, Any]
) -> None:
    """A short run answers done with simulate()'s metrics and its full scenario, and reads back
    the same."""
    assert done_run["status"] == "done" and done_run["progress"] == 1.0
    assert done_run["metrics"] == simulate(SHORT).metrics
    assert done_run["scenario"] == Scenario(**SHORT).model_dump()
    assert client.get(f"/api/runs/{done_run['id']}").json() == done_run


def test_runs_list_newest_first(client: TestClient, done_run: dict[str, Any]) -> None:
    """Runs list newest first within the limit asked; a limit of 0 is 422."""
    second = client.post("/api/runs", json={**SHORT, "duration": 1.0}).json()
    ids = [r["id"] for r in client.get("/api/runs", params={"limit": 500}).json()]
    assert ids.index(second["id"]) < ids.index(done_run["id"])
    assert len(client.get("/api/runs", params={"limit": 1}).json()) == 1
    assert client.get("/api/runs", params={"limit": 0}).status_code == 422


def test_series_in_json_csv_and_parquet_match_simulate(
    client: TestClient, done_run: dict[str, Any]
) -> None:
    """A run's series in JSON, CSV and Parquet equal simulate()'s."""
    expected = flat_columns(simulate(SHORT).series)
    url = f"/api/runs/{done_run['id']}/series"

    body = client.get(url, params={"format": "json"}).json()
    assert body["metrics"] == done_run["metrics"]
    assert flat_columns({k: np.array(v) for k, v in body["series"].items()}).keys() == (
        expected.keys()
    )
    np.testing.assert_array_equal(body["series"]["legs"], simulate(SHORT).series["legs"])

    response = client.get(url, params={"format": "csv"})
    assert response.headers["content-type"].startswith("text/csv")
    rows = list(csv.reader(io.StringIO(response.text)))
    assert rows[0] == list(expected)
    np.testing.assert_array_equal(
        np.array(rows[1:], dtype=float), np.column_stack(list(expected.values()))
    )

    response = client.get(url, params={"format": "parquet"})
    table = pq.read_table(io.BytesIO(response.content))
    assert table.column_names == list(expected)
    for name, values in expected.items():
        np.testing.assert_array_equal(table.column(name).to_numpy(), values)
    assert json.loads(table.schema.metadata[b"metrics"]) == done_run["metrics"]

    assert client.get(url, params={"format": "xml"}).status_code == 422


def test_unknown_run_is_404_and_unfinished_run_has_no_series(
    client: TestClient, store: RunStore
) -> None:
    """An unknown run is 404 naming it; an unfinished run's series is 409."""
    for path in ("/api/runs/nope", "/api/runs/nope/series"):
        response = client.get(path)
        assert response.status_code == 404 and "nope" in response.json()["detail"]
    queued = store.create(Scenario(**SHORT))  # stored, never submitted
    assert client.get(f"/api/runs/{queued.id}/series").status_code == 409


def test_a_long_run_becomes_a_job_that_completes_and_is_stored(client: TestClient) -> None:
    """A long run answers 202 with its location and completes, stored with simulate()'s metrics
    and every sample."""
    scenario = {**SHORT, "duration": 10.0}  # 200 steps > SYNC_STEPS
    response = client.post("/api/runs", json=scenario)
    assert response.status_code == 202
    run = response.json()
    assert run["status"] in ("queued", "running") and run["metrics"] is None
    assert response.headers["location"] == f"/api/runs/{run['id']}"
    run = wait_finished(client, f"/api/runs/{run['id']}")
    assert run["status"] == "done" and run["progress"] == 1.0
    assert run["metrics"] == simulate(scenario).metrics
    series = client.get(f"/api/runs/{run['id']}/series").json()["series"]
    assert len(series["t"]) == 201


@pytest.mark.parametrize(
    ("body", "field", "allowed"),
    [
        ({"beta": 2.0}, "beta", "0 ≤ beta ≤ 1"),
        ({"sigma": 0.0}, "sigma", "0.1 ≤ sigma ≤ 15"),
        ({"spectrum": "flat"}, "spectrum", "one of 'jonswap', 'pierson_moskowitz'"),
        ({"duration": 5000.0}, "duration", "0 < duration ≤ 3600"),
        ({"bogus": 1}, "bogus", None),
    ],
)
def test_bad_run_bodies_are_422_naming_field_and_range(
    client: TestClient, body: dict[str, Any], field: str, allowed: str | None
) -> None:
    """A bad run body is 422 naming the field and what is allowed, and stores nothing."""
    before = len(client.get("/api/runs", params={"limit": 500}).json())
    response = client.post("/api/runs", json=body)
    assert response.status_code == 422
    error = response.json()["detail"][0]
    assert error["loc"] == ["body", field] and error.get("allowed") == allowed
    assert response.json()["message"].startswith(f"{field}: ")
    assert len(client.get("/api/runs", params={"limit": 500}).json()) == before  # none stored


def test_cross_field_and_non_finite_bodies_are_422(client: TestClient) -> None:
    """A planner not of the mechanism names the allowed ones; a NaN in the body is 422 as not
    finite."""
    response = client.post("/api/runs", json={"planner": "pid"})
    assert response.status_code == 422 and "allowed: ['conv1'" in response.json()["message"]
    response = client.post(
        "/api/runs", content=b'{"beta": NaN}', headers={"Content-Type": "application/json"}
    )
    assert response.status_code == 422 and "finite" in response.json()["message"]


def test_an_unknown_vessel_is_422_and_nothing_is_stored(client: TestClient) -> None:
    """The vessel name is checked with the scenario: a 422 naming it, and no run is created."""
    before = len(client.get("/api/runs").json())
    response = client.post("/api/runs", json={**SHORT, "vessel": "nope"})
    assert response.status_code == 422
    assert response.json()["detail"][0]["loc"] == ["body", "vessel"]
    assert "'asv', 'barge' or 'sov'" in response.json()["message"]
    assert len(client.get("/api/runs").json()) == before


def test_runs_survive_a_restart_and_interrupted_jobs_rerun(
    tmp_path: Path, executor: Executor
) -> None:
    """A new RunStore and app on the same file serve the old runs; a job a dead server left
    `running` is queued again at start-up and completes."""
    path = tmp_path / "runs.sqlite"
    with RunStore(path) as store:
        app = create_app(LiveSession(), store, access=access(), executor=executor)
        with TestClient(app) as first:
            done = first.post("/api/runs", json=SHORT).json()
            csv_before = first.get(f"/api/runs/{done['id']}/series?format=csv").text
        interrupted = store.create(Scenario(**SHORT)).id
        store.mark_running(interrupted)  # as if the server died mid-run

    with RunStore(path) as store:
        app = create_app(LiveSession(), store, access=access(), executor=executor)
        with TestClient(app) as second:
            assert second.get(f"/api/runs/{done['id']}").json() == done
            assert second.get(f"/api/runs/{done['id']}/series?format=csv").text == csv_before
            rerun = wait_finished(second, f"/api/runs/{interrupted}")
    assert rerun["status"] == "done" and rerun["metrics"] == done["metrics"]


# -- operability sweeps -------------------------------------------------------------------------

#: a 2-cell sweep of 2 s runs, 4 runs in all: about a second in process
TINY_SWEEP = {"hs": [0.5, 2.0], "tp": [8.0], "planner": ["mtmp"], "seeds": 2, "duration": 2.0}


def test_a_sweep_is_a_job_with_progress_a_table_and_a_heatmap(client: TestClient) -> None:
    """A sweep is priced, runs to done with progress, and gives its criterion, table and heatmap."""
    response = client.post("/api/sweeps", json=TINY_SWEEP)
    assert response.status_code == 202, response.text
    queued = response.json()
    assert response.headers["location"] == f"/api/sweeps/{queued['id']}"
    assert queued["total"] == 4 and queued["result"] is None
    assert queued["spec"]["hs"] == [0.5, 2.0] and queued["spec"]["tip_error_threshold"] == 0.05
    sweep = wait_finished(client, f"/api/sweeps/{queued['id']}")
    assert sweep["status"] == "done", sweep["error"]
    assert (sweep["done"], sweep["progress"]) == (4, 1.0)
    result = sweep["result"]
    assert "tip position error ≤ 0.05 m" in result["criterion"]
    assert [cell["hs"] for cell in result["cells"]] == [0.5, 2.0]
    assert all(cell["runs"] == 2 for cell in result["cells"])
    assert result["cells"][0]["operability"] == 1.0  # a calm sea is operable for MTMP
    heatmap = client.get(f"/api/sweeps/{queued['id']}/heatmap.png")
    assert heatmap.status_code == 200 and heatmap.headers["content-type"] == "image/png"
    assert heatmap.content[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"hs": []}, "hs"),
        ({"planner": ["nope"]}, "planner"),
        ({"hs": [0.1 * i for i in range(1, 60)], "tp": [4.0 + 0.1 * i for i in range(100)]},
         "cells"),
        ({"seeds": 0}, "seeds"),
    ],
)  # fmt: skip
def test_bad_sweeps_are_422_naming_the_field(
    client: TestClient, change: dict[str, Any], field: str
) -> None:
    """A bad sweep spec is 422 naming the field."""
    response = client.post("/api/sweeps", json={**TINY_SWEEP, **change})
    assert response.status_code == 422, response.text
    assert field in response.json()["message"]


def test_an_unknown_sweep_is_404(client: TestClient) -> None:
    """An unknown sweep and its heatmap are 404."""
    assert client.get("/api/sweeps/nope").status_code == 404
    assert client.get("/api/sweeps/nope/heatmap.png").status_code == 404


def test_sweeps_survive_a_restart_and_interrupted_sweeps_rerun(
    tmp_path: Path, executor: Executor
) -> None:
    """Stored sweeps survive a restart, and one left running by a dead server runs again."""
    path = tmp_path / "runs.sqlite"
    with RunStore(path) as store:
        interrupted = store.create_sweep(TINY_SWEEP, 4).id
        store.sweep_running(interrupted)  # as if the server died mid-sweep
        assert store.get_sweep(interrupted).status == "running"

    with RunStore(path) as store:
        app = create_app(LiveSession(), store, access=access(), executor=executor)
        with TestClient(app) as second:
            sweep = wait_finished(second, f"/api/sweeps/{interrupted}")
            assert second.get(f"/api/sweeps/{interrupted}/heatmap.png").status_code == 200
    assert sweep["status"] == "done" and len(sweep["result"]["cells"]) == 2


# -- the live session ---------------------------------------------------------------------------


def test_live_is_flat_scenario_fields_with_time_controls_and_metrics(
    live: LiveSession, tmp_path: Path
) -> None:
    """GET /api/live gives the session's scenario fields flat, its time controls and metrics."""
    state = live_client(live, tmp_path).get("/api/live").json()
    for key in ("mechanism", "planner", "sea_state", "beta", "k_e", "k_c", "heading", "dt"):
        assert state[key] == live.snapshot()[key]
    assert (state["t"], state["speed"], state["playing"]) == (0.0, 1.0, True)
    assert "duration" not in state and "violations" in state["metrics"]


def test_patch_changes_the_session_on_the_next_step(live: LiveSession, tmp_path: Path) -> None:
    """A PATCH changes the live session's fields and answers the new state."""
    client = live_client(live, tmp_path)
    client.post("/api/live/step", params={"n": 10})
    response = client.patch(
        "/api/live", json={"beta": 0.3, "planner": "wpi", "sea_state": 5, "speed": 2.0}
    )
    assert response.status_code == 200
    state = response.json()
    assert (state["beta"], state["planner"], state["sea_state"], state["speed"]) == (
        0.3, "wpi", 5.0, 2.0,
    )  # fmt: skip
    assert live.scenario.beta == 0.3 and live.scenario.planner == "wpi"
    assert live.controls.speed == 2.0
    stepped = client.post("/api/live/step").json()
    assert stepped["t"] == pytest.approx(0.55)  # no reset: time runs on


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"beta": 2.0}, "beta"),
        ({"speed": 100.0}, "speed"),
        ({"k_e": 0.1, "k_c": -1.0}, "k_c"),  # one bad field: the good one is not applied either
        ({"bogus": 1}, "bogus"),
        ({"duration": 10.0}, "duration"),  # not a live field
        ({"playing": "maybe"}, "playing"),
        ({"planner": "pid"}, "planner"),  # exists, but not for the hybrid system
        ({"mechanism": "upr4"}, "planner"),  # mtmp does not plan for the 4-UPR
    ],
)
def test_a_bad_patch_is_422_and_changes_nothing(
    live: LiveSession, tmp_path: Path, body: dict[str, Any], field: str
) -> None:
    """A bad PATCH is 422 naming the field and leaves the session unchanged."""
    client = live_client(live, tmp_path)
    before = live.snapshot()
    response = client.patch("/api/live", json=body)
    assert response.status_code == 422
    assert field in response.json()["message"]
    assert live.snapshot() == before


def test_patch_reports_the_live_speed_range(live: LiveSession, tmp_path: Path) -> None:
    """A speed out of range is refused naming the allowed range."""
    error = live_client(live, tmp_path).patch("/api/live", json={"speed": 0.1}).json()
    assert error["detail"][0]["allowed"] == "0.25 ≤ speed ≤ 8"


def test_pause_step_play_reset(live: LiveSession, tmp_path: Path) -> None:
    """Pause, step n, play and reset move the live session's clock as asked; a step of 0 is 422."""
    client = live_client(live, tmp_path)
    assert client.post("/api/live/pause").json()["playing"] is False
    assert live.controls.playing is False
    assert client.post("/api/live/step", params={"n": 3}).json()["t"] == pytest.approx(0.15)
    assert client.post("/api/live/play").json()["playing"] is True
    assert client.post("/api/live/reset").json()["t"] == 0.0
    assert live.snapshot()["t"] == 0.0
    assert client.post("/api/live/step", params={"n": 0}).status_code == 422


def test_a_mechanism_change_with_its_planner_restarts_the_session(
    live: LiveSession, tmp_path: Path
) -> None:
    """Changing the mechanism with one of its planners restarts the live session at t = 0."""
    client = live_client(live, tmp_path)
    client.post("/api/live/step", params={"n": 5})
    state = client.patch("/api/live", json={"mechanism": "upr4", "planner": "pid"}).json()
    assert (state["mechanism"], state["planner"], state["t"]) == ("upr4", "pid", 0.0)


# -- issue 16: planners side by side, stored runs replayed ---------------------------------------


def test_compare_planner_runs_beside_on_the_same_motion(live: LiveSession, tmp_path: Path) -> None:
    """PATCH compare_planner adds a second lane (restart at t = 0): GET answers its planner
    and metrics; both lanes see the same base motion; later patches reach both lanes except
    the second's planner; a planner of another mechanism is a 422 naming the field and
    changes nothing; null stops it."""
    client = live_client(live, tmp_path)
    client.post("/api/live/step", params={"n": 5})
    state = client.patch("/api/live", json={"compare_planner": "pi"}).json()
    assert state["t"] == 0.0 and state["compare"]["planner"] == "pi"
    client.post("/api/live/step", params={"n": 20})
    state = client.get("/api/live").json()
    assert state["compare"]["metrics"]["tip_position_error_rms"] > 0
    assert "held" in state["compare"]["faults"] and state["replay"] is None
    np.testing.assert_array_equal(live.latest(0)["base_pose"], live.latest(1)["base_pose"])
    assert np.any(live.latest(0)["xi"] != live.latest(1)["xi"])  # two planners, two motions

    state = client.patch("/api/live", json={"beta": 0.5, "planner": "wpi"}).json()
    assert state["t"] == pytest.approx(1.0)  # not a restart
    assert [(s.planner, s.beta) for s in live._sim.scenarios] == [("wpi", 0.5), ("pi", 0.5)]

    before = live.snapshot()
    for bad in ("pid", "nope", ""):
        refused = client.patch("/api/live", json={"compare_planner": bad, "beta": 0.2})
        assert refused.status_code == 422, refused.text
        assert refused.json()["detail"][0]["loc"] == ["body", "compare_planner"]
    assert live.snapshot()["beta"] == before["beta"] and live.compare_planner == "pi"

    state = client.patch("/api/live", json={"compare_planner": None}).json()
    assert state["compare"] is None and live._sim.n_lanes == 1
    # a mechanism without that planner drops the comparison
    client.patch("/api/live", json={"compare_planner": "mtmp"})
    state = client.patch("/api/live", json={"mechanism": "upr4", "planner": None}).json()
    assert state["compare"] is None and state["mechanism"] == "upr4"


def test_compare_and_replay_need_the_token(live: LiveSession, tmp_path: Path) -> None:
    """Compare and replay need the token and the server's origin; refused, they change nothing."""
    client = live_client(live, tmp_path, token=TOKEN)
    replay = client.post("/api/live/replay", json={"run_id": "0" * 32})
    compare = client.patch("/api/live", json={"compare_planner": "pi"})
    assert (replay.status_code, compare.status_code) == (401, 401)
    evil = {"Origin": "http://evil.example", "Authorization": f"Bearer {TOKEN}"}
    assert client.patch("/api/live", json={"compare_planner": "pi"},
                        headers=evil).status_code == 403  # fmt: skip
    assert live.compare_planner is None and live.replaying is None


def test_replay_plays_seeks_and_returns_to_live(live: LiveSession, tmp_path: Path) -> None:
    """POST /api/live/replay shows a stored run's samples (nothing simulated): GET answers
    `replay` and the run's scenario and metrics; the same id again seeks; pause, step and
    play act on it; an unknown run is a 404, a run not done a 409, a time past its end a
    422; reset returns to the live simulation where it was."""
    client = live_client(live, tmp_path)
    store = client.app.state.services.store
    scenario = Scenario(mechanism="upr4", duration=4.0, sea_state=3)
    result = simulate(scenario)
    run = store.create(scenario)
    store.finish(run.id, result)
    queued = store.create(Scenario(duration=1.0))
    client.post("/api/live/step", params={"n": 3})
    live_t = live.snapshot()["t"]

    state = client.post("/api/live/replay", json={"run_id": run.id, "t": 1.0,
                                                  "playing": False}).json()  # fmt: skip
    assert state["replay"] == {"run_id": run.id, "t": 1.0, "duration": 4.0}
    assert (state["mechanism"], state["t"], state["playing"]) == ("upr4", 1.0, False)
    assert state["metrics"] == json.loads(json.dumps(result.metrics))
    k = int(np.flatnonzero(result.series["t"] == 1.0)[0])
    np.testing.assert_array_equal(live.latest()["state"], result.series["state"][k])

    state = client.post("/api/live/replay", json={"run_id": run.id, "t": 2.5,
                                                  "playing": False}).json()  # fmt: skip
    assert state["replay"]["t"] == 2.5 and live.latest()["t"] == pytest.approx(2.5)
    assert client.post("/api/live/step", params={"n": 2}).json()["replay"]["t"] == 2.6
    assert client.post("/api/live/play").json()["playing"] is True
    live.advance(10.0)  # past its end: it stops there, paused
    state = client.get("/api/live").json()
    assert (state["replay"]["t"], state["playing"]) == (4.0, False)

    assert client.post("/api/live/replay", json={"run_id": "0" * 32}).status_code == 404
    assert client.post("/api/live/replay", json={"run_id": queued.id}).status_code == 409
    past = client.post("/api/live/replay", json={"run_id": run.id, "t": 9.0})
    assert past.status_code == 422 and past.json()["detail"][0]["loc"] == ["body", "t"]
    assert client.get("/api/live").json()["replay"]["t"] == 4.0  # unchanged

    state = client.post("/api/live/reset").json()
    assert state["replay"] is None and state["mechanism"] == "hybrid" and state["t"] == 0.0
    assert live_t > 0


# -- security -----------------------------------------------------------------------------------


def test_with_a_token_mutations_need_the_bearer_token(live: LiveSession, tmp_path: Path) -> None:
    """With a token every mutation needs the bearer token (missing, wrong or Basic: 401) while
    reading stays open."""
    client = live_client(live, tmp_path, token=TOKEN)
    assert client.get("/api/live").status_code == 200  # reading stays open
    for headers in ({}, {"Authorization": "Bearer wrong"}, {"Authorization": f"Basic {TOKEN}"}):
        response = client.patch("/api/live", json={"beta": 0.2}, headers=headers)
        assert response.status_code == 401 and response.headers["www-authenticate"] == "Bearer"
        assert client.post("/api/live/reset", headers=headers).status_code == 401
        assert client.post("/api/runs", json=SHORT, headers=headers).status_code == 401
    assert live.scenario.beta == 0.7
    assert client.get("/api/runs").json() == []  # nothing was submitted

    good = {"Authorization": f"Bearer {TOKEN}"}
    assert client.patch("/api/live", json={"beta": 0.2}, headers=good).status_code == 200
    assert live.scenario.beta == 0.2
    assert client.post("/api/runs", json={"beta": 9}, headers=good).status_code == 422


def test_cross_origin_mutations_are_refused_and_cors_is_closed(
    live: LiveSession, tmp_path: Path
) -> None:
    """Mutations from another origin are 403 and change nothing; no CORS header is given to it."""
    client = live_client(live, tmp_path)
    evil = {"Origin": "http://evil.example"}
    assert client.post("/api/live/pause", headers=evil).status_code == 403
    assert client.patch("/api/live", json={"beta": 0.1}, headers=evil).status_code == 403
    assert live.controls.playing and live.scenario.beta == 0.7
    same = {"Origin": SAME_ORIGIN}  # the landing page's own origin
    assert client.post("/api/live/pause", headers=same).status_code == 200
    response = client.get("/api/live", headers=evil)
    assert "access-control-allow-origin" not in response.headers
    preflight = client.options(
        "/api/live", headers={**evil, "Access-Control-Request-Method": "PATCH"}
    )
    assert "access-control-allow-origin" not in preflight.headers


def test_live_faults_are_served_finite(
    tmp_path: Path, nan_sea: Callable[[float, float], None]
) -> None:
    """NaN injected into the base motion: GET /api/live stays strict JSON (no NaN) and
    reports the held steps; the session keeps stepping."""
    nan_sea(0.32, np.inf)
    live = LiveSession({"sea_state": 3})
    client = live_client(live, tmp_path)
    client.post("/api/live/step?n=20")
    response = client.get("/api/live")
    assert response.status_code == 200

    def refuse(constant: str) -> None:
        raise AssertionError(f"{constant} in the answer")

    state = json.loads(response.text, parse_constant=refuse)
    assert state["t"] == pytest.approx(1.0)
    assert state["faults"]["counts"]["base_motion"] == 14  # samples at t = 0.35 … 1.0
    assert state["faults"]["events"][-1]["kinds"] == ["base_motion"]


# -- issue 13: what an attacker tried, and what happens now -------------------------------------


def test_a_host_spoofed_patch_changes_nothing(live: LiveSession, tmp_path: Path) -> None:
    """DNS rebinding: a page served under its own name reaches the server with Host and Origin
    both its own. The Host is not one the server answers to: 400 before anything is read, for
    reads too. Origin is compared as scheme + host + port with the server's own origins, never
    with the Host header."""
    client = live_client(live, tmp_path)
    before = live.snapshot()
    rebound = {"Host": "evil.example:80", "Origin": "http://evil.example:80"}
    spoofed = client.patch("/api/live", json={"beta": 0.1, "playing": False}, headers=rebound)
    assert spoofed.status_code == 400 and "--allow-host" in spoofed.json()["message"]
    assert client.get("/api/live", headers=rebound).status_code == 400
    assert client.post("/api/live/reset", headers={"Host": "evil.example"}).status_code == 400
    assert live.snapshot() == before
    others = ["https://testserver", "http://testserver:8080", "http://testserver.evil.example",
              "http://evil.example", "null", "http://testserver/page"]  # fmt: skip
    codes = [client.patch("/api/live", json={"beta": 0.1}, headers={"Origin": o}).status_code
             for o in others]  # fmt: skip
    assert codes == [403] * len(others)
    assert live.snapshot() == before
    own = client.patch("/api/live", json={"beta": 0.2}, headers={"Origin": "http://testserver:80"})
    assert own.status_code == 200 and live.scenario.beta == 0.2
    record(
        "attack_host_spoofing",
        spoofed_patch=spoofed.status_code,
        other_origins_refused=f"{codes.count(403)}/{len(others)}",
        changed="nothing",
    )


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"planner": ""}, "planner"),
        ({"planner": "", "beta": 0.2}, "planner"),  # the good field is not applied either
        ({"planner": "nope", "speed": 2.0}, "planner"),
        ({"mechanism": ""}, "mechanism"),
        ({"vessel": ""}, "vessel"),
        ({"spectrum": ""}, "spectrum"),
        ({"joint_limits": ""}, "joint_limits"),
        ({"playing": "true"}, "playing"),  # strictly true or false
        ({"playing": 1}, "playing"),
        ({"playing": None}, "playing"),
        ({"mechanism": "upr4", "planner": "mtmp"}, "planner"),
    ],
)
def test_a_refused_patch_changes_nothing_empty_names_included(
    live: LiveSession, tmp_path: Path, body: dict[str, Any], field: str
) -> None:
    """A refused PATCH (empty names included) changes nothing, and the session goes on."""
    client = live_client(live, tmp_path)
    before = live.snapshot()
    response = client.patch("/api/live", json=body)
    assert response.status_code == 422, response.text
    assert field in {e["loc"][-1] for e in response.json()["detail"]}, response.json()
    assert live.snapshot() == before
    # the session is whole: the 3D view, reset and stepping go on
    assert client.post("/api/live/reset").status_code == 200
    assert client.post("/api/live/step", params={"n": 3}).status_code == 200
    record(f"attack_refused_patch[{json.dumps(body)}]", status=response.status_code,
           changed="nothing")  # fmt: skip


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({**SHORT, "planner": ""}, "planner"),
        ({**SHORT, "planner": "pid"}, "planner"),
        ({**SHORT, "duration": 0.001}, "duration"),  # zero steps
        ({**SHORT, "duration": 0.02, "dt": 0.05}, "duration"),
        ({**SHORT, "mechanism": ""}, "mechanism"),
    ],
)
def test_a_refused_run_stores_nothing(
    client: TestClient, store: RunStore, body: dict[str, Any], field: str
) -> None:
    """A refused run body is 422 naming the field and stores nothing."""
    before = len(store.list_runs(500))
    response = client.post("/api/runs", json=body)
    assert response.status_code == 422, response.text
    assert response.json()["detail"][0]["loc"] == ["body", field], response.json()
    assert len(store.list_runs(500)) == before


def test_a_run_its_worker_refuses_is_422_and_not_stored(
    client: TestClient, store: RunStore, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A scenario the request's checks let through but the engine refuses before its first
    step: the answer is a 422 naming the field, and the run is not left behind as failed."""
    import twin.sim.engine

    real = twin.sim.engine.Simulation

    def refusing(scenario: Any, *args: Any, **kwargs: Any) -> Any:
        if getattr(scenario, "seed", None) == 424242:
            raise twin.sim.engine.TwinError("heading: refused by the engine (test)")
        return real(scenario, *args, **kwargs)

    monkeypatch.setattr(twin.sim.engine, "Simulation", refusing)
    before = len(store.list_runs(500))
    response = client.post("/api/runs", json={**SHORT, "seed": 424242})
    assert response.status_code == 422, response.text
    assert response.json()["detail"][0]["loc"] == ["body", "heading"]
    assert len(store.list_runs(500)) == before
    record("attack_refused_run", status=response.status_code, stored="nothing")


def test_a_run_over_its_wall_clock_budget_fails_and_is_answered(
    tmp_path: Path, executor: Executor
) -> None:
    """The longest run a scenario may be, synchronous (the cap raised to its 200 000 steps),
    with a budget of 0.05 s: answered at once, failed, saying why."""
    with RunStore(tmp_path / "runs.sqlite") as store:
        jobs = JobRunner(store, sync_max_steps=200_000, budget=0.05)
        app = create_app(LiveSession(), store, access=access(), executor=executor, jobs=jobs)
        with TestClient(app) as c:
            start = time.monotonic()
            response = c.post("/api/runs", json=LONGEST)
            answered = time.monotonic() - start
    run = response.json()
    assert response.status_code == 201 and run["status"] == "failed", run
    assert "wall-clock budget of 0.05 s" in run["error"] and "of 200000 steps" in run["error"]
    assert answered < 10.0
    record("attack_costly_sync_run", steps=200_000, budget_s=0.05, status=run["status"],
           answered_s=round(answered, 2))  # fmt: skip


def test_a_deleted_or_replaced_store_answers_503(tmp_path: Path, executor: Executor) -> None:
    """The store's file deleted while the server runs: writes (and reads, and health) are a
    503 saying so, not a 500, and no run is accepted into a file nobody can reopen; the same
    once another file takes its place."""
    path = tmp_path / "data" / "runs.sqlite"
    with RunStore(path) as store:
        app = create_app(LiveSession(), store, access=access(), executor=executor)
        with TestClient(app) as c:
            done = c.post("/api/runs", json=SHORT).json()
            for suffix in ("", "-wal", "-shm"):
                if Path(f"{path}{suffix}").exists():
                    os.remove(f"{path}{suffix}")
            deleted = c.post("/api/runs", json=SHORT)
            assert deleted.status_code == 503 and "deleted" in deleted.json()["message"]
            assert c.post("/api/sweeps", json=TINY_SWEEP).status_code == 503
            assert c.get(f"/api/runs/{done['id']}").status_code == 503
            assert c.get("/api/health").status_code == 503
            with RunStore(tmp_path / "other.sqlite"):
                pass
            shutil.copy(tmp_path / "other.sqlite", path)  # another file in its place
            replaced = c.post("/api/runs", json=SHORT)
            assert replaced.status_code == 503 and "replaced" in replaced.json()["message"]
            assert c.get("/api/live").status_code == 200  # the live twin goes on
    with RunStore(path) as reopened:
        assert reopened.list_runs() == []  # nothing was written into the replacement
    record("attack_deleted_store", deleted=deleted.status_code, replaced=replaced.status_code)


def test_a_long_step_lets_readers_in_and_stops_at_its_wall_cap(
    live: LiveSession, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """POST /api/live/step?n=1000 on slow steps (5 ms each, injected) with a 2 s wall cap:
    it stops at the cap, saying how many steps it took, and GET /api/live answers meanwhile:
    a read started during the first chunk is done before a later chunk begins (the lock is
    let go between chunks). Ordered by events, not timed, so a loaded machine cannot fail it."""
    import twin.sim.live

    monkeypatch.setattr(twin.sim.live, "STEP_WALL", 2.0)
    advance = LiveSession._advance
    started, read_done, stepped = threading.Event(), threading.Event(), threading.Event()
    read_seen_at_chunk: list[bool] = []

    def slow(self: LiveSession, n: int) -> None:
        read_seen_at_chunk.append(read_done.is_set())
        started.set()
        time.sleep(0.005 * n)
        advance(self, n)

    monkeypatch.setattr(LiveSession, "_advance", slow)
    client = live_client(live, tmp_path)
    latencies: list[float] = []

    def read() -> None:
        started.wait(30)
        while not stepped.is_set():
            start = time.monotonic()
            assert client.get("/api/live").status_code == 200
            latencies.append(time.monotonic() - start)
            read_done.set()

    reader = threading.Thread(target=read)
    reader.start()
    start = time.monotonic()
    response = client.post("/api/live/step", params={"n": 1000})
    took = time.monotonic() - start
    stepped.set()
    reader.join(30)
    taken = int(response.headers["x-steps-taken"])
    assert response.status_code == 200 and 0 < taken < 1000
    assert response.json()["t"] == pytest.approx(taken * 0.05)
    assert len(read_seen_at_chunk) == -(-taken // twin.sim.live.STEP_CHUNK)
    assert any(read_seen_at_chunk[1:]), read_seen_at_chunk  # a read got in between chunks
    record("attack_long_step", n=1000, steps_taken=taken, step_s=round(took, 2),
           reads=len(latencies), read_max_s=round(max(latencies), 3))  # fmt: skip


def test_short_tokens_are_refused_and_wrong_ones_rate_limited(
    live: LiveSession, tmp_path: Path
) -> None:
    """A short token is refused at start; wrong tokens past the burst are rate limited."""
    with pytest.raises(ValueError, match=f"at least {MIN_TOKEN}"):
        Access(token="x" * (MIN_TOKEN - 1))
    app = create_app(
        live, RunStore(tmp_path / "runs.sqlite"),
        access=access(TOKEN, failure_burst=3, failure_rate=4.0),
    )  # fmt: skip
    client = TestClient(app)
    wrong = {"Authorization": "Bearer " + "0" * len(TOKEN)}
    codes = [client.post("/api/live/pause", headers=wrong).status_code for _ in range(5)]
    assert codes == [401, 401, 401, 429, 429]
    limited = client.post("/api/live/pause", headers=wrong)
    assert limited.status_code == 429 and int(limited.headers["retry-after"]) >= 1
    assert live.controls.playing  # nothing changed
    # issue 30: someone else's wrong tokens, from the same address, never refuse the right one
    good = {"Authorization": f"Bearer {TOKEN}"}
    assert client.post("/api/live/pause", headers=good).status_code == 200
    record("attack_token_guessing", min_token=MIN_TOKEN, answers=codes)


def test_the_access_policy_names_hosts_and_origins_as_the_server_was_started() -> None:
    """The access policy allows the server's own hosts and origins and the ones added, and no
    look-alikes."""
    policy = Access.for_server(
        "::1", (8000, 8080), allow_hosts=("Twin.Example.com",),
        allow_origins=("https://twin.example.com",),
    )  # fmt: skip
    for host in ("localhost:8000", "127.0.0.1", "[::1]:8080", "twin.example.com:9000"):
        assert policy.allows_host(host), host
    for host in (None, "", "evil.example", "127.0.0.2", "localhost.evil.example", "a b"):
        assert not policy.allows_host(host), host
    for origin in ("http://localhost:8000", "http://[::1]:8080", "http://twin.example.com:8080",
                   "https://twin.example.com", "https://twin.example.com:443"):  # fmt: skip
        assert policy.allows_origin(origin), origin
    for origin in ("http://localhost", "https://localhost:8000", "http://twin.example.com",
                   "http://localhost:8000/x", "null", "file://", "http://localhost:9"):  # fmt: skip
        assert not policy.allows_origin(origin), origin
    assert Access.for_server("0.0.0.0", (8000,)).hosts == {"localhost", "127.0.0.1", "::1"}
    for bad in ({"allow_hosts": ("a:1",)}, {"allow_origins": ("twin.example.com",)}):
        with pytest.raises(ValueError):
            Access.for_server("127.0.0.1", (8000,), **bad)

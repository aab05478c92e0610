"""POST /api/runs of a short run (issue 30: a 60 s run's POST p50): the run runs on the
request's own worker thread, the one that stored it (`JobRunner.run_here`), not on a thread it
hands the run to and waits for; the answer is the run as stored, and a scenario the engine
refuses is still a 422 that leaves nothing stored."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from tests.web.support import access, record_run_threads, refuse_runs
from twin.runs.executor import IN_PROCESS, Executor
from twin.sim.live import LiveSession
from twin.web import JobRunner, RunStore, create_app

#: 20 steps of the hybrid system: a short run, under the synchronous cap
SHORT = {"mechanism": "hybrid", "planner": "mtmp", "sea_state": 3, "duration": 1.0}


@pytest.fixture(scope="module")
def executor() -> Iterator[Executor]:
    with Executor.start(IN_PROCESS) as executor:
        yield executor


@pytest.fixture
def client(tmp_path: Path, executor: Executor) -> Iterator[TestClient]:
    store = RunStore(tmp_path / "runs.sqlite")
    app = create_app(LiveSession({"sea_state": 3}), store, access=access(), executor=executor,
                     jobs=JobRunner(store))  # fmt: skip
    with TestClient(app) as client:
        yield client
    store.close()


def test_a_short_run_runs_on_the_requests_thread(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A short run is done on the request's own thread, answered 201 as stored."""
    threads = record_run_threads(monkeypatch)
    response = client.post("/api/runs", json=SHORT)
    assert response.status_code == 201, response.text
    body = response.json()
    assert body["status"] == "done" and body["progress"] == 1.0 and body["metrics"]
    assert response.headers["Location"] == f"/api/runs/{body['id']}"
    assert len(threads) == 1
    # the request's worker thread (anyio's), not the runner's own in-process thread
    assert not threads[0].name.startswith("twin-"), threads[0].name
    assert client.get(f"/api/runs/{body['id']}").json() == body  # answered as stored


def test_a_short_run_the_engine_refuses_is_a_422_and_leaves_nothing(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A short run the engine refuses is 422 saying so and stores no run."""
    refuse_runs(monkeypatch)
    response = client.post("/api/runs", json=SHORT)
    assert response.status_code == 422, response.text
    assert "refused by the engine" in response.text
    assert client.get("/api/runs").json() == []

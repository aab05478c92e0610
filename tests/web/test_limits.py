"""Request limits: body size (413), submission rate and queue (429), names not paths."""

from __future__ import annotations

from concurrent.futures import Future
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from tests.web.support import access
from twin.assets import asset_path
from twin.sim import Scenario
from twin.sim.live import LiveSession
from twin.web import JobRunner, RunStore, SweepRunner, create_app
from twin.web.limits import RateLimit

SHORT = {"mechanism": "hybrid", "duration": 1.0}


class QueueOnly(JobRunner):
    """Stores runs as queued and never executes them: the limits are the HTTP layer's."""

    def start(self, executor: object = None) -> list[str]:
        return []

    def submit(self, run_id: str) -> Future:
        return Future()

    def is_sync(self, scenario: Scenario) -> bool:
        return False

    def shutdown(self) -> None:
        pass


class SweepQueueOnly(SweepRunner):
    def start(self, executor: object = None) -> list[str]:
        return []

    def submit(self, sweep_id: str) -> None:
        pass


def app_client(tmp_path: Path, **limits: float) -> tuple[TestClient, RunStore, LiveSession]:
    store = RunStore(tmp_path / "runs.sqlite")
    live = LiveSession({"sea_state": 3})
    app = create_app(
        live, store, access=access(), jobs=QueueOnly(store), sweeps=SweepQueueOnly(store),
        **limits,
    )  # fmt: skip
    return TestClient(app), store, live


def test_a_body_over_the_cap_is_413_before_it_is_parsed(tmp_path: Path) -> None:
    """A POST or PATCH body over the cap is 413 naming the cap, and stores or changes nothing."""
    client, store, live = app_client(tmp_path, max_body=2048)
    big = {**SHORT, "planner": "x" * 4000}
    response = client.post("/api/runs", json=big)
    assert response.status_code == 413
    assert "at most 2048 bytes" in response.json()["message"]
    assert client.patch("/api/live", json={"beta": 0.5, "planner": "y" * 4000}).status_code == 413
    assert store.list_runs() == [] and live.scenario.beta == 0.7


def test_a_chunked_body_without_length_is_cut_off_at_the_cap(tmp_path: Path) -> None:
    """A chunked body with no Content-Length is cut off at the cap with 413, nothing stored."""
    client, store, _ = app_client(tmp_path, max_body=2048)

    def chunks():
        yield b'{"mechanism": "hybrid", "planner": "'
        for _ in range(100):
            yield b"x" * 100
        yield b'"}'

    response = client.post(
        "/api/runs", content=chunks(), headers={"content-type": "application/json"}
    )
    assert response.status_code == 413
    assert store.list_runs() == []


def test_a_bad_content_length_is_400(tmp_path: Path) -> None:
    """A Content-Length that is not a number is a 400 naming the header."""
    client, _, _ = app_client(tmp_path)
    response = client.post(
        "/api/runs", content=b"{}", headers={"content-length": "lots", "content-type": "a/b"}
    )
    assert response.status_code == 400 and "Content-Length" in response.json()["message"]


def test_submissions_past_the_burst_are_429_with_retry_after(tmp_path: Path) -> None:
    """Submissions past the burst are 429 with a Retry-After and the rule in words; runs and
    sweeps share the bucket; refused ones store nothing."""
    client, store, _ = app_client(tmp_path, run_rate=0.5, run_burst=3)
    codes = [client.post("/api/runs", json=SHORT).status_code for _ in range(5)]
    assert codes == [202, 202, 202, 429, 429]
    refused = client.post("/api/runs", json=SHORT)
    assert refused.status_code == 429 and 1 <= int(refused.headers["retry-after"]) <= 2
    assert "at most 3 at once, then 0.5 per second" in refused.json()["detail"]
    assert len(store.list_runs()) == 3  # refused submissions store nothing
    assert client.post("/api/sweeps", json={"hs": [1.0]}).status_code == 429  # same bucket


def test_a_full_queue_is_429_until_runs_finish(tmp_path: Path) -> None:
    """With the pending cap reached a run is 429 naming the count, and accepted again once one
    finishes."""
    client, store, _ = app_client(tmp_path, max_pending_runs=2)
    assert [client.post("/api/runs", json=SHORT).status_code for _ in range(3)] == [202, 202, 429]
    assert "2 runs queued or running (at most 2)" in client.post("/api/runs", json=SHORT).text
    first = store.list_runs()[-1].id
    store.fail(first, "cancelled by the test")
    assert client.post("/api/runs", json=SHORT).status_code == 202


def test_the_rate_limit_refills_and_forgets_idle_clients() -> None:
    """The token bucket refills at its rate, is per client, forgets idle clients (bounded
    memory) and refuses a NaN rate."""
    limit = RateLimit(rate=2.0, burst=2)
    assert [limit.acquire("a", now=0.0) for _ in range(2)] == [0.0, 0.0]
    assert limit.acquire("a", now=0.0) == pytest.approx(0.5)
    assert limit.acquire("a", now=0.5) == 0.0  # one token back after 1 / rate
    assert limit.acquire("b", now=0.5) == 0.0  # buckets are per client
    for i in range(1100):
        limit.acquire(f"c{i}", now=100.0 + i)  # each refills long before the next arrives
    assert len(limit._buckets) <= 1025
    with pytest.raises(ValueError, match="rate > 0"):
        RateLimit(rate=float("nan"), burst=1)


@pytest.mark.parametrize("vessel", [str(asset_path("vessels", "sov.nc")), "/etc/passwd.nc", "../x"])
def test_no_endpoint_takes_a_vessel_path(tmp_path: Path, vessel: str) -> None:
    """Python may load its own RAO file; REST names a shipped table or is refused."""
    Scenario(vessel=str(asset_path("vessels", "sov.nc")))  # allowed from Python
    client, store, live = app_client(tmp_path)
    for response in (
        client.post("/api/runs", json={**SHORT, "vessel": vessel}),
        client.patch("/api/live", json={"vessel": vessel}),
    ):
        assert response.status_code == 422
        assert response.json()["detail"][0]["loc"] == ["body", "vessel"]
    sweep = client.post("/api/sweeps", json={"hs": [1.0], "scenario": {"vessel": vessel}})
    assert sweep.status_code == 422
    assert "vessel" in sweep.json()["message"]  # SweepSpec's own check, or the REST one
    assert store.list_runs() == [] and live.scenario.vessel is None
    assert client.post("/api/runs", json={**SHORT, "vessel": "barge"}).status_code == 202


def test_an_initial_state_outside_the_limits_is_422_naming_the_index(tmp_path: Path) -> None:
    """An initial state outside the joint ranges is 422 naming the index, value and range; an
    over-long one is refused too; nothing stored."""
    client, store, _ = app_client(tmp_path)
    state = [0.0, 0.0, 2.475, 0.0, 0.0, 0.0, 0.0, 0.0, 1e300]
    response = client.post("/api/runs", json={**SHORT, "initial_state": state})
    assert response.status_code == 422
    assert "initial_state[8] = 1e+300" in response.text and "≤ initial_state[8] ≤" in response.text
    too_long = client.post("/api/runs", json={**SHORT, "initial_state": [0.0] * 10_000})
    assert too_long.status_code in (413, 422)
    assert store.list_runs() == []

"""Bounded jobs (issue 30): every sweep is priced before it starts, its heatmap is drawn on the
executor with a panel limit, every run and sweep can be cancelled or deleted, a job that keeps
being interrupted is failed instead of requeued forever, and the pending caps are atomic."""

from __future__ import annotations

import io
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from fastapi.testclient import TestClient
from PIL import Image

from tests.figures import record
from tests.web.support import access, wait_for
from tests.web.test_limits import SHORT, SweepQueueOnly, app_client
from twin.db import MAX_ATTEMPTS
from twin.runs.executor import IN_PROCESS, Executor
from twin.runs.sweep import MAX_PANELS, SweepResult, SweepSpec, SweepStopped, heatmap_bytes
from twin.sim import Scenario
from twin.sim.live import LiveSession
from twin.web import RunStore, SweepRunner, create_app
from twin.web.actions import submit_sweep
from twin.web.limits import price_sweep
from twin.web.store import QueueFull

ONE_CELL = {"hs": [1.0], "tp": [8.0], "seeds": 1, "duration": 0.05}


# -- pricing and the heatmap -------------------------------------------------------------------


def test_a_sweep_over_the_panel_limit_is_422_naming_it_and_stores_nothing(
    tmp_path: Path,
) -> None:
    """A sweep over MAX_PANELS panels is 422 naming the limit and stores nothing; one at the limit
    is accepted."""
    client, store, _ = app_client(tmp_path)
    headings = [float(h) for h in range(MAX_PANELS + 1)]  # the 5,000-heading attack, smaller
    response = client.post("/api/sweeps", json={**ONE_CELL, "heading": headings})
    assert response.status_code == 422
    message = response.json()["message"]
    assert f"at most {MAX_PANELS}" in message and "MAX_PANELS" in message
    assert response.json()["detail"][0]["loc"] == ["body", "heading"]
    assert store.pending("sweeps") == 0
    ok = client.post("/api/sweeps", json={**ONE_CELL, "heading": headings[:MAX_PANELS]})
    assert ok.status_code == 202
    record("attack30_heatmap", panels_asked=len(headings), status=response.status_code,
           stored="nothing", at_the_limit=ok.status_code)  # fmt: skip


def test_a_sweep_is_priced_in_steps_cells_panels_and_bytes() -> None:
    """A sweep's price counts its cells, panels and steps exactly, and positive bytes."""
    spec = SweepSpec(hs=[1, 2], tp=[6, 8, 10], planner=["mtmp", "pi"], seeds=2, duration=1.0)
    price = price_sweep(spec)
    assert (price.cells, price.panels, price.steps) == (12, 2, 12 * 2 * 20)
    assert price.bytes > 0


def _result(panels: int) -> SweepResult:
    spec = SweepSpec(hs=[1.0, 2.0], tp=[8.0], heading=[float(h) for h in range(panels)])
    rows = [
        {"hs": hs, "tp": 8.0, "heading": float(h), "planner": "mtmp", "beta": 0.7, "k_e": 25.0,
         "k_c": 9.0, "runs": 1, "operable_runs": 1, "operability": 1.0}
        for h in range(panels) for hs in (1.0, 2.0)
    ]  # fmt: skip
    return SweepResult(spec, pd.DataFrame(), pd.DataFrame(rows), 0.0, IN_PROCESS)


def test_the_heatmap_draws_at_most_max_panels() -> None:
    """A figure of more panels than allowed is the same size as one of exactly as many."""
    capped = Image.open(io.BytesIO(heatmap_bytes(_result(4), max_panels=3)))
    three = Image.open(io.BytesIO(heatmap_bytes(_result(3), max_panels=3)))
    four = Image.open(io.BytesIO(heatmap_bytes(_result(4), max_panels=4)))  # a second row
    assert capped.format == "PNG"
    assert capped.size[1] == three.size[1] < four.size[1]


class Recording(Executor):
    """An in-process executor that records the functions submitted to it."""

    submitted: list[str]

    def submit(self, fn: Any, *args: Any, **kwargs: Any) -> Any:
        self.submitted.append(getattr(fn, "__name__", repr(fn)))
        return super().submit(fn, *args, **kwargs)


def test_the_heatmap_is_drawn_on_the_executor_not_in_the_server(tmp_path: Path) -> None:
    """A sweep's heatmap PNG is drawn by an executor task, not in the server process."""
    executor = Executor.start(IN_PROCESS)
    executor.__class__ = Recording
    executor.submitted = []
    store = RunStore(tmp_path / "runs.sqlite")
    runner = SweepRunner(store)
    try:
        runner.start(executor)
        sweep = submit_sweep(store, runner, SweepSpec(**ONE_CELL))
        assert wait_for(lambda: store.get_sweep(sweep.id).status == "done", timeout=120)
        assert "heatmap_bytes" in executor.submitted
        assert store.sweep_heatmap(sweep.id).startswith(b"\x89PNG")
        record("attack30_heatmap_process", drawn_by="heatmap_bytes, an executor task")
    finally:
        runner.shutdown()
        executor.close()
        store.close()


# -- cancel and delete -------------------------------------------------------------------------


def test_a_queued_run_can_be_cancelled_and_deleted(tmp_path: Path) -> None:
    """A queued run cancelled is failed (cancelled) and leaves the queue; deleted, it is 404."""
    client, store, _ = app_client(tmp_path)
    run = client.post("/api/runs", json=SHORT).json()
    cancelled = client.post(f"/api/runs/{run['id']}/cancel")
    assert cancelled.status_code == 200
    assert cancelled.json()["status"] == "failed"
    assert cancelled.json()["error"].startswith("cancelled")
    assert store.pending() == 0
    assert client.delete(f"/api/runs/{run['id']}").status_code == 204
    assert client.get(f"/api/runs/{run['id']}").status_code == 404
    assert client.delete(f"/api/runs/{run['id']}").status_code == 404


def test_a_queued_sweep_can_be_cancelled_and_deleted(tmp_path: Path) -> None:
    """A queued sweep cancelled is failed (cancelled) and leaves the queue; deleted, it is 404."""
    client, store, _ = app_client(tmp_path)
    sweep = client.post("/api/sweeps", json=ONE_CELL).json()
    cancelled = client.post(f"/api/sweeps/{sweep['id']}/cancel").json()
    assert cancelled["status"] == "failed" and cancelled["error"].startswith("cancelled")
    assert store.pending("sweeps") == 0
    assert client.delete(f"/api/sweeps/{sweep['id']}").status_code == 204
    assert client.get(f"/api/sweeps/{sweep['id']}").status_code == 404


def test_cancel_and_delete_need_the_token(tmp_path: Path) -> None:
    """Cancel and delete without the token are 401 and leave the run queued."""
    store = RunStore(tmp_path / "runs.sqlite")
    app = create_app(
        LiveSession(), store, access=access("s3cret-token-0123"), sweeps=SweepQueueOnly(store)
    )
    client = TestClient(app)
    run = store.create(Scenario(**SHORT))
    assert client.post(f"/api/runs/{run.id}/cancel").status_code == 401
    assert client.delete(f"/api/runs/{run.id}").status_code == 401
    assert store.get(run.id).status == "queued"


def test_cancelling_a_running_sweep_stops_it_and_the_next_one_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The sweep in hand sees the cancel at its next chunk; it stays cancelled (no outcome
    written over it) and the queue goes on."""
    import twin.runs.sweep as sweep_module

    release = threading.Event()
    calls: list[str] = []

    def fake_run_sweep(spec: Any, *, stop: Any, **_: Any) -> Any:
        calls.append("run")
        if len(calls) == 1:  # the first sweep: a long one, until cancelled
            while not stop():
                release.wait(0.01)
            raise SweepStopped("stopped")
        return _result(1)

    monkeypatch.setattr(sweep_module, "run_sweep", fake_run_sweep)
    monkeypatch.setattr(sweep_module, "heatmap_bytes", lambda result: b"\x89PNG")
    store = RunStore(tmp_path / "runs.sqlite")
    runner = SweepRunner(store)
    executor = Executor.start(IN_PROCESS)
    try:
        runner.start(executor)
        first = submit_sweep(store, runner, SweepSpec(**ONE_CELL))
        second = submit_sweep(store, runner, SweepSpec(**ONE_CELL))
        assert wait_for(lambda: store.get_sweep(first.id).status == "running", timeout=30)
        assert runner.cancel(first.id)
        assert wait_for(lambda: store.get_sweep(second.id).status == "done", timeout=60)
        stopped = store.get_sweep(first.id)
        assert stopped.status == "failed" and stopped.error.startswith("cancelled")
        record("attack30_cancel", running_sweep=stopped.error, next_sweep="done")
    finally:
        runner.shutdown()
        executor.close()
        store.close()


# -- restarts ----------------------------------------------------------------------------------


def test_a_run_interrupted_max_attempts_times_is_failed_not_requeued(tmp_path: Path) -> None:
    """A run interrupted MAX_ATTEMPTS times is failed, saying so, instead of requeued again."""
    with RunStore(tmp_path / "runs.sqlite") as store:
        run = store.create(Scenario(**SHORT))
        for _ in range(MAX_ATTEMPTS):
            assert store.requeue_unfinished() == [run.id]  # a server starts …
            assert store.mark_running(run.id)  # … runs it, and is stopped or crashes
        assert store.requeue_unfinished() == []
        failed = store.get(run.id)
        assert failed.status == "failed" and "interrupted" in failed.error
        assert f"{MAX_ATTEMPTS} times" in failed.error
        record("attack30_requeue", starts=MAX_ATTEMPTS, then=failed.status)


def test_a_sweep_interrupted_max_attempts_times_is_failed_not_requeued(tmp_path: Path) -> None:
    """A sweep interrupted MAX_ATTEMPTS times is failed as interrupted instead of requeued again."""
    with RunStore(tmp_path / "runs.sqlite") as store:
        sweep = store.create_sweep(SweepSpec(**ONE_CELL).model_dump(), 1)
        for _ in range(MAX_ATTEMPTS):
            assert store.requeue_unfinished_sweeps() == [sweep.id]
            store.sweep_running(sweep.id)
        assert store.requeue_unfinished_sweeps() == []
        assert "interrupted" in store.get_sweep(sweep.id).error


# -- atomic caps -------------------------------------------------------------------------------


def test_the_pending_sweep_cap_holds_under_concurrent_submissions(tmp_path: Path) -> None:
    """Under 40 concurrent submissions the store admits exactly the pending-sweep cap."""
    with RunStore(tmp_path / "runs.sqlite") as store:
        spec = SweepSpec(**ONE_CELL).model_dump()

        def submit(_: int) -> bool:
            try:
                store.create_sweep(spec, 1, max_pending=4)
            except QueueFull:
                return False
            return True

        with ThreadPoolExecutor(8) as pool:
            admitted = sum(pool.map(submit, range(40)))
        assert admitted == 4 == store.pending("sweeps")
        record("attack30_pending_sweeps", submitted=40, threads=8, admitted=admitted, cap=4)


def test_the_viewer_surface_is_capped_like_rest(tmp_path: Path) -> None:
    """`submit_sweep` (the viewer's button calls it) refuses past MAX_PENDING_SWEEPS."""
    from twin.web.deps import MAX_PENDING_SWEEPS

    with RunStore(tmp_path / "runs.sqlite") as store:
        runner = SweepQueueOnly(store)
        for _ in range(MAX_PENDING_SWEEPS):
            submit_sweep(store, runner, SweepSpec(**ONE_CELL))
        with pytest.raises(QueueFull, match=f"at most {MAX_PENDING_SWEEPS}"):
            submit_sweep(store, runner, SweepSpec(**ONE_CELL))
        assert store.pending("sweeps") == MAX_PENDING_SWEEPS


def test_the_pending_run_cap_holds_under_concurrent_rest_submissions(tmp_path: Path) -> None:
    """Under concurrent REST submissions exactly the pending-run cap is accepted (202), the rest
    429."""
    client, store, _ = app_client(tmp_path, max_pending_runs=3, run_burst=100, run_rate=100.0)

    def post(_: int) -> int:
        return client.post("/api/runs", json=SHORT).status_code

    with ThreadPoolExecutor(8) as pool:
        codes = list(pool.map(post, range(24)))
    assert codes.count(202) == 3 == store.pending()
    assert set(codes) == {202, 429}





def test_a_full_store_is_507_saying_what_to_do(tmp_path: Path) -> None:
    """A run past the store's quota is 507 naming --max-runs and DELETE; after a delete one is
    accepted."""
    from tests.web.test_limits import QueueOnly
    from twin.web.store import Quota

    store = RunStore(tmp_path / "runs.sqlite", Quota(max_runs=1))
    app = create_app(LiveSession(), store, access=access(), jobs=QueueOnly(store),
                     sweeps=SweepQueueOnly(store))  # fmt: skip
    client = TestClient(app)
    assert client.post("/api/runs", json=SHORT).status_code == 202
    full = client.post("/api/runs", json=SHORT)
    assert full.status_code == 507
    record("attack30_disk", max_runs=1, second_run=full.status_code, after_delete=202)
    assert "--max-runs" in full.json()["detail"] and "DELETE" in full.json()["detail"]
    run_id = store.list_runs()[0].id
    assert client.delete(f"/api/runs/{run_id}").status_code == 204  # room again
    assert client.post("/api/runs", json=SHORT).status_code == 202


# -- shutdown ----------------------------------------------------------------------------------


def test_a_start_reported_after_the_stop_leaves_the_run_queued(tmp_path: Path) -> None:
    """A worker's "started" report, or an in-process run's start, handled after the shutdown
    began marks nothing: the run stays queued for the next start (no run left `running`)."""
    from twin.web.jobs import JobRunner

    with RunStore(tmp_path / "runs.sqlite") as store:
        runner = JobRunner(store)
        executor = Executor.start(IN_PROCESS)
        try:
            runner.start(executor)
            run = store.create(Scenario(**SHORT))  # stored, not yet handed to the runner
            runner.shutdown()
            runner._progress(run.id, {"name": run.id, "progress": 0.0})
            assert not runner._mark_running(run.id)
            assert store.get(run.id).status == "queued"
        finally:
            executor.close()


class FailingSweeps(SweepQueueOnly):
    def shutdown(self, timeout: float = 2.0) -> None:
        raise RuntimeError("a runner that fails to stop")


def test_runs_are_requeued_at_shutdown_even_when_another_runner_fails_to_stop(
    tmp_path: Path,
) -> None:
    """The app's shutdown stops every runner whatever another raised: a run left running is
    queued again although the sweep runner's shutdown failed."""
    from twin.web.jobs import JobRunner

    store = RunStore(tmp_path / "runs.sqlite")
    app = create_app(LiveSession({"sea_state": 3}), store, access=access(),
                     jobs=JobRunner(store), sweeps=FailingSweeps(store))  # fmt: skip
    try:
        with TestClient(app):
            run = store.create(Scenario(**SHORT))
            assert store.mark_running(run.id)
        assert store.get(run.id).status == "queued"
    finally:
        store.close()

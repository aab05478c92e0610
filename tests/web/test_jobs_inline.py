"""Short runs on the server's own thread (issue 30: a 60 s run's POST p50): a run of at most
`INLINE_MAX_STEPS` steps runs in process when that thread is free, with the same engine and the
same stored outcome as on the executor; a second one meanwhile goes to the executor; a cancel
in flight drops its outcome; a refused scenario is refused as before."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.web.support import HeldRuns, record_run_threads, refuse_runs, wait_for
from twin.runs.executor import IN_PROCESS, Executor
from twin.sim import Scenario
from twin.web.jobs import INLINE_MAX_STEPS, JobRunner, steps
from twin.web.store import RunStore

#: 20 steps of the hybrid system: well under INLINE_MAX_STEPS
SHORT = {"mechanism": "hybrid", "duration": 1.0, "sea_state": 3}


class Recording(Executor):
    """An in-process executor that records the functions submitted to it."""

    submitted: list[str]

    def submit(self, fn: Any, *args: Any, **kwargs: Any) -> Any:
        self.submitted.append(getattr(fn, "__name__", repr(fn)))
        return super().submit(fn, *args, **kwargs)


@pytest.fixture(scope="module")
def executor() -> Iterator[Recording]:
    executor = Executor.start(IN_PROCESS)
    executor.__class__ = Recording
    assert isinstance(executor, Recording)
    executor.submitted = []
    try:
        yield executor
    finally:
        executor.close()


@pytest.fixture
def store(tmp_path: Path) -> Iterator[RunStore]:
    with RunStore(tmp_path / "runs.sqlite") as store:
        yield store


def _runner(store: RunStore, executor: Executor, **options: Any) -> JobRunner:
    jobs = JobRunner(store, **options)
    jobs.start(executor)
    return jobs


def test_a_short_run_runs_in_process_with_the_executors_outcome(
    store: RunStore, executor: Recording
) -> None:
    """The same scenario in process and on the executor: one engine, so the same metrics and
    series, and only the second is an executor task."""
    scenario = Scenario(**SHORT)
    assert steps(scenario) <= INLINE_MAX_STEPS
    inline = _runner(store, executor)
    try:
        executor.submitted.clear()
        here = inline.submit(store.create(scenario).id).result(timeout=120)
        assert executor.submitted == []  # no Dask task for it
    finally:
        inline.shutdown()
    remote = _runner(store, executor, inline_max_steps=0)
    try:
        there = remote.submit(store.create(scenario).id).result(timeout=120)
        assert executor.submitted == ["run_scenario"]
    finally:
        remote.shutdown()
    assert here.status == there.status == "done" and here.progress == 1.0
    assert here.metrics == there.metrics
    a, b = store.result(here.id), store.result(there.id)
    assert a.series.keys() == b.series.keys()
    for key in a.series:
        assert (a.series[key] == b.series[key]).all(), key


@pytest.mark.parametrize("second_by", ["submit", "run_here"])
def test_a_short_run_while_one_is_in_hand_goes_to_the_executor(
    store: RunStore, executor: Recording, monkeypatch: pytest.MonkeyPatch, second_by: str
) -> None:
    """One short run in process at a time, one slot for both threads: the next, submitted or
    run by a request's thread, goes to the executor instead of waiting, and both finish."""
    held = HeldRuns(monkeypatch, first_only=True)
    jobs = _runner(store, executor)
    try:
        executor.submitted.clear()
        first = jobs.submit(store.create(Scenario(**SHORT)).id)
        assert held.entered.wait(60)
        second = getattr(jobs, second_by)(store.create(Scenario(**SHORT)).id)
        assert second.result(timeout=120).status == "done"
        assert executor.submitted == ["run_scenario"]
        assert not first.done()  # still held on the server's thread
        held.release.set()
        assert first.result(timeout=120).status == "done"
    finally:
        held.release.set()
        jobs.shutdown()


def test_cancelling_a_short_run_in_flight_drops_its_outcome(
    store: RunStore, executor: Recording, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A short run cancelled while running is failed as cancelled, its result dropped and nothing
    left pending."""
    held = HeldRuns(monkeypatch)
    entered, release = held.entered, held.release
    jobs = _runner(store, executor)
    try:
        run = store.create(Scenario(**SHORT))
        done = jobs.submit(run.id)
        assert entered.wait(60)
        assert store.get(run.id).status == "running"
        assert jobs.cancel(run.id)
        release.set()
        assert wait_for(done.done, timeout=60) and done.cancelled()
        stored = store.get(run.id)
        assert stored.status == "failed" and stored.error is not None
        assert stored.error.startswith("cancelled") and stored.metrics is None
        assert jobs.pending() == 0
    finally:
        release.set()
        jobs.shutdown()


def test_a_short_run_the_engine_refuses_raises_as_on_the_executor(
    store: RunStore, executor: Recording, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A `ValueError` before the first step reaches the request (a 422 there), stored failed."""
    refuse_runs(monkeypatch)
    jobs = _runner(store, executor)
    try:
        run = store.create(Scenario(**SHORT))
        with pytest.raises(ValueError, match="refused by the engine"):
            jobs.submit(run.id).result(timeout=60)
        assert store.get(run.id).status == "failed"
    finally:
        jobs.shutdown()


def test_run_here_runs_on_the_calling_thread_with_the_executors_outcome(
    store: RunStore, executor: Recording, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A request's worker thread runs its short run itself (no hand-off to the runner's
    thread): resolved when `run_here` returns, no executor task, and the same stored run as
    the executor's."""
    threads = record_run_threads(monkeypatch)
    scenario = Scenario(**SHORT)
    jobs = _runner(store, executor)
    try:
        executor.submitted.clear()
        done = jobs.run_here(store.create(scenario).id)
        assert done.done() and threads == [threading.current_thread()]
        assert executor.submitted == [] and jobs.pending() == 0
        here = done.result()
    finally:
        jobs.shutdown()
    remote = _runner(store, executor, inline_max_steps=0)
    try:
        there = remote.run_here(store.create(scenario).id).result(timeout=120)
        assert executor.submitted == ["run_scenario"]  # too long to run here: the executor
    finally:
        remote.shutdown()
    assert here.status == there.status == "done" and here.metrics == there.metrics
    assert here == store.get(here.id)  # the answer is the run as stored
    a, b = store.result(here.id), store.result(there.id)
    for key in a.series:
        assert (a.series[key] == b.series[key]).all(), key


def test_cancelling_a_run_running_here_drops_its_outcome(
    store: RunStore, executor: Recording, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A cancel while a request's thread runs the run: the future is cancelled, the run stays
    cancelled in the store, and the slot is free again."""
    held = HeldRuns(monkeypatch)
    entered, release = held.entered, held.release
    jobs = _runner(store, executor)
    run = store.create(Scenario(**SHORT))
    outcome: list[Any] = []
    request = threading.Thread(target=lambda: outcome.append(jobs.run_here(run.id)))
    try:
        request.start()
        assert entered.wait(60) and store.get(run.id).status == "running"
        assert jobs.cancel(run.id)
        release.set()
        request.join(60)
        assert outcome and outcome[0].cancelled()
        stored = store.get(run.id)
        assert stored.status == "failed" and stored.error is not None
        assert stored.error.startswith("cancelled") and stored.metrics is None
        assert jobs.pending() == 0
        executor.submitted.clear()
        assert jobs.run_here(store.create(Scenario(**SHORT)).id).done()  # the slot is free
        assert executor.submitted == []
    finally:
        release.set()
        jobs.shutdown()


def test_run_here_before_start_says_so_as_submit_does(store: RunStore) -> None:
    """Not started: as `submit`, it says so (and runs nothing)."""
    run = store.create(Scenario(**SHORT))
    with pytest.raises(RuntimeError, match="start"):
        JobRunner(store).run_here(run.id)
    assert store.get(run.id).status == "queued"

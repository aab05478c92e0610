"""RunStore: runs persist in SQLite across reopening, exactly, and writes are all-or-nothing."""

from __future__ import annotations

import sqlite3
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from twin.errors import TwinError
from twin.sim import Scenario, SimulationResult, simulate
from twin.web.store import SCHEMA_VERSION, RunNotFound, RunStore

SHORT = Scenario(mechanism="hybrid", planner="mtmp", sea_state=3, duration=1.0)


@pytest.fixture(scope="module")
def result() -> SimulationResult:
    return simulate(SHORT)


@pytest.fixture
def store(tmp_path: Path) -> Iterator[RunStore]:
    with RunStore(tmp_path / "data" / "runs.sqlite") as store:
        yield store


def test_a_new_run_is_queued_with_its_validated_scenario(store: RunStore) -> None:
    """A new run is queued at progress 0 with its validated scenario, defaults filled in."""
    run = store.create(Scenario(mechanism="upr4", duration=2.0))
    assert run.status == "queued" and run.progress == 0.0 and run.metrics is None
    assert len(run.id) == 32 and run.created.tzinfo is not None
    assert run.scenario["planner"] == "pid"  # the mechanism's default, filled in
    assert store.scenario(run.id) == Scenario(mechanism="upr4", duration=2.0)


def test_runs_survive_reopening_the_file_bit_for_bit(
    store: RunStore, result: SimulationResult
) -> None:
    """A restart reads back status, metrics and identical series (npz keeps float64 exactly)."""
    run_id = store.create(SHORT).id
    store.mark_running(run_id)
    store.finish(run_id, result)
    store.close()
    with RunStore(store.path) as reopened:
        run = reopened.get(run_id)
        assert run.status == "done" and run.progress == 1.0 and run.finished is not None
        assert run.metrics == result.metrics
        stored = reopened.result(run_id)
    assert list(stored.series) == list(result.series)  # column order kept for csv/parquet
    for key, values in result.series.items():
        np.testing.assert_array_equal(stored.series[key], values)
    assert stored.scenario.model_dump() == result.scenario.model_dump()


def test_the_file_is_in_wal_mode_with_the_schema_version(store: RunStore) -> None:
    """The store's SQLite file is in WAL mode with the current schema version."""
    with sqlite3.connect(store.path) as conn:
        assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION


def test_a_newer_schema_is_refused(tmp_path: Path) -> None:
    """A store file of a newer schema is refused with a TwinError saying so."""
    path = tmp_path / "runs.sqlite"
    with sqlite3.connect(path) as conn:
        conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    with pytest.raises(TwinError, match="newer"):
        RunStore(path)


def test_list_is_newest_first_and_limited(store: RunStore) -> None:
    """list_runs returns runs newest first, at most `limit`."""
    ids = [store.create(SHORT).id for _ in range(4)]
    assert [r.id for r in store.list_runs()] == ids[::-1]
    assert [r.id for r in store.list_runs(limit=2)] == ids[:1:-1]


def test_unknown_ids_raise_run_not_found(store: RunStore, result: SimulationResult) -> None:
    """Every store call with an unknown id raises RunNotFound naming it."""
    for call in (store.get, store.scenario, store.result, store.mark_running):
        with pytest.raises(RunNotFound, match="nope"):
            call("nope")
    with pytest.raises(RunNotFound):
        store.finish("nope", result)


def test_a_run_not_done_has_no_series(store: RunStore) -> None:
    """Asking for the result of a queued run raises TwinError naming its status."""
    run_id = store.create(SHORT).id
    with pytest.raises(TwinError, match="queued"):
        store.result(run_id)


def test_failure_and_progress_are_recorded(store: RunStore) -> None:
    """Progress is recorded clipped to [0, 1], and a failure with its error."""
    run_id = store.create(SHORT).id
    store.mark_running(run_id)
    store.set_progress(run_id, 0.25)
    assert store.get(run_id).progress == 0.25
    store.set_progress(run_id, 7.0)  # clipped, never outside [0, 1]
    assert store.get(run_id).progress == 1.0
    store.fail(run_id, "TwinError: boom")
    run = store.get(run_id)
    assert run.status == "failed" and run.error == "TwinError: boom"


def test_a_rejected_finish_writes_nothing(store: RunStore, result: SimulationResult) -> None:
    """Metrics that are not finite JSON are refused before the transaction: still running."""
    run_id = store.create(SHORT).id
    store.mark_running(run_id)
    bad = SimulationResult(result.scenario, result.series, {"eta": float("nan")})
    with pytest.raises(ValueError):
        store.finish(run_id, bad)
    run = store.get(run_id)
    assert run.status == "running" and run.metrics is None


def test_unfinished_runs_are_requeued_oldest_first(
    store: RunStore, result: SimulationResult
) -> None:
    """requeue_unfinished requeues queued and running runs oldest first and leaves done ones."""
    queued, running, done = (store.create(SHORT).id for _ in range(3))
    store.mark_running(running)
    store.mark_running(done)
    store.finish(done, result)
    assert store.requeue_unfinished() == [queued, running]
    assert store.get(running).status == "queued" and store.get(done).status == "done"


def test_two_stores_on_one_file_write_concurrently(store: RunStore) -> None:
    """Threads and a second connection (as worker processes have) lose no run."""
    other = RunStore(store.path)
    created: list[str] = []

    def create(s: RunStore) -> None:
        for _ in range(20):
            created.append(s.create(SHORT).id)

    threads = [threading.Thread(target=create, args=(s,)) for s in (store, other, store, other)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    other.close()
    assert len(created) == 80
    assert {r.id for r in store.list_runs(limit=500)} == set(created)


def test_a_corrupt_file_is_one_line_saying_what_to_do(tmp_path: Path) -> None:
    """Issue 30: a raw sqlite traceback after 23 s of start-up before; now a TwinError whose
    one line names the file and the way out (the server opens the store before the executor)."""
    path = tmp_path / "runs.sqlite"
    path.write_bytes(b"this is not a database" * 100)
    with pytest.raises(TwinError) as info:
        RunStore(path)
    message = str(info.value)
    assert "\n" not in message and str(path) in message and "move it aside" in message
    from tests.figures import record

    record("attack30_corrupt_store", lines=1, says="move it aside")


def test_one_bad_row_is_that_rows_error_not_the_lists(store: RunStore) -> None:
    """An unreadable row is listed as failed (unreadable) while the other rows list normally."""
    good = store.create(SHORT).id
    bad = store.create(SHORT).id
    with sqlite3.connect(store.path) as conn:
        conn.execute("UPDATE runs SET scenario = '{not json' WHERE id = ?", (bad,))
    runs = {run.id: run for run in store.list_runs()}
    assert runs[good].status == "queued"
    assert runs[bad].status == "failed" and "unreadable" in runs[bad].error
    from tests.figures import record

    record("attack30_bad_row", list_status=200, bad_row="failed, unreadable")


def test_an_older_stores_npz_series_still_read(store: RunStore, result: SimulationResult) -> None:
    """Series stored as npz by an older store read back exactly."""
    import io

    run_id = store.create(SHORT).id
    store.mark_running(run_id)
    buffer = io.BytesIO()
    np.savez(buffer, **result.series)  # how series were stored before issue 30
    store.finish_packed(run_id, result.metrics, buffer.getvalue())
    for key, values in store.result(run_id).series.items():
        np.testing.assert_array_equal(values, result.series[key])


def _full_store(tmp_path: Path, **quota: object) -> RunStore:
    from twin.web.store import Quota

    return RunStore(tmp_path / "q.sqlite", Quota(**quota))


def test_a_full_store_refuses_naming_the_quota(tmp_path: Path, result: SimulationResult) -> None:
    """A store at its run or byte quota refuses a new run with StoreFull naming the option, within
    the quota."""
    from twin.web.store import StoreFull

    with _full_store(tmp_path, max_runs=2) as store:
        for _ in range(2):
            store.create(SHORT)
        with pytest.raises(StoreFull, match="--max-runs"):
            store.create(SHORT)
        assert len(store.list_runs()) == 2
    with _full_store(tmp_path / "b", max_bytes=50_000) as store:
        with pytest.raises(StoreFull, match="--max-store"):
            for _ in range(100):  # a 1 s run reserves its price, ~ 8 KB
                store.create(SHORT)
        used, runs = store.usage()
        assert used <= 50_000 and 1 <= runs < 100


def test_retention_deletes_the_oldest_finished_unpinned_results(
    tmp_path: Path, result: SimulationResult
) -> None:
    """With retention, a full store deletes the oldest finished unpinned run to make room."""
    with _full_store(tmp_path, max_runs=3, retain=True) as store:
        ids = []
        for _ in range(3):
            run_id = store.create(SHORT).id
            store.mark_running(run_id)
            store.finish(run_id, result)
            ids.append(run_id)
        store.pin("runs", ids[0])
        newest = store.create(SHORT).id  # full: the oldest unpinned finished one goes
        kept = {run.id for run in store.list_runs()}
        assert kept == {ids[0], ids[2], newest}


def test_a_finished_run_counts_what_it_stored_not_its_price(
    store: RunStore, result: SimulationResult
) -> None:
    """A finished run's usage is what it stored, less than the price reserved for it."""
    run_id = store.create(Scenario(mechanism="hybrid", duration=600.0)).id
    reserved, _ = store.usage()
    store.mark_running(run_id)
    store.finish(run_id, result)  # 1 s of series: far less than 600 s were priced at
    stored, _ = store.usage()
    assert stored < reserved

"""The run store: every scripted run, its status, metrics and series, in one SQLite file.

One table of runs, one row per run, and one of operability sweeps (`sweeps`). SQLite in WAL
mode lets the web process read while a worker process writes; every change is one
transaction, so a process killed mid-write leaves the previous state and the file reopens
consistent. Series are a Parquet blob (`pack_series`: zstd, float64 exact, each column
readable alone; older stores' npz blobs are read as before), written once when the run is
done.

Status goes queued → running → done | failed; `progress` is the fraction of steps taken, and
only grows while a run is running (a late progress report never moves a done run back).

The store is written by the server process alone (workers send results back through the
executor), and one server holds a data directory at a time (`twin.web.lock`). It remembers
which file it opened: if that file is deleted or replaced while the server runs, every access
raises `StoreUnavailable` (a 503) instead of writing runs into a file nobody can open again.
"""

from __future__ import annotations

import json
import sqlite3
import time
import uuid
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from types import TracebackType
from typing import Any, Literal

from pydantic import BaseModel, Field

from twin.db import (
    CANCELLED,
    MAX_ATTEMPTS,
    UNFINISHED,
    WAS_CANCELLED,
    Database,
    cancel_sql,
    migrate,
    requeue,
)
from twin.errors import TwinError
from twin.runs.executor import pack_series, unpack_series
from twin.sim import Scenario, SimulationResult

Status = Literal["queued", "running", "done", "failed"]

#: SQLite's `synchronous` in WAL mode. NORMAL: a commit is durable once it returns against a
#: crash of the process (the WAL is in the OS's hands), and the file stays consistent after a
#: power loss or an OS crash, which may lose the last commits since the WAL was last synced (at
#: a checkpoint). FULL also syncs the WAL on every commit: 4-8 ms a commit on our VM's disk
#: against 0.4 ms (issue 30), three commits in every synchronous POST /api/runs
#: (docs/reliability.md).
SYNCHRONOUS = "NORMAL"
#: bumped when the table changes; a newer file is refused rather than misread
SCHEMA_VERSION = 1

_SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    id        TEXT PRIMARY KEY,
    created   REAL NOT NULL,
    finished  REAL,
    status    TEXT NOT NULL CHECK (status IN ('queued', 'running', 'done', 'failed')),
    progress  REAL NOT NULL DEFAULT 0 CHECK (progress BETWEEN 0 AND 1),
    scenario  TEXT NOT NULL,
    metrics   TEXT,
    error     TEXT,
    series    BLOB,
    attempts  INTEGER NOT NULL DEFAULT 0,
    size      INTEGER NOT NULL DEFAULT 0,
    pinned    INTEGER NOT NULL DEFAULT 0
);
CREATE INDEX IF NOT EXISTS runs_by_created ON runs (created);
CREATE TABLE IF NOT EXISTS sweeps (
    id        TEXT PRIMARY KEY,
    created   REAL NOT NULL,
    finished  REAL,
    status    TEXT NOT NULL CHECK (status IN ('queued', 'running', 'done', 'failed')),
    done      INTEGER NOT NULL DEFAULT 0,
    total     INTEGER NOT NULL,
    spec      TEXT NOT NULL,
    result    TEXT,
    error     TEXT,
    heatmap   BLOB,
    attempts  INTEGER NOT NULL DEFAULT 0,
    size      INTEGER NOT NULL DEFAULT 0,
    pinned    INTEGER NOT NULL DEFAULT 0
);
"""
#: columns added after a table's first version, each with its default: added to an older file
#: when this twin opens it (schema-1 readers name their columns, so they read it as before)
_ADDED = {
    table: {name: "INTEGER NOT NULL DEFAULT 0" for name in ("attempts", "size", "pinned")}
    for table in ("runs", "sweeps")
}
#: [bytes] what a row holds, by table (`size` of rows written before it was kept)
_ROW_BYTES = {
    "runs": "LENGTH(scenario) + COALESCE(LENGTH(metrics), 0) + COALESCE(LENGTH(series), 0)",
    "sweeps": "LENGTH(spec) + COALESCE(LENGTH(result), 0) + COALESCE(LENGTH(heatmap), 0)",
}
#: [bytes] a row's own overhead beside its fields (ids, times, status; an upper bound)
ROW_OVERHEAD = 256
# The sweeps table came after schema 1 without changing what schema-1 readers see, so the
# version stays: IF NOT EXISTS adds it to an older file the first time this twin opens it.
# `series` is the last column so listing runs never reads a blob's overflow pages.
_COLUMNS = "id, created, finished, status, progress, scenario, metrics, error"
_SWEEP_COLUMNS = "id, created, finished, status, done, total, spec, result, error"


class RunNotFound(TwinError):
    """No run has this id."""


@dataclass(frozen=True)
class Quota:
    """How much a store may hold (`twin serve --max-store`, `--max-runs`, `--retain`).

    Attributes:
        max_bytes: [bytes] runs' and sweeps' stored fields in all (None: no limit). A queued
            or running job counts its price (`limits.price_run`, an upper bound) until it is
            done, then what it stored.
        max_runs: runs stored at most (None: no limit).
        retain: when full, delete the oldest finished (done or failed), unpinned results to
            make room, instead of refusing.
    """

    max_bytes: int | None = None
    max_runs: int | None = None
    retain: bool = False


class StoreFull(TwinError):
    """The store's quota is reached and nothing may be deleted to make room (a 507)."""


class QueueFull(TwinError):
    """As many runs (or sweeps) are queued or running as allowed: nothing was stored.

    Attributes:
        pending: how many are queued or running.
        cap: the most allowed.
    """

    def __init__(self, what: str, pending: int, cap: int) -> None:
        super().__init__(
            f"{pending} {what} queued or running (at most {cap}); retry once some finish"
        )
        self.pending, self.cap = pending, cap


__all__ = [
    "QueueFull",
    "Quota",
    "Run",
    "RunNotFound",
    "RunStore",
    "StoreFull",
    "Sweep",
    "SweepNotFound",
    "pack_series",
    "unpack_series",
]


class Run(BaseModel):
    """A stored run without its series (`RunStore.result` has those)."""

    id: str = Field(description="run id (32 hex digits)")
    created: datetime = Field(description="when the run was submitted (UTC)")
    finished: datetime | None = Field(None, description="when it finished (UTC)")
    status: Status = Field(description="queued → running → done | failed")
    progress: float = Field(description="[-] fraction of the steps taken, 0-1")
    scenario: dict[str, Any] = Field(description="the validated scenario, every field")
    metrics: dict[str, Any] | None = Field(None, description="once done (docs/simulation.md)")
    error: str | None = Field(None, description="why it failed")


class Sweep(BaseModel):
    """A stored operability sweep without its heatmap (`RunStore.sweep_heatmap` has it)."""

    id: str = Field(description="sweep id (32 hex digits)")
    created: datetime = Field(description="when the sweep was submitted (UTC)")
    finished: datetime | None = Field(None, description="when it finished (UTC)")
    status: Status = Field(description="queued → running → done | failed")
    done: int = Field(description="runs finished")
    total: int = Field(description="runs in all (cells × seeds)")
    progress: float = Field(description="[-] done / total, 0-1")
    spec: dict[str, Any] = Field(description="the validated SweepSpec, every field")
    result: dict[str, Any] | None = Field(
        None,
        description="once done: the criterion, `tip_error_threshold` [m], elapsed [s] and the "
        "operability table's rows (`cells`)",
    )
    error: str | None = Field(None, description="why it failed")


def _sweep(row: sqlite3.Row) -> Sweep:
    try:
        return _sweep_fields(row)
    except (ValueError, TypeError) as exc:
        return Sweep(**_unreadable(row, exc), done=0, total=0, progress=0.0, spec={})


def _sweep_fields(row: sqlite3.Row) -> Sweep:
    return Sweep(
        id=row["id"],
        created=_utc(row["created"]),
        finished=_utc(row["finished"]),
        status=row["status"],
        done=row["done"],
        total=row["total"],
        progress=row["done"] / row["total"] if row["total"] else 0.0,
        spec=json.loads(row["spec"]),
        result=None if row["result"] is None else json.loads(row["result"]),
        error=row["error"],
    )


class SweepNotFound(RunNotFound):
    """No sweep has this id (a `RunNotFound`, so the API answers 404 alike)."""


def _utc(t: float | None) -> datetime | None:
    return None if t is None else datetime.fromtimestamp(t, UTC)


def _unreadable(row: sqlite3.Row, exc: Exception) -> dict[str, Any]:
    """The fields of a row whose stored JSON cannot be read: failed, saying why, so one bad
    row is that row's error and not a 500 for a whole list."""
    return {
        "id": row["id"], "created": _utc(row["created"]), "finished": _utc(row["finished"]),
        "status": "failed", "error": f"stored row unreadable ({type(exc).__name__}: {exc}); "
        "delete it (DELETE) or restore the store from a backup",
    }  # fmt: skip


#: tables whose rows count as stored runs against `Quota.max_runs` (a workability job keeps
#: its uploaded record's columns: issue 43)
COUNTED = ("runs", "workability")
#: tables whose finished, unpinned rows a retaining store deletes to make room, and the
#: tables of their parts deleted with them
_RETAINED = {"runs": (), "sweeps": (), "workability": ("workability_plots",)}


def _has_table(conn: sqlite3.Connection, table: str) -> bool:
    sql = "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?"
    return conn.execute(sql, (table,)).fetchone() is not None


def usage(conn: sqlite3.Connection) -> tuple[int, int]:
    """([bytes] stored or reserved by runs, sweeps and workability jobs, rows counted as runs:
    runs and workability jobs) of the store file `conn` is open on (a workability table not
    there yet, or without its `size`, counts nothing)."""
    used = runs = 0
    for table in _RETAINED:
        if not _has_table(conn, table):
            continue
        try:
            count, size = conn.execute(
                f"SELECT COUNT(*), COALESCE(SUM(size), 0) FROM {table}"
            ).fetchone()
        except sqlite3.OperationalError:  # an older workability table, before its `size`
            continue
        used += size
        runs += count if table in COUNTED else 0
    return used, runs


def make_room(conn: sqlite3.Connection, quota: Quota, table: str, need: int) -> None:
    """Within a write transaction on `conn`: room for a new row of `need` bytes in `table`
    under `quota`, deleting the oldest finished unpinned results if it retains (runs, sweeps
    and workability jobs alike, oldest first).

    Raises:
        StoreFull: over the quota, and (without retention, or nothing left to delete) no
            room can be made.
    """
    if quota.max_bytes is None and quota.max_runs is None:
        return
    counted = table in COUNTED

    def over() -> tuple[bool, bool]:
        used, runs = usage(conn)
        return (quota.max_bytes is not None and used + need > quota.max_bytes,
                counted and quota.max_runs is not None and runs + 1 > quota.max_runs)  # fmt: skip

    def finished(t: str) -> str:  # workability jobs cannot be pinned
        return "status IN ('done', 'failed')" + (" AND pinned = 0" if t != "workability" else "")

    while any(too_much := over()):
        victim = None
        if quota.retain:
            # only a counted row's deletion frees a run's place
            tables = [t for t in _RETAINED if _has_table(conn, t)
                      and (t in COUNTED or not too_much[1])]  # fmt: skip
            victim = conn.execute(" UNION ALL ".join(
                f"SELECT '{t}' AS t, id, created FROM {t} WHERE {finished(t)}" for t in tables
            ) + " ORDER BY created LIMIT 1").fetchone()  # fmt: skip
        if victim is None:
            used, runs = usage(conn)
            limit = (f"{used + need} of at most {quota.max_bytes} bytes" if too_much[0]
                     else f"{runs + 1} runs of at most {quota.max_runs}")  # fmt: skip
            raise StoreFull(
                f"run store full: this would make {limit} (--max-store, --max-runs; stored "
                "workability jobs count as runs); delete runs, sweeps or workability jobs "
                "(DELETE /api/runs/{id}, /api/sweeps/{id}, /api/workability/{id}), unpin "
                "some, or start the server with a larger quota or --retain"
            )
        for part in (victim["t"], *_RETAINED[victim["t"]]):
            conn.execute(f"DELETE FROM {part} WHERE id = ?", (victim["id"],))


def insert_capped(
    db: Database,
    quota: Quota,
    table: str,
    cap: int | None,
    insert: str,
    parameters: tuple[Any, ...],
    what: str | None = None,
) -> None:
    """`insert` into `table` of `db` (its last parameter: the row's size [bytes]) only while
    fewer than `cap` jobs of `table` (`what`, in the refusal; default the table's name) are
    queued or running and `quota` has room (`make_room`): count, room and insert in one write
    transaction, so concurrent submissions cannot pass a cap between the count and the insert.

    Raises:
        QueueFull: `cap` jobs are queued or running (nothing stored).
        StoreFull: no room can be made.
    """
    with db.writing() as conn:
        count = conn.execute(f"SELECT COUNT(*) FROM {table} WHERE {UNFINISHED}").fetchone()[0]
        if cap is not None and count >= cap:
            raise QueueFull(what or table, count, cap)
        make_room(conn, quota, table, parameters[-1])
        conn.execute(insert, parameters)


def _run(row: sqlite3.Row) -> Run:
    try:
        return _run_fields(row)
    except (ValueError, TypeError) as exc:  # json.JSONDecodeError and pydantic's are ValueErrors
        return Run(**_unreadable(row, exc), progress=0.0, scenario={})


def _run_fields(row: sqlite3.Row) -> Run:
    return Run(
        id=row["id"],
        created=_utc(row["created"]),
        finished=_utc(row["finished"]),
        status=row["status"],
        progress=row["progress"],
        scenario=json.loads(row["scenario"]),
        metrics=None if row["metrics"] is None else json.loads(row["metrics"]),
        error=row["error"],
    )


class RunStore:
    """Runs persisted in an SQLite file; safe to share between threads and processes.

    Args:
        path: the database file; created (with its folder) if missing.

    Raises:
        TwinError: the file was written by a newer schema.
    """

    def __init__(self, path: str | Path, quota: Quota | None = None) -> None:
        self.path = Path(path)
        self.quota = quota if quota is not None else Quota()
        self._db = Database(self.path, self._open, SYNCHRONOUS)

    def _open(self, conn: sqlite3.Connection) -> None:
        """Schema, the version check and the sizes of rows from before sizes were kept
        (sqlite3.DatabaseError: a bad file)."""
        migrate(conn, f"run store {self.path}", _SCHEMA, _ADDED, SCHEMA_VERSION)
        for table in _ADDED:
            conn.execute(
                f"UPDATE {table} SET size = {_ROW_BYTES[table]} + {ROW_OVERHEAD} WHERE size = 0"
            )
        # a damaged page shows here, at start-up, not as a 500 in the middle of a request
        problem = conn.execute("PRAGMA quick_check(1)").fetchone()[0]
        if problem != "ok":
            raise sqlite3.DatabaseError(f"integrity check: {problem}")

    @property
    def available(self) -> bool:
        """Whether the file opened is still the one at `path`."""
        return self._db.available

    # -- writers -----------------------------------------------------------------------------
    def _write(self, sql: str, parameters: tuple[Any, ...]) -> int:
        """One statement in one transaction; returns the number of rows changed."""
        return self._db.write((sql, parameters))

    def create(self, scenario: Scenario, max_pending: int | None = None) -> Run:
        """Store a new run of `scenario` as queued.

        Args:
            scenario: the run's scenario.
            max_pending: refuse if this many runs are already queued or running; checked in
                the same transaction as the insert, so concurrent submissions cannot pass it.

        Raises:
            QueueFull: `max_pending` runs are queued or running (nothing stored).
        """
        from twin.web.limits import price_run

        run_id = uuid.uuid4().hex
        text = scenario.model_dump_json()
        size = price_run(scenario).bytes + len(text) + ROW_OVERHEAD
        insert_capped(
            self._db, self.quota, "runs", max_pending,
            "INSERT INTO runs (id, created, status, scenario, size) VALUES (?, ?, 'queued', ?, ?)",
            (run_id, time.time(), text, size),
        )  # fmt: skip
        return self.get(run_id)

    def usage(self) -> tuple[int, int]:
        """([bytes] stored or reserved by runs and sweeps, runs stored)."""
        with self._db.lock:
            self._db.check()
            return usage(self._db.conn)

    def mark_running(self, run_id: str) -> bool:
        """A queued run starts (a run in any other status stays as it is); whether it did.

        Raises:
            RunNotFound: no run has this id.
        """
        return self._write_one(
            "runs", run_id,
            "UPDATE runs SET status = 'running', progress = 0, attempts = attempts + 1 "
            "WHERE id = ? AND status = 'queued'",
            (run_id,),
        )  # fmt: skip

    def _write_one(
        self, table: Literal["runs", "sweeps"], job_id: str, sql: str, parameters: tuple[Any, ...]
    ) -> bool:
        """A write to one run or sweep; whether it changed the row (none changed: RunNotFound /
        SweepNotFound if there is no such row, else it was in another status)."""
        changed = self._write(sql, parameters)
        if not changed:
            (self.get if table == "runs" else self.get_sweep)(job_id)
        return bool(changed)

    def set_progress(self, run_id: str, progress: float) -> None:
        """Progress of a running run, clipped to [0, 1]; it only grows, and only while the run
        is running (a late report of a finished or requeued run changes nothing)."""
        self._write(
            "UPDATE runs SET progress = MAX(progress, ?) WHERE id = ? AND status = 'running'",
            (min(max(float(progress), 0.0), 1.0), run_id),
        )

    def finish(self, run_id: str, result: SimulationResult) -> Run:
        """Store a finished run's metrics and series (status done).

        Raises:
            ValueError: metrics that are not finite JSON (nothing is written).
        """
        return self.finish_packed(run_id, result.metrics, pack_series(result.series))

    def finish_packed(self, run_id: str, metrics: dict[str, Any], series: bytes) -> Run:
        """`finish` with the series already packed (`pack_series`, as a worker sends them).

        Raises:
            ValueError: metrics that are not finite JSON (nothing is written).
        """
        text = json.dumps(metrics, allow_nan=False)
        self._changed(
            run_id,
            "UPDATE runs SET status = 'done', progress = 1, finished = ?, metrics = ?, "
            f"series = ?, error = NULL, size = LENGTH(scenario) + ? + {ROW_OVERHEAD} "
            "WHERE id = ? AND NOT " + WAS_CANCELLED,
            (time.time(), text, series, len(text) + len(series), run_id),
        )
        return self.get(run_id)

    def pin(self, table: Literal["runs", "sweeps"], job_id: str, pinned: bool = True) -> None:
        """Keep a run (or sweep) from retention (`Quota.retain`), or let it go again.

        Raises:
            RunNotFound: no run (SweepNotFound: no sweep) has this id.
        """
        if not self._write(f"UPDATE {table} SET pinned = ? WHERE id = ?", (int(pinned), job_id)):
            (self.get if table == "runs" else self.get_sweep)(job_id)

    def delete(self, run_id: str) -> bool:
        """Forget a run, its series with it; whether there was one."""
        return bool(self._write("DELETE FROM runs WHERE id = ?", (run_id,)))

    def cancel(self, run_id: str, reason: str = "by request") -> bool:
        """A queued or running run becomes failed, `error` "cancelled …"; whether it was one.

        Raises:
            RunNotFound: no run has this id.
        """
        return self._cancel("runs", run_id, reason)

    def _cancel(self, table: Literal["runs", "sweeps"], job_id: str, reason: str) -> bool:
        """`cancel` or `cancel_sweep`: the row's size shrinks to its scenario or spec."""
        own = "scenario" if table == "runs" else "spec"
        return self._write_one(
            table, job_id,
            cancel_sql(table, f"LENGTH({own}) + {ROW_OVERHEAD}"),
            (time.time(), f"{CANCELLED} {reason}", job_id),
        )  # fmt: skip

    def fail(self, run_id: str, error: str) -> None:
        self._changed(
            run_id,
            "UPDATE runs SET status = 'failed', finished = ?, error = ?, "
            f"size = LENGTH(scenario) + ? + {ROW_OVERHEAD} "
            "WHERE id = ? AND NOT " + WAS_CANCELLED,
            (time.time(), error, len(error.encode()), run_id),
        )

    def requeue_unfinished(self, max_attempts: int = MAX_ATTEMPTS) -> list[str]:
        """Runs a stopped server left queued or running, set back to queued, oldest first;
        those already started `max_attempts` times are failed instead, saying so."""
        return self._requeue("runs", "progress = 0", max_attempts)

    def _requeue(self, table: str, reset: str, max_attempts: int) -> list[str]:
        own = "scenario" if table == "runs" else "spec"
        return requeue(self._db, table, reset, max_attempts, f"LENGTH({own}) + {ROW_OVERHEAD}")

    def pending(self, table: Literal["runs", "sweeps"] = "runs") -> int:
        """How many runs (or sweeps) are queued or running."""
        return int(self._db.read(f"SELECT COUNT(*) FROM {table} WHERE {UNFINISHED}")[0][0])

    def _changed(self, run_id: str, sql: str, parameters: tuple[Any, ...]) -> None:
        """A write to one run: RunNotFound if there is none (a cancelled one stays as is)."""
        if self._write(sql, parameters) == 0:
            self.get(run_id)

    # -- readers -----------------------------------------------------------------------------
    def _row(self, run_id: str, columns: str) -> sqlite3.Row:
        rows = self._db.read(f"SELECT {columns} FROM runs WHERE id = ?", (run_id,))
        if not rows:
            raise RunNotFound(f"unknown run id {run_id!r}")
        return rows[0]

    def get(self, run_id: str) -> Run:
        """The run without its series.

        Raises:
            RunNotFound: no run has this id.
        """
        return _run(self._row(run_id, _COLUMNS))

    def list_runs(self, limit: int = 50) -> list[Run]:
        """The newest `limit` runs, newest first."""
        rows = self._db.read(
            f"SELECT {_COLUMNS} FROM runs ORDER BY created DESC, rowid DESC LIMIT ?", (limit,)
        )
        return [_run(row) for row in rows]

    def scenario(self, run_id: str) -> Scenario:
        """The run's scenario, validated again."""
        return Scenario.model_validate_json(self._row(run_id, "scenario")["scenario"])

    def result(self, run_id: str) -> SimulationResult:
        """A done run as the `SimulationResult` it was stored from (series bit-identical).

        Raises:
            RunNotFound: no run has this id.
            TwinError: the run is not done, so it has no series.
        """
        row = self._row(run_id, "status, scenario, metrics, series")
        if row["status"] != "done":
            raise TwinError(f"run {run_id} is {row['status']}; series exist once it is done")
        # Stored scenarios were validated when submitted; constructing without re-validation
        # keeps old runs readable if a later version tightens a range.
        scenario = Scenario.model_construct(**json.loads(row["scenario"]))
        return SimulationResult(scenario, unpack_series(row["series"]), json.loads(row["metrics"]))

    def series_blob(self, run_id: str) -> tuple[dict[str, Any], dict[str, Any], bytes]:
        """A done run's (scenario, metrics, packed series) without decoding the series (the
        streaming exports read them lazily, `twin.web.export.Series`).

        Raises:
            RunNotFound: no run has this id.
            TwinError: the run is not done.
        """
        row = self._row(run_id, "status, scenario, metrics, series")
        if row["status"] != "done":
            raise TwinError(f"run {run_id} is {row['status']}; series exist once it is done")
        return json.loads(row["scenario"]), json.loads(row["metrics"]), row["series"]

    # -- sweeps ------------------------------------------------------------------------------
    def create_sweep(
        self, spec: dict[str, Any], total: int, max_pending: int | None = None
    ) -> Sweep:
        """Store a new sweep of a validated `SweepSpec` (as a dict) of `total` runs, queued.

        Raises:
            QueueFull: `max_pending` sweeps are queued or running (checked atomically with the
                insert, as `create` does).
        """
        from twin.runs.sweep import SweepSpec
        from twin.web.limits import price_sweep

        sweep_id = uuid.uuid4().hex
        text = json.dumps(spec, allow_nan=False)
        size = price_sweep(SweepSpec.model_construct(**spec)).bytes + len(text) + ROW_OVERHEAD
        insert_capped(
            self._db, self.quota, "sweeps", max_pending,
            "INSERT INTO sweeps (id, created, status, total, spec, size) "
            "VALUES (?, ?, 'queued', ?, ?, ?)",
            (sweep_id, time.time(), total, text, size),
        )  # fmt: skip
        return self.get_sweep(sweep_id)

    def cancel_sweep(self, sweep_id: str, reason: str = "by request") -> bool:
        """A queued or running sweep becomes failed, `error` "cancelled …"; whether it was.

        Raises:
            SweepNotFound: no sweep has this id.
        """
        return self._cancel("sweeps", sweep_id, reason)

    def delete_sweep(self, sweep_id: str) -> bool:
        """Forget a sweep, its table and heatmap with it; whether there was one."""
        return bool(self._write("DELETE FROM sweeps WHERE id = ?", (sweep_id,)))

    def sweep_running(self, sweep_id: str) -> bool:
        """A queued sweep starts (one cancelled meanwhile stays as it is); whether it did.

        Raises:
            SweepNotFound: no sweep has this id.
        """
        return self._write_one(
            "sweeps", sweep_id,
            "UPDATE sweeps SET status = 'running', done = 0, attempts = attempts + 1 "
            "WHERE id = ? AND status IN ('queued', 'running')",
            (sweep_id,),
        )  # fmt: skip

    def sweep_progress(self, sweep_id: str, done: int) -> None:
        """Runs done of a running sweep; it only grows (a late report changes nothing)."""
        self._write(
            "UPDATE sweeps SET done = MAX(done, ?) WHERE id = ? AND status = 'running'",
            (done, sweep_id),
        )

    def finish_sweep(self, sweep_id: str, result: dict[str, Any], heatmap: bytes) -> Sweep:
        """Store a finished sweep's `SweepResult.to_dict()` and heatmap PNG (status done)."""
        text = json.dumps(result, allow_nan=False)
        self._sweep_changed(
            sweep_id,
            "UPDATE sweeps SET status = 'done', done = total, finished = ?, result = ?, "
            f"heatmap = ?, error = NULL, size = LENGTH(spec) + ? + {ROW_OVERHEAD} "
            "WHERE id = ? AND NOT " + WAS_CANCELLED,
            (time.time(), text, heatmap, len(text) + len(heatmap), sweep_id),
        )
        return self.get_sweep(sweep_id)

    def fail_sweep(self, sweep_id: str, error: str) -> None:
        self._sweep_changed(
            sweep_id,
            "UPDATE sweeps SET status = 'failed', finished = ?, error = ?, "
            f"size = LENGTH(spec) + {ROW_OVERHEAD} WHERE id = ? AND NOT " + WAS_CANCELLED,
            (time.time(), error, sweep_id),
        )

    def requeue_unfinished_sweeps(self, max_attempts: int = MAX_ATTEMPTS) -> list[str]:
        """Sweeps a stopped server left queued or running, set back to queued, oldest first;
        those already started `max_attempts` times are failed instead, saying so."""
        return self._requeue("sweeps", "done = 0", max_attempts)

    def get_sweep(self, sweep_id: str) -> Sweep:
        """The sweep without its heatmap.

        Raises:
            SweepNotFound: no sweep has this id.
        """
        return _sweep(self._sweep_row(sweep_id, _SWEEP_COLUMNS))

    def sweep_heatmap(self, sweep_id: str) -> bytes:
        """A done sweep's heatmap PNG.

        Raises:
            SweepNotFound: no sweep has this id.
            TwinError: the sweep is not done.
        """
        row = self._sweep_row(sweep_id, "status, heatmap")
        if row["status"] != "done":
            raise TwinError(f"sweep {sweep_id} is {row['status']}; its heatmap exists once done")
        return bytes(row["heatmap"])

    def _sweep_changed(self, sweep_id: str, sql: str, parameters: tuple[Any, ...]) -> None:
        """A write to one sweep: SweepNotFound if there is none (a cancelled one stays)."""
        if self._write(sql, parameters) == 0:
            self.get_sweep(sweep_id)

    def _sweep_row(self, sweep_id: str, columns: str) -> sqlite3.Row:
        rows = self._db.read(f"SELECT {columns} FROM sweeps WHERE id = ?", (sweep_id,))
        if not rows:
            raise SweepNotFound(f"unknown sweep id {sweep_id!r}")
        return rows[0]

    # -- lifetime ----------------------------------------------------------------------------
    def close(self) -> None:
        self._db.close()

    def __enter__(self) -> RunStore:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

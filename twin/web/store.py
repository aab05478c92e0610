"""The run store: every scripted run, its status, metrics and series, in one SQLite file.

One table of runs, one row per run, and one of operability sweeps (`sweeps`). SQLite in WAL
mode lets the web process read while a worker process writes; every change is one
transaction, so a process killed mid-write leaves the previous state and the file reopens
consistent. Series are a compressed npz blob (float64,
exact), written once when the run is done.

Status goes queued → running → done | failed; `progress` is the fraction of steps taken, and
only grows while a run is running (a late progress report never moves a done run back).

The store is written by the server process alone (workers send results back through the
executor), and one server holds a data directory at a time (`twin.web.lock`). It remembers
which file it opened: if that file is deleted or replaced while the server runs, every access
raises `StoreUnavailable` (a 503) instead of writing runs into a file nobody can open again.
"""

from __future__ import annotations

import json
import os
import sqlite3
import threading
import time
import uuid
from datetime import UTC, datetime
from pathlib import Path
from types import TracebackType
from typing import Any, Literal

from pydantic import BaseModel, Field

from twin.errors import TwinError
from twin.sim import Scenario, SimulationResult
from twin.sim.executor import pack_series, unpack_series

Status = Literal["queued", "running", "done", "failed"]

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
    series    BLOB
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
    heatmap   BLOB
);
"""
# The sweeps table came after schema 1 without changing what schema-1 readers see, so the
# version stays: IF NOT EXISTS adds it to an older file the first time this twin opens it.
# `series` is the last column so listing runs never reads a blob's overflow pages.
_COLUMNS = "id, created, finished, status, progress, scenario, metrics, error"
_SWEEP_COLUMNS = "id, created, finished, status, done, total, spec, result, error"


class RunNotFound(TwinError):
    """No run has this id."""


__all__ = [
    "Run",
    "RunNotFound",
    "RunStore",
    "StoreUnavailable",
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


def _run(row: sqlite3.Row) -> Run:
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


class StoreUnavailable(RuntimeError):
    """The store's file is gone or replaced, or SQLite cannot write it (a 503, not a 500)."""


class RunStore:
    """Runs persisted in an SQLite file; safe to share between threads and processes.

    Args:
        path: the database file; created (with its folder) if missing.

    Raises:
        TwinError: the file was written by a newer schema.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        # One connection guarded by a lock: FastAPI calls from its thread pool; autocommit
        # mode (isolation_level=None) so each `_write` is exactly one explicit transaction.
        self._conn = sqlite3.connect(
            self.path, timeout=10.0, isolation_level=None, check_same_thread=False
        )
        self._conn.row_factory = sqlite3.Row
        self._lock = threading.Lock()
        with self._lock:
            self._conn.execute("PRAGMA journal_mode = WAL")  # readers never block the writer
            self._conn.execute("PRAGMA synchronous = FULL")  # a committed run survives power loss
            version = self._conn.execute("PRAGMA user_version").fetchone()[0]
            if version > SCHEMA_VERSION:
                self._conn.close()
                raise TwinError(
                    f"{self.path}: run store schema {version} is newer than this twin's "
                    f"({SCHEMA_VERSION}); upgrade wave-twin or use another data directory"
                )
            self._conn.executescript(
                f"BEGIN IMMEDIATE; {_SCHEMA} PRAGMA user_version = {SCHEMA_VERSION}; COMMIT;"
            )
            self._identity = self._stat()

    def _stat(self) -> tuple[int, int] | None:
        try:
            info = os.stat(self.path)
        except OSError:
            return None
        return info.st_dev, info.st_ino

    def _check(self) -> None:
        """Raise `StoreUnavailable` if the file opened is no longer the one at `path`."""
        now = self._stat()
        if now != self._identity:
            what = "deleted" if now is None else "replaced by another file"
            raise StoreUnavailable(
                f"run store {self.path} was {what} while the server runs: nothing more is "
                "stored, so no run is written where nobody could read it back; restart the "
                "server (with the file restored, or to start a new store)"
            )

    @property
    def available(self) -> bool:
        """Whether the file opened is still the one at `path`."""
        return self._stat() == self._identity

    def _execute(self, sql: str, parameters: tuple[Any, ...] = ()) -> sqlite3.Cursor:
        """A read, under the lock, after the file check (SQLite errors are a 503)."""
        self._check()
        try:
            return self._conn.execute(sql, parameters)
        except sqlite3.OperationalError as exc:
            raise StoreUnavailable(f"run store {self.path}: {exc}") from exc

    # -- writers -----------------------------------------------------------------------------
    def _write(self, sql: str, parameters: tuple[Any, ...]) -> int:
        """One statement in one transaction; returns the number of rows changed."""
        with self._lock:
            self._check()
            try:
                self._conn.execute("BEGIN IMMEDIATE")
            except sqlite3.OperationalError as exc:
                raise StoreUnavailable(f"run store {self.path}: {exc}") from exc
            try:
                changed = self._conn.execute(sql, parameters).rowcount
            except BaseException as exc:
                self._conn.execute("ROLLBACK")
                if isinstance(exc, sqlite3.OperationalError):
                    raise StoreUnavailable(f"run store {self.path}: {exc}") from exc
                raise
            self._conn.execute("COMMIT")
            return changed

    def create(self, scenario: Scenario) -> Run:
        """Store a new run of `scenario` as queued."""
        run_id = uuid.uuid4().hex
        self._write(
            "INSERT INTO runs (id, created, status, scenario) VALUES (?, ?, 'queued', ?)",
            (run_id, time.time(), scenario.model_dump_json()),
        )
        return self.get(run_id)

    def mark_running(self, run_id: str) -> bool:
        """A queued run starts (a run in any other status stays as it is); whether it did.

        Raises:
            RunNotFound: no run has this id.
        """
        changed = self._write(
            "UPDATE runs SET status = 'running', progress = 0 WHERE id = ? AND status = 'queued'",
            (run_id,),
        )
        if not changed:
            self.get(run_id)  # RunNotFound for an unknown id
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
            "series = ?, error = NULL WHERE id = ?",
            (time.time(), text, series, run_id),
        )
        return self.get(run_id)

    def delete(self, run_id: str) -> None:
        """Forget a run (one refused before it ran: a refused request leaves nothing)."""
        self._write("DELETE FROM runs WHERE id = ?", (run_id,))

    def fail(self, run_id: str, error: str) -> None:
        self._changed(
            run_id,
            "UPDATE runs SET status = 'failed', finished = ?, error = ? WHERE id = ?",
            (time.time(), error, run_id),
        )

    def requeue_unfinished(self) -> list[str]:
        """Runs a stopped server left queued or running, set back to queued, oldest first."""
        with self._lock:
            self._check()
            self._conn.execute("BEGIN IMMEDIATE")
            rows = self._conn.execute(
                "SELECT id FROM runs WHERE status IN ('queued', 'running') ORDER BY created, rowid"
            ).fetchall()
            self._conn.execute(
                "UPDATE runs SET status = 'queued', progress = 0 WHERE status = 'running'"
            )
            self._conn.execute("COMMIT")
        return [row["id"] for row in rows]

    def pending(self, table: Literal["runs", "sweeps"] = "runs") -> int:
        """How many runs (or sweeps) are queued or running."""
        with self._lock:
            return self._execute(
                f"SELECT COUNT(*) FROM {table} WHERE status IN ('queued', 'running')"
            ).fetchone()[0]

    def _changed(self, run_id: str, sql: str, parameters: tuple[Any, ...]) -> None:
        if self._write(sql, parameters) == 0:
            raise RunNotFound(f"unknown run id {run_id!r}")

    # -- readers -----------------------------------------------------------------------------
    def _row(self, run_id: str, columns: str) -> sqlite3.Row:
        with self._lock:
            row = self._execute(f"SELECT {columns} FROM runs WHERE id = ?", (run_id,)).fetchone()
        if row is None:
            raise RunNotFound(f"unknown run id {run_id!r}")
        return row

    def get(self, run_id: str) -> Run:
        """The run without its series.

        Raises:
            RunNotFound: no run has this id.
        """
        return _run(self._row(run_id, _COLUMNS))

    def list_runs(self, limit: int = 50) -> list[Run]:
        """The newest `limit` runs, newest first."""
        with self._lock:
            rows = self._execute(
                f"SELECT {_COLUMNS} FROM runs ORDER BY created DESC, rowid DESC LIMIT ?",
                (limit,),
            ).fetchall()
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

    # -- sweeps ------------------------------------------------------------------------------
    def create_sweep(self, spec: dict[str, Any], total: int) -> Sweep:
        """Store a new sweep of a validated `SweepSpec` (as a dict) of `total` runs, queued."""
        sweep_id = uuid.uuid4().hex
        self._write(
            "INSERT INTO sweeps (id, created, status, total, spec) VALUES (?, ?, 'queued', ?, ?)",
            (sweep_id, time.time(), total, json.dumps(spec, allow_nan=False)),
        )
        return self.get_sweep(sweep_id)

    def sweep_running(self, sweep_id: str) -> None:
        self._sweep_changed(
            sweep_id, "UPDATE sweeps SET status = 'running', done = 0 WHERE id = ?", (sweep_id,)
        )

    def sweep_progress(self, sweep_id: str, done: int) -> None:
        """Runs done of a running sweep; it only grows (a late report changes nothing)."""
        self._write(
            "UPDATE sweeps SET done = MAX(done, ?) WHERE id = ? AND status = 'running'",
            (done, sweep_id),
        )

    def finish_sweep(self, sweep_id: str, result: dict[str, Any], heatmap: bytes) -> Sweep:
        """Store a finished sweep's `SweepResult.to_dict()` and heatmap PNG (status done)."""
        self._sweep_changed(
            sweep_id,
            "UPDATE sweeps SET status = 'done', done = total, finished = ?, result = ?, "
            "heatmap = ?, error = NULL WHERE id = ?",
            (time.time(), json.dumps(result, allow_nan=False), heatmap, sweep_id),
        )
        return self.get_sweep(sweep_id)

    def fail_sweep(self, sweep_id: str, error: str) -> None:
        self._sweep_changed(
            sweep_id,
            "UPDATE sweeps SET status = 'failed', finished = ?, error = ? WHERE id = ?",
            (time.time(), error, sweep_id),
        )

    def requeue_unfinished_sweeps(self) -> list[str]:
        """Sweeps a stopped server left queued or running, set back to queued, oldest first."""
        with self._lock:
            self._check()
            self._conn.execute("BEGIN IMMEDIATE")
            rows = self._conn.execute(
                "SELECT id FROM sweeps WHERE status IN ('queued', 'running') "
                "ORDER BY created, rowid"
            ).fetchall()
            self._conn.execute(
                "UPDATE sweeps SET status = 'queued', done = 0 WHERE status = 'running'"
            )
            self._conn.execute("COMMIT")
        return [row["id"] for row in rows]

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
        if self._write(sql, parameters) == 0:
            raise SweepNotFound(f"unknown sweep id {sweep_id!r}")

    def _sweep_row(self, sweep_id: str, columns: str) -> sqlite3.Row:
        with self._lock:
            row = self._execute(
                f"SELECT {columns} FROM sweeps WHERE id = ?", (sweep_id,)
            ).fetchone()
        if row is None:
            raise SweepNotFound(f"unknown sweep id {sweep_id!r}")
        return row

    # -- lifetime ----------------------------------------------------------------------------
    def close(self) -> None:
        with self._lock:
            self._conn.close()

    def __enter__(self) -> RunStore:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

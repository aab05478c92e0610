"""Workability jobs of the REST API in the run store's SQLite file (a table of their own).

`WorkabilityStore` is a second, small class over the same database file as `RunStore` (SQLite
in WAL mode lets both connections share it; every change is one transaction, as there). It adds
two tables when it opens the file (`CREATE TABLE IF NOT EXISTS`, so an older store keeps what it
has and `RunStore`'s schema version is untouched):

- `workability`: one row per job: status queued → running → done | failed, runs `done` of
  `total` (the total is the upper bound priced at submission until the evaluation's cache
  lookup says how many it needs), the request (`spec`: the `WorkabilitySpec` fields; `record`:
  `{"name": …}` for a shipped record or `{"csv": …, "kind": …}` for an uploaded one), the
  result (`WorkabilityResult.to_dict()`), the error, and how many times it was started;
- `workability_plots`: its PNG plots by file name (`monthly.png`, `windows.png`, …).

A cancelled job's late result is not stored over it (as sweeps). Jobs left unfinished by a
stopped server are queued again at the next start, up to `store.MAX_ATTEMPTS` starts.

Not counted by `RunStore`'s quota (`--max-store`): a job stores its summary (a few kB) and
2-4 PNGs (~100 kB); the records uploaded are capped by the request body's size.
"""

from __future__ import annotations

import json
import sqlite3
import threading
import time
import uuid
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from pydantic import BaseModel, Field

from twin.errors import TwinError
from twin.web.store import (
    CANCELLED,
    MAX_ATTEMPTS,
    QueueFull,
    RunNotFound,
    Status,
    StoreUnavailable,
    cancel_sql,
    connect,
    requeue,
    transaction,
)

_SCHEMA = """
CREATE TABLE IF NOT EXISTS workability (
    id        TEXT PRIMARY KEY,
    created   REAL NOT NULL,
    finished  REAL,
    status    TEXT NOT NULL CHECK (status IN ('queued', 'running', 'done', 'failed')),
    done      INTEGER NOT NULL DEFAULT 0,
    total     INTEGER NOT NULL,
    spec      TEXT NOT NULL,
    record    TEXT NOT NULL,
    result    TEXT,
    error     TEXT,
    attempts  INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE IF NOT EXISTS workability_plots (
    id        TEXT NOT NULL,
    name      TEXT NOT NULL,
    png       BLOB NOT NULL,
    PRIMARY KEY (id, name)
);
"""
_COLUMNS = "id, created, finished, status, done, total, spec, record, result, error"
_WAS_CANCELLED = f"(status = 'failed' AND error LIKE '{CANCELLED}%')"


def _utc(t: float | None) -> datetime | None:
    return None if t is None else datetime.fromtimestamp(t, UTC)


class WorkabilityNotFound(RunNotFound):
    """No workability job has this id (a `RunNotFound`: the API answers 404)."""


class Workability(BaseModel):
    """A stored workability job without its plots (`WorkabilityStore.plot` has those)."""

    id: str = Field(description="job id (32 hex digits)")
    created: datetime = Field(description="when it was submitted (UTC)")
    finished: datetime | None = Field(None, description="when it finished (UTC)")
    status: Status = Field(description="queued → running → done | failed")
    done: int = Field(description="runs evaluated (cached ones count as done)")
    total: int = Field(description="runs in all (the priced upper bound until it starts)")
    progress: float = Field(description="[-] done / total, 0-1")
    spec: dict[str, Any] = Field(description="the validated WorkabilitySpec, every field")
    record: dict[str, Any] = Field(
        description="the record: {name} of a shipped one, or {kind, bytes} of an uploaded one"
    )
    result: dict[str, Any] | None = Field(
        None, description="once done: WorkabilityResult.to_dict() (summary, windows, notes)"
    )
    plots: list[str] = Field(default_factory=list, description="PNG plots, once done")
    error: str | None = Field(None, description="why it failed")


class WorkabilityStore:
    """Workability jobs in the SQLite file of a `RunStore` (its `path`).

    Args:
        path: the database file (the run store's); created with its folder if missing.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        # as RunStore: one connection under a lock, autocommit, one transaction per write
        self._conn = connect(self.path)
        self._lock = threading.Lock()
        try:
            with self._lock:
                self._conn.execute("PRAGMA journal_mode = WAL")
                self._conn.execute("PRAGMA synchronous = FULL")
                self._conn.executescript(f"BEGIN IMMEDIATE; {_SCHEMA} COMMIT;")
        except sqlite3.DatabaseError as exc:
            self._conn.close()
            raise TwinError(f"run store {self.path} cannot be read ({exc})") from None

    # -- plumbing ----------------------------------------------------------------------------
    def _write(self, *statements: tuple[str, tuple[Any, ...]]) -> int:
        """Statements in one transaction; the rows the first one changed."""
        with self._lock:
            if not self.path.exists():
                raise StoreUnavailable(f"run store {self.path} was deleted while the server runs")
            with transaction(self._conn, self.path):
                changed = self._conn.execute(*statements[0]).rowcount
                for sql, parameters in statements[1:]:
                    self._conn.execute(sql, parameters)
            return changed

    def _read(self, sql: str, parameters: tuple[Any, ...] = ()) -> list[sqlite3.Row]:
        with self._lock:
            try:
                return self._conn.execute(sql, parameters).fetchall()
            except sqlite3.OperationalError as exc:
                raise StoreUnavailable(f"run store {self.path}: {exc}") from exc

    # -- writers -----------------------------------------------------------------------------
    def create(
        self,
        spec: dict[str, Any],
        record: dict[str, Any],
        total: int,
        max_pending: int | None = None,
    ) -> Workability:
        """Store a new job (queued) of a validated spec (a dict) on `record`.

        Raises:
            QueueFull: `max_pending` jobs are queued or running (counted in the insert's
                transaction, so concurrent submissions cannot pass it).
        """
        job_id = uuid.uuid4().hex
        with self._lock:
            self._conn.execute("BEGIN IMMEDIATE")
            try:
                count = self._conn.execute(
                    "SELECT COUNT(*) FROM workability WHERE status IN ('queued', 'running')"
                ).fetchone()[0]
                if max_pending is not None and count >= max_pending:
                    raise QueueFull("workability jobs", count, max_pending)
                self._conn.execute(
                    "INSERT INTO workability (id, created, status, total, spec, record) "
                    "VALUES (?, ?, 'queued', ?, ?, ?)",
                    (job_id, time.time(), total, json.dumps(spec, allow_nan=False),
                     json.dumps(record)),
                )  # fmt: skip
            except BaseException:
                self._conn.execute("ROLLBACK")
                raise
            self._conn.execute("COMMIT")
        return self.get(job_id)

    def running(self, job_id: str) -> bool:
        """A queued job starts (a cancelled one stays as it is); whether it did."""
        changed = self._write((
            "UPDATE workability SET status = 'running', done = 0, attempts = attempts + 1 "
            "WHERE id = ? AND status IN ('queued', 'running')", (job_id,),
        ))  # fmt: skip
        if not changed:
            self.get(job_id)
        return bool(changed)

    def progress(self, job_id: str, done: int, total: int) -> None:
        """Runs done of those a running job needs (`total` as the evaluation counts them)."""
        self._write((
            "UPDATE workability SET done = MAX(done, ?), total = ? "
            "WHERE id = ? AND status = 'running'", (done, max(total, 1), job_id),
        ))  # fmt: skip

    def finish(self, job_id: str, result: dict[str, Any], plots: dict[str, bytes]) -> None:
        """Store a finished job's result and PNG plots (status done), unless it was cancelled."""
        text = json.dumps(result, allow_nan=False)
        self._write(
            ("UPDATE workability SET status = 'done', done = total, finished = ?, result = ?, "
             "error = NULL WHERE id = ? AND NOT " + _WAS_CANCELLED,
             (time.time(), text, job_id)),
            ("DELETE FROM workability_plots WHERE id = ?", (job_id,)),
            *[("INSERT INTO workability_plots (id, name, png) SELECT ?, ?, ? WHERE EXISTS "
               "(SELECT 1 FROM workability WHERE id = ? AND status = 'done')",
               (job_id, name, png, job_id)) for name, png in plots.items()],
        )  # fmt: skip

    def fail(self, job_id: str, error: str) -> None:
        self._write((
            "UPDATE workability SET status = 'failed', finished = ?, error = ? "
            "WHERE id = ? AND NOT " + _WAS_CANCELLED, (time.time(), error, job_id),
        ))  # fmt: skip

    def cancel(self, job_id: str, reason: str = "by request") -> bool:
        """A queued or running job becomes failed, `error` "cancelled …"; whether it was.

        Raises:
            WorkabilityNotFound: no job has this id.
        """
        changed = self._write(
            (cancel_sql("workability"), (time.time(), f"{CANCELLED} {reason}", job_id))
        )
        if not changed:
            self.get(job_id)
        return bool(changed)

    def delete(self, job_id: str) -> bool:
        """Forget a job with its plots; whether there was one."""
        return bool(self._write(
            ("DELETE FROM workability WHERE id = ?", (job_id,)),
            ("DELETE FROM workability_plots WHERE id = ?", (job_id,)),
        ))  # fmt: skip

    def requeue_unfinished(self, max_attempts: int = MAX_ATTEMPTS) -> list[str]:
        """Jobs a stopped server left queued or running, queued again, oldest first; those
        started `max_attempts` times already are failed instead, saying so."""
        with self._lock:
            return requeue(self._conn, "workability", "done = 0", max_attempts)

    # -- readers -----------------------------------------------------------------------------
    def pending(self) -> int:
        """Jobs queued or running."""
        rows = self._read("SELECT COUNT(*) FROM workability WHERE status IN ('queued', 'running')")
        return int(rows[0][0])

    def _row(self, job_id: str, columns: str) -> sqlite3.Row:
        rows = self._read(f"SELECT {columns} FROM workability WHERE id = ?", (job_id,))
        if not rows:
            raise WorkabilityNotFound(f"unknown workability id {job_id!r}")
        return rows[0]

    def get(self, job_id: str) -> Workability:
        """The job without its plots' bytes.

        Raises:
            WorkabilityNotFound: no job has this id.
        """
        row = self._row(job_id, _COLUMNS)
        names = [r["name"] for r in self._read(
            "SELECT name FROM workability_plots WHERE id = ? ORDER BY name", (job_id,)
        )]  # fmt: skip
        record = json.loads(row["record"])
        if "csv" in record:  # the upload itself is not echoed back: its size says which
            record = {"kind": record.get("kind"), "bytes": len(record["csv"].encode())}
        return Workability(
            id=row["id"], created=_utc(row["created"]), finished=_utc(row["finished"]),
            status=row["status"], done=row["done"], total=row["total"],
            progress=min(row["done"] / row["total"], 1.0) if row["total"] else 0.0,
            spec=json.loads(row["spec"]), record=record,
            result=None if row["result"] is None else json.loads(row["result"]),
            plots=names, error=row["error"],
        )  # fmt: skip

    def request(self, job_id: str) -> tuple[dict[str, Any], dict[str, Any]]:
        """(spec fields, record source) of a job, as submitted."""
        row = self._row(job_id, "spec, record")
        return json.loads(row["spec"]), json.loads(row["record"])

    def plot(self, job_id: str, name: str) -> bytes:
        """A done job's PNG plot `name` (e.g. "monthly.png").

        Raises:
            WorkabilityNotFound: no job has this id.
            TwinError: the job is not done, or has no such plot (naming those it has).
        """
        job = self.get(job_id)
        if job.status != "done":
            raise TwinError(f"workability {job_id} is {job.status}; its plots exist once done")
        rows = self._read(
            "SELECT png FROM workability_plots WHERE id = ? AND name = ?", (job_id, name)
        )
        if not rows:
            raise TwinError(f"workability {job_id} has no plot {name!r}; it has {job.plots}")
        return bytes(rows[0]["png"])

    def close(self) -> None:
        with self._lock:
            self._conn.close()

"""Workability jobs of the REST API in the run store's SQLite file (a table of their own).

`WorkabilityStore` is a second, small class over the same database file as `RunStore` (SQLite
in WAL mode lets both connections share it; every change is one transaction, as there). It adds
two tables when it opens the file (`CREATE TABLE IF NOT EXISTS`, so an older store keeps what it
has and `RunStore`'s schema version is untouched):

- `workability`: one row per job: status queued → running → done | failed, runs `done` of
  `total` (the total is the upper bound priced at submission until the evaluation's cache
  lookup says how many it needs), the request (`spec`: the `WorkabilitySpec` fields; `record`:
  `{"name": …}` for a shipped record or `{"upload": file name, "kind": …, "bytes": …}` for an
  uploaded one), the record's columns as read at submission (`upload`:
  `twin.web.upload_records.pack_record`, kept only while the job is queued or running), the
  result (`WorkabilityResult.to_dict()`), the error, how many times it was started, and its
  `size` [bytes];
- `workability_plots`: its files by name: the PNG plots (`monthly.png`, `windows.png`, …) and
  the per-row table (`rows.csv.gz`).

A cancelled job's late result is not stored over it (as sweeps). Jobs left unfinished by a
stopped server are queued again at the next start, up to `twin.db.MAX_ATTEMPTS` starts; the
attempt is counted when the runner picks a job up, before anything of it is read.

Counted by the store's quota (issue 43: 80 submit-and-cancel cycles took a 300 MB store to
453 MB): every job's `size` counts against `--max-store` and each job as a run against
`--max-runs` (`twin.web.store.make_room`, with `--retain` deleting the oldest finished ones).
A job ends (done, failed or cancelled) without its upload.
"""

from __future__ import annotations

import json
import sqlite3
import time
import uuid
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

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
from twin.web.store import ROW_OVERHEAD, Quota, RunNotFound, Status, insert_capped

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
    attempts  INTEGER NOT NULL DEFAULT 0,
    size      INTEGER NOT NULL DEFAULT 0,
    upload    BLOB
);
CREATE TABLE IF NOT EXISTS workability_plots (
    id        TEXT NOT NULL,
    name      TEXT NOT NULL,
    png       BLOB NOT NULL,
    PRIMARY KEY (id, name)
);
"""
_COLUMNS = "id, created, finished, status, done, total, spec, record, result, error"
#: columns added after the table's first version: added to an older file when it is opened
_ADDED = {"workability": {"size": "INTEGER NOT NULL DEFAULT 0", "upload": "BLOB"}}
#: [bytes] what a job holds once its upload is gone: its fields, its result and its files
#: (SQLite computes a SET from the row as it was, so this is the size of a row whose upload the
#: same UPDATE drops)
_SIZE = (
    "LENGTH(spec) + LENGTH(record) + COALESCE(LENGTH(result), 0)"
    " + (SELECT COALESCE(SUM(LENGTH(png)), 0) FROM workability_plots p"
    f" WHERE p.id = workability.id) + {ROW_OVERHEAD}"
)
#: a finished job lets its upload go (it is read again only by a job that runs)
_DROP_UPLOAD = (
    f"UPDATE workability SET upload = NULL, size = {_SIZE} "
    "WHERE id = ? AND status IN ('done', 'failed')"
)
#: the per-row table's name among a job's files
ROWS_FILE = "rows.csv.gz"


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
        description="the record: {name} of a shipped one, or {upload, kind, bytes} of an "
        "uploaded one (its file name, format and size)"
    )
    result: dict[str, Any] | None = Field(
        None, description="once done: WorkabilityResult.to_dict() (summary, windows, notes)"
    )
    plots: list[str] = Field(default_factory=list, description="PNG plots, once done")
    rows: bool = Field(False, description="whether the per-row CSV is there (GET …/rows.csv)")
    error: str | None = Field(None, description="why it failed")


class WorkabilityStore:
    """Workability jobs in the SQLite file of a `RunStore` (its `path`).

    Args:
        path: the database file (the run store's); created with its folder if missing.
        quota: the store's quota (the `RunStore`'s on the same file); None: none.
    """

    def __init__(self, path: str | Path, quota: Quota | None = None) -> None:
        self.path = Path(path)
        self.quota = quota if quota is not None else Quota()
        # as RunStore's: one connection under a lock, one transaction per write
        self._db = Database(
            self.path, lambda conn: migrate(conn, f"run store {self.path}", _SCHEMA, _ADDED), "FULL"
        )

    # -- writers -----------------------------------------------------------------------------
    def create(
        self,
        spec: dict[str, Any],
        record: dict[str, Any],
        total: int,
        upload: bytes | None = None,
        max_pending: int | None = None,
        reserve: int = 0,
    ) -> Workability:
        """Store a new job (queued) of a validated spec (a dict) on `record`, with the
        record's columns as read (`upload`, `pack_record`'s bytes) if it has them, else
        `reserve` bytes of the quota held for them until `attach` brings them.

        Raises:
            QueueFull: `max_pending` jobs are queued or running (counted in the insert's
                transaction, so concurrent submissions cannot pass it).
            StoreFull: the job's size is over the quota and no room can be made.
        """
        job_id = uuid.uuid4().hex
        spec_text, record_text = json.dumps(spec, allow_nan=False), json.dumps(record)
        size = len(spec_text) + len(record_text) + len(upload or b"") + reserve + ROW_OVERHEAD
        insert_capped(
            self._db, self.quota, "workability", max_pending,
            "INSERT INTO workability (id, created, status, total, spec, record, upload, size) "
            "VALUES (?, ?, 'queued', ?, ?, ?, ?, ?)",
            (job_id, time.time(), total, spec_text, record_text, upload, size),
            "workability jobs",
        )  # fmt: skip
        return self.get(job_id)

    def attach(self, job_id: str, upload: bytes, total: int) -> bool:
        """A queued job's record columns, read after it was stored (`create`'s `reserve`), and
        its runs priced on them; whether it was still queued."""
        return bool(self._db.write((
            f"UPDATE workability SET upload = ?, total = ?, size = {_SIZE} + ? "
            "WHERE id = ? AND status = 'queued'", (upload, total, len(upload), job_id),
        )))  # fmt: skip

    def running(self, job_id: str) -> bool:
        """A queued job starts (a cancelled one stays as it is); whether it did."""
        changed = self._db.write((
            "UPDATE workability SET status = 'running', done = 0, attempts = attempts + 1 "
            "WHERE id = ? AND status IN ('queued', 'running')", (job_id,),
        ))  # fmt: skip
        if not changed:
            self.get(job_id)
        return bool(changed)

    def progress(self, job_id: str, done: int, total: int) -> None:
        """Runs done of those a running job needs (`total` as the evaluation counts them)."""
        self._db.write((
            "UPDATE workability SET done = MAX(done, ?), total = ? "
            "WHERE id = ? AND status = 'running'", (done, max(total, 1), job_id),
        ))  # fmt: skip

    def finish(self, job_id: str, result: dict[str, Any], plots: dict[str, bytes]) -> None:
        """Store a finished job's result and files (status done: the PNG plots, `ROWS_FILE`),
        unless it was cancelled; its upload goes."""
        text = json.dumps(result, allow_nan=False)
        self._db.write(
            ("UPDATE workability SET status = 'done', done = total, finished = ?, result = ?, "
             "error = NULL WHERE id = ? AND NOT " + WAS_CANCELLED,
             (time.time(), text, job_id)),
            ("DELETE FROM workability_plots WHERE id = ?", (job_id,)),
            *[("INSERT INTO workability_plots (id, name, png) SELECT ?, ?, ? WHERE EXISTS "
               "(SELECT 1 FROM workability WHERE id = ? AND status = 'done')",
               (job_id, name, png, job_id)) for name, png in plots.items()],
            (_DROP_UPLOAD, (job_id,)),
        )  # fmt: skip

    def fail(self, job_id: str, error: str) -> None:
        """A job failed with `error` (unless it was cancelled); its upload goes."""
        self._db.write((
            "UPDATE workability SET status = 'failed', finished = ?, error = ? "
            "WHERE id = ? AND NOT " + WAS_CANCELLED, (time.time(), error, job_id),
        ), (_DROP_UPLOAD, (job_id,)))  # fmt: skip

    def cancel(self, job_id: str, reason: str = "by request") -> bool:
        """A queued or running job becomes failed, `error` "cancelled …", and its upload goes;
        whether it was.

        Raises:
            WorkabilityNotFound: no job has this id.
        """
        changed = self._db.write(
            (cancel_sql("workability"), (time.time(), f"{CANCELLED} {reason}", job_id)),
            (_DROP_UPLOAD, (job_id,)),
        )
        if not changed:
            self.get(job_id)
        return bool(changed)

    def delete(self, job_id: str) -> bool:
        """Forget a job with its plots; whether there was one."""
        return bool(self._db.write(
            ("DELETE FROM workability WHERE id = ?", (job_id,)),
            ("DELETE FROM workability_plots WHERE id = ?", (job_id,)),
        ))  # fmt: skip

    def requeue_unfinished(self, max_attempts: int = MAX_ATTEMPTS) -> list[str]:
        """Jobs a stopped server left queued or running, queued again, oldest first; those
        started `max_attempts` times already are failed instead, saying so."""
        ids = requeue(self._db, "workability", "done = 0", max_attempts)
        self._db.write((  # those failed let their uploads go
            f"UPDATE workability SET upload = NULL, size = {_SIZE} "
            "WHERE status = 'failed' AND upload IS NOT NULL", (),
        ))  # fmt: skip
        return ids

    # -- readers -----------------------------------------------------------------------------
    def pending(self) -> int:
        """Jobs queued or running."""
        rows = self._db.read(f"SELECT COUNT(*) FROM workability WHERE {UNFINISHED}")
        return int(rows[0][0])

    def _row(self, job_id: str, columns: str) -> sqlite3.Row:
        rows = self._db.read(f"SELECT {columns} FROM workability WHERE id = ?", (job_id,))
        if not rows:
            raise WorkabilityNotFound(f"unknown workability id {job_id!r}")
        return rows[0]

    def get(self, job_id: str) -> Workability:
        """The job without its plots' bytes.

        Raises:
            WorkabilityNotFound: no job has this id.
        """
        row = self._row(job_id, _COLUMNS)
        names = [r["name"] for r in self._db.read(
            "SELECT name FROM workability_plots WHERE id = ? ORDER BY name", (job_id,)
        )]  # fmt: skip
        record = json.loads(row["record"])
        if "csv" in record:  # a job stored before issue 43: the text is not echoed back
            record = {"kind": record.get("kind"), "bytes": len(record["csv"].encode())}
        return Workability(
            id=row["id"], created=_utc(row["created"]), finished=_utc(row["finished"]),
            status=row["status"], done=row["done"], total=row["total"],
            progress=min(row["done"] / row["total"], 1.0) if row["total"] else 0.0,
            spec=json.loads(row["spec"]), record=record,
            result=None if row["result"] is None else json.loads(row["result"]),
            plots=[n for n in names if n.endswith(".png")], rows=ROWS_FILE in names,
            error=row["error"],
        )  # fmt: skip

    def request(self, job_id: str) -> tuple[dict[str, Any], dict[str, Any], bytes | None]:
        """(spec fields, record source, the record's packed columns or None) of a job, as
        submitted."""
        row = self._row(job_id, "spec, record, upload")
        upload = None if row["upload"] is None else bytes(row["upload"])
        return json.loads(row["spec"]), json.loads(row["record"]), upload

    def plot(self, job_id: str, name: str) -> bytes:
        """A done job's file `name`: a PNG plot ("monthly.png", …) or `ROWS_FILE`.

        Raises:
            WorkabilityNotFound: no job has this id.
            TwinError: the job is not done, or has no such file (naming its plots).
        """
        job = self.get(job_id)
        if job.status != "done":
            raise TwinError(f"workability {job_id} is {job.status}; its plots exist once done")
        rows = self._db.read(
            "SELECT png FROM workability_plots WHERE id = ? AND name = ?", (job_id, name)
        )
        if not rows:
            raise TwinError(f"workability {job_id} has no plot {name!r}; it has {job.plots}")
        return bytes(rows[0]["png"])

    def close(self) -> None:
        self._db.close()

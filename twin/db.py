"""SQLite for the twin's three stores: the run store (`twin.web.store`), the workability jobs in
the same file (`twin.web.workability_store`) and the cell cache
(`twin.runs.workability.CellCache`).

Stated once here: how a file is opened (its folder made, WAL so readers never block the
writer, a busy timeout, autocommit so that each write is exactly one explicit transaction),
that a connection is closed when its user is done (`with sqlite3.connect(...)` only commits, it
does not close), one write transaction, tables and columns added to an older file, and what the
two job stores share: a cancelled job's mark, and jobs a stopped server left unfinished queued
again (`requeue`).

It sits below every layer (it imports only `twin.errors`), so both `sim` and `web` use it.
"""

from __future__ import annotations

import os
import sqlite3
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from twin.errors import TwinError

#: times a job may be started (then interrupted by a stop or a crash) before the next start
#: fails it instead of queueing it again: a job that ties a server up must not do so forever
MAX_ATTEMPTS = 3
#: what a cancelled job's `error` starts with
CANCELLED = "cancelled"
#: SQL: the row is a cancelled job (its outcome, arriving later, is not stored over it)
WAS_CANCELLED = f"(status = 'failed' AND error LIKE '{CANCELLED}%')"
#: SQL: the row is a job not finished yet
UNFINISHED = "status IN ('queued', 'running')"


class StoreUnavailable(RuntimeError):
    """The store's file is gone or replaced, or SQLite cannot write it (a 503, not a 500)."""


def connect(path: Path, synchronous: str = "NORMAL", timeout: float = 10.0) -> sqlite3.Connection:
    """A connection to the file `path` (its folder made if missing) in WAL mode with
    `synchronous` ("NORMAL" or "FULL") and a busy timeout of `timeout` [s], rows as
    `sqlite3.Row`, usable from any thread (its user serialises access), in autocommit mode
    (isolation_level=None) so each write is one explicit transaction (`transaction`).

    Raises:
        sqlite3.DatabaseError: the file is not a database (the connection is closed).
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    conn = sqlite3.connect(path, timeout=timeout, isolation_level=None, check_same_thread=False)
    try:
        conn.execute("PRAGMA journal_mode = WAL")
        conn.execute(f"PRAGMA synchronous = {synchronous}")
    except BaseException:
        conn.close()
        raise
    conn.row_factory = sqlite3.Row
    return conn


@contextmanager
def transaction(
    conn: sqlite3.Connection, name: str, write: bool = True
) -> Iterator[sqlite3.Connection]:
    """One transaction on `conn` (its user holds any lock): BEGIN IMMEDIATE (a write: it takes
    the file's write lock at once; `write` False: BEGIN, a read that never waits for writers),
    COMMIT at the end, ROLLBACK on any error. SQLite's operational errors (locked, disk full,
    file gone) become `StoreUnavailable` (a 503), naming the store (`name`, e.g. "run store
    <path>")."""
    try:
        conn.execute("BEGIN IMMEDIATE" if write else "BEGIN")
    except sqlite3.OperationalError as exc:
        raise StoreUnavailable(f"{name}: {exc}") from exc
    try:
        yield conn
    except BaseException as exc:
        conn.execute("ROLLBACK")
        if isinstance(exc, sqlite3.OperationalError):
            raise StoreUnavailable(f"{name}: {exc}") from exc
        raise
    conn.execute("COMMIT")


@contextmanager
def session(
    path: Path, write: bool = True, timeout: float = 30.0
) -> Iterator[sqlite3.Connection]:
    """A connection of its own for one transaction on the file `path` (`write`: as in
    `transaction`), for a store opened by many processes at once (the cell cache by a sweep's
    workers); committed and closed at the end, rolled back and closed on any error."""
    conn = connect(path, timeout=timeout)
    try:
        with transaction(conn, f"{path}", write):
            yield conn
    finally:
        conn.close()


def migrate(
    conn: sqlite3.Connection,
    name: str,
    schema: str,
    added: dict[str, dict[str, str]] | None = None,
    version: int | None = None,
) -> None:
    """The tables of `schema` (`CREATE TABLE IF NOT EXISTS …`) made, the columns a table gained
    after its first version (`added`: table → column → type and default) added to an older
    file's, and the file's `user_version` set to `version` (None: left as it is).

    Raises:
        TwinError: the file's version is newer than `version` (it is not written).
    """
    if version is not None:
        found = conn.execute("PRAGMA user_version").fetchone()[0]
        if found > version:
            raise TwinError(
                f"{name}: schema {found} is newer than this twin's ({version}); upgrade "
                "wave-twin or use another data directory"
            )
    stamp = "" if version is None else f"PRAGMA user_version = {version};"
    conn.executescript(f"BEGIN IMMEDIATE; {schema} {stamp} COMMIT;")
    for table, columns in (added or {}).items():
        have = {row[1] for row in conn.execute(f"PRAGMA table_info({table})")}
        for column, kind in columns.items():
            if column not in have:
                conn.execute(f"ALTER TABLE {table} ADD COLUMN {column} {kind}")


class Database:
    """One SQLite file a server process holds open: one connection guarded by a lock (FastAPI
    calls from its thread pool), each write one transaction. It remembers which file it opened:
    if that file is deleted or replaced while it runs, every access raises `StoreUnavailable`
    instead of writing into a file nobody can open again.

    Args:
        path: the database file; created (with its folder) if missing.
        setup: run once on the new connection under the lock (the schema: `migrate`).
        synchronous: as `connect`.

    Raises:
        TwinError: the file is not a database, is damaged, or `setup` refused it (closed).
    """

    def __init__(
        self,
        path: Path,
        setup: Callable[[sqlite3.Connection], None],
        synchronous: str = "NORMAL",
    ) -> None:
        self.path = path
        self.name = f"run store {path}"
        self.lock = threading.Lock()
        try:
            self.conn = connect(path, synchronous)
        except sqlite3.DatabaseError as exc:
            raise self._unreadable(exc) from None
        try:
            with self.lock:
                setup(self.conn)
        except sqlite3.DatabaseError as exc:  # not a database, or a damaged one
            self.conn.close()
            raise self._unreadable(exc) from None
        except BaseException:
            self.conn.close()
            raise
        self._identity = self._stat()

    def _unreadable(self, exc: Exception) -> TwinError:
        return TwinError(
            f"{self.name} cannot be read ({exc}): move it aside (mv {self.path} {self.path}.bad) "
            "to start with an empty store, or restore it from a backup"
        )

    def _stat(self) -> tuple[int, int] | None:
        try:
            info = os.stat(self.path)
        except OSError:
            return None
        return info.st_dev, info.st_ino

    def check(self) -> None:
        """Raise `StoreUnavailable` if the file opened is no longer the one at `path`."""
        now = self._stat()
        if now != self._identity:
            what = "deleted" if now is None else "replaced by another file"
            raise StoreUnavailable(
                f"{self.name} was {what} while the server runs: nothing more is stored, so "
                "nothing is written where nobody could read it back; restart the server (with "
                "the file restored, or to start a new store)"
            )

    @property
    def available(self) -> bool:
        """Whether the file opened is still the one at `path`."""
        return self._stat() == self._identity

    @contextmanager
    def writing(self) -> Iterator[sqlite3.Connection]:
        """The connection inside one write transaction, under the lock, after the file check."""
        with self.lock:
            self.check()
            with transaction(self.conn, self.name):
                yield self.conn

    def write(self, *statements: tuple[str, tuple[Any, ...]]) -> int:
        """(sql, parameters) statements in one transaction; the rows the first one changed."""
        with self.writing() as conn:
            changed = conn.execute(*statements[0]).rowcount
            for sql, parameters in statements[1:]:
                conn.execute(sql, parameters)
            return int(changed)

    def read(self, sql: str, parameters: tuple[Any, ...] = ()) -> list[sqlite3.Row]:
        """A query's rows, under the lock, after the file check (SQLite errors are a 503)."""
        with self.lock:
            self.check()
            try:
                return self.conn.execute(sql, parameters).fetchall()
            except sqlite3.OperationalError as exc:
                raise StoreUnavailable(f"{self.name}: {exc}") from exc

    def close(self) -> None:
        with self.lock:
            self.conn.close()


def cancel_sql(table: str, size: str | None = None) -> str:
    """The UPDATE that fails a queued or running job of `table` as cancelled (parameters:
    finished [s since the epoch], error, id); `size` is the SQL the row's size [bytes] becomes,
    None to leave it."""
    resize = "" if size is None else f", size = {size}"
    return (
        f"UPDATE {table} SET status = 'failed', finished = ?, error = ?{resize} "
        f"WHERE id = ? AND {UNFINISHED}"
    )


def requeue(
    db: Database, table: str, reset: str, max_attempts: int, size: str | None = None
) -> list[str]:
    """Jobs of `table` a stopped server left queued or running, set back to queued (`reset`:
    the SQL assignments that undo their progress), oldest first, in one transaction; those
    already started `max_attempts` times are failed instead, saying so (`size`: as in
    `cancel_sql`)."""
    resize = "" if size is None else f", size = {size}"
    with db.writing() as conn:
        conn.execute(
            f"UPDATE {table} SET status = 'failed', finished = ?, error = 'interrupted: "
            "started ' || attempts || ' times, each stopped by a server stop or crash "
            f"before it finished; not queued again (resubmit it, smaller)'{resize} "
            f"WHERE {UNFINISHED} AND attempts >= ?",
            (time.time(), max_attempts),
        )
        rows = conn.execute(
            f"SELECT id FROM {table} WHERE {UNFINISHED} ORDER BY created, rowid"
        ).fetchall()
        conn.execute(f"UPDATE {table} SET status = 'queued', {reset} WHERE status = 'running'")
    return [row["id"] for row in rows]

"""twin.db: the one SQLite layer of the run store, the workability jobs and the cell cache."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from twin.db import (
    CANCELLED,
    Database,
    StoreUnavailable,
    cancel_sql,
    migrate,
    requeue,
    session,
)
from twin.errors import TwinError

JOBS = """
CREATE TABLE IF NOT EXISTS jobs (
    id TEXT PRIMARY KEY, created REAL NOT NULL, finished REAL, status TEXT NOT NULL,
    error TEXT, done INTEGER NOT NULL DEFAULT 0, attempts INTEGER NOT NULL DEFAULT 0
);
"""


def jobs(path: Path) -> Database:
    """A store of one `jobs` table."""
    return Database(path, lambda conn: migrate(conn, f"jobs {path}", JOBS))


def test_a_session_closes_its_connection_and_commits(tmp_path: Path) -> None:
    """A session's connection is closed after it (`with sqlite3.connect()` leaves it open) and
    what it wrote is there for the next one."""
    path = tmp_path / "a" / "cells.sqlite"
    with session(path) as conn:
        conn.execute("CREATE TABLE t (x)")
        conn.execute("INSERT INTO t VALUES (1)")
    with pytest.raises(sqlite3.ProgrammingError, match="closed"):
        conn.execute("SELECT 1")
    with session(path, write=False) as again:
        assert again.execute("SELECT x FROM t").fetchall()[0][0] == 1
        assert again.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_a_failed_session_rolls_back_and_closes(tmp_path: Path) -> None:
    """An error inside a session writes nothing of it and still closes the connection."""
    path = tmp_path / "cells.sqlite"
    with session(path) as conn:
        conn.execute("CREATE TABLE t (x)")
    with pytest.raises(ZeroDivisionError), session(path) as conn:
        conn.execute("INSERT INTO t VALUES (1)")
        _ = 1 / 0
    with pytest.raises(sqlite3.ProgrammingError):
        conn.execute("SELECT 1")
    with session(path, write=False) as again:
        assert again.execute("SELECT COUNT(*) FROM t").fetchone()[0] == 0


def test_migrate_adds_missing_columns_and_refuses_a_newer_file(tmp_path: Path) -> None:
    """An older table gains the added column once; a file of a newer version is refused."""
    path = tmp_path / "s.sqlite"
    with session(path) as conn:
        conn.execute("CREATE TABLE jobs (id TEXT)")
    db = Database(path, lambda c: migrate(c, "s", JOBS, {"jobs": {"size": "INTEGER"}}, 2))
    names = [row["name"] for row in db.read("PRAGMA table_info(jobs)")]
    db.close()
    assert names == ["id", "size"]
    with pytest.raises(TwinError, match="schema 2 is newer than this twin's \\(1\\)"):
        Database(path, lambda c: migrate(c, "s", JOBS, version=1))


def test_a_file_that_is_no_database_is_refused_saying_what_to_do(tmp_path: Path) -> None:
    """A file of garbage is a TwinError naming the move-aside command, not a crash later."""
    path = tmp_path / "bad.sqlite"
    path.write_bytes(b"not a database at all" * 100)
    with pytest.raises(TwinError, match=r"mv .*bad\.sqlite"):
        jobs(path)


def test_a_deleted_file_makes_every_access_unavailable(tmp_path: Path) -> None:
    """Once the opened file is gone, reads and writes raise StoreUnavailable (a 503)."""
    db = jobs(tmp_path / "j.sqlite")
    db.write(("INSERT INTO jobs (id, created, status) VALUES ('a', 0, 'queued')", ()))
    (tmp_path / "j.sqlite").unlink()
    with pytest.raises(StoreUnavailable, match="deleted"):
        db.read("SELECT * FROM jobs")
    with pytest.raises(StoreUnavailable, match="deleted"):
        db.write(("DELETE FROM jobs", ()))
    db.close()


def test_requeue_queues_the_unfinished_and_fails_those_started_too_often(tmp_path: Path) -> None:
    """Running and queued jobs come back queued, oldest first, their progress reset; a job
    started `max_attempts` times is failed saying so; a done one is left."""
    db = jobs(tmp_path / "j.sqlite")
    rows = [("a", 2, "running", 5, 1), ("b", 1, "queued", 0, 0), ("c", 3, "running", 7, 3),
            ("d", 0, "done", 9, 1)]  # fmt: skip
    db.write(*[("INSERT INTO jobs (id, created, status, done, attempts) VALUES (?, ?, ?, ?, ?)",
                row) for row in rows])  # fmt: skip
    assert requeue(db, "jobs", "done = 0", max_attempts=3) == ["b", "a"]
    state = {r["id"]: (r["status"], r["done"], r["error"]) for r in db.read("SELECT * FROM jobs")}
    db.close()
    assert state["a"] == ("queued", 0, None)
    assert state["c"][0] == "failed" and "started 3 times" in state["c"][2]
    assert state["d"] == ("done", 9, None)


def test_cancel_sql_fails_only_an_unfinished_job(tmp_path: Path) -> None:
    """The cancel statement changes a queued job and leaves a done one."""
    db = jobs(tmp_path / "j.sqlite")
    db.write(("INSERT INTO jobs (id, created, status) VALUES ('q', 0, 'queued'), "
              "('d', 0, 'done')", ()))  # fmt: skip
    cancelled = [db.write((cancel_sql("jobs"), (1.0, f"{CANCELLED} test", job))) for job in "qd"]
    db.close()
    assert cancelled == [1, 0]

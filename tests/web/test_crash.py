"""Crash recovery: `twin serve` killed with SIGKILL mid-write keeps its run store consistent.

A real server (`--no-viewer`, loopback, its default executor: a Dask LocalCluster of two
worker processes) is killed once per entry of `KILLS`, each time at another moment of writing:
with its workers while it stores the progress they report; alone, at the same moment (its
orphaned workers must notice and exit by themselves, within 10 s); and with its workers
right after a restart, while it requeues the unfinished runs and a burst of submissions
inserts new ones. After each kill the SQLite file opens with
`PRAGMA integrity_check` ok, in WAL mode, every row with a valid status, and every run that
was accepted (201/202 with an id) is still there, a 201 still done. A last restart requeues
and finishes every unfinished run, accepted or cut off mid-request, and serves every run's
series. The test ends by itself within `BUDGET` s.
"""

from __future__ import annotations

import contextlib
import io
import os
import random
import signal
import sqlite3
import threading
import time
from collections import Counter
from pathlib import Path
from typing import Any

import httpx
import psutil
import pyarrow.parquet as pq

from tests.figures import record
from tests.timing import scaled
from tests.web.support import wait_for
from tests.web.test_load import Server

#: [s] the whole test must end within this (two phases wait for the runs requeued by the kill
#: before them)
BUDGET = 180.0
#: how each server dies (`test_sigkill_…` says when)
KILLS = ("progress", "orphan", "burst")
#: a 2 s run: synchronous, 201 once done
SHORT = {"mechanism": "upr4", "planner": "pid", "n_components": 16, "duration": 2.0}
#: over the synchronous cap, and long enough to be caught running, writing progress every
#: 0.5 s: the most steps a scenario may have, on the finest sea (200,000 steps, 2,048 wave
#: components: 1-2 s on the compiled engine)
MEDIUM = {"mechanism": "upr4", "planner": "pid", "n_components": 2048, "dt": 0.005,
          "duration": 1000.0}  # fmt: skip
#: answered 202 at once, run in the background
LONG = {**MEDIUM, "mechanism": "hybrid", "planner": "mtmp"}
STATUSES = {"queued", "running", "done", "failed"}
#: runs stored; runs a worker is running and has written progress into
STORED = "SELECT COUNT(*) FROM runs"
RUNNING = "SELECT COUNT(*) FROM runs WHERE status = 'running' AND progress > 0"
#: runs queued or running (a restart has requeued the ones a kill cut off)
UNFINISHED = "SELECT COUNT(*) FROM runs WHERE status IN ('queued', 'running')"


class Submissions:
    """Runs submitted to one server from threads; which it accepted, how the rest ended."""

    def __init__(self, url: str) -> None:
        self.url = url
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.accepted: dict[str, int] = {}  # run id → 201/202
        self.statuses: Counter[str] = Counter()
        self.errors: list[str] = []
        self.threads: list[threading.Thread] = []

    def post(self, scenario: dict[str, Any]) -> None:
        """One POST /api/runs; a connection dropped by the kill is counted, not raised."""
        try:
            response = httpx.post(f"{self.url}/api/runs", json=scenario, timeout=60.0)
        except httpx.TransportError:
            with self.lock:
                self.statuses["dropped"] += 1
            return
        with self.lock:
            self.statuses[str(response.status_code)] += 1
            if response.status_code in (201, 202):
                run = response.json()
                self.accepted[run["id"]] = response.status_code
                expected = "done" if response.status_code == 201 else "queued"
                if run["status"] != expected:
                    self.errors.append(f"{response.status_code} but {run['status']}: {run}")
            elif response.status_code != 429:  # a 429 only refuses the run
                self.errors.append(f"POST {scenario}: {response.status_code} {response.text}")

    def background(self, *scenarios: dict[str, Any], repeat: bool = False) -> None:
        """POST the scenarios one after another in a thread (over and over if `repeat`)."""

        def loop() -> None:
            while not self.stop.is_set():
                for scenario in scenarios:
                    if self.stop.is_set():
                        return
                    self.post(scenario)
                if not repeat:
                    return

        thread = threading.Thread(target=loop, daemon=True)
        thread.start()
        self.threads.append(thread)

    def join(self) -> None:
        self.stop.set()
        for thread in self.threads:
            thread.join(timeout=15.0)  # the server is dead: every request ends at once
            assert not thread.is_alive(), "a submission hung after the kill"
        assert not self.errors, self.errors


def rows(path: Path) -> dict[str, dict[str, Any]]:
    """The run store opened as any SQLite client would: checked, then its runs by id."""
    with contextlib.closing(sqlite3.connect(path, timeout=10.0)) as db:
        assert db.execute("PRAGMA integrity_check").fetchall() == [("ok",)]
        assert db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        found = {
            run_id: {"status": status, "progress": progress, "metrics": metrics,
                     "series": series, "finished": finished}
            for run_id, status, progress, metrics, series, finished in db.execute(
                "SELECT id, status, progress, metrics IS NOT NULL, length(series), finished "
                "FROM runs"
            )
        }  # fmt: skip
    for run_id, row in found.items():
        assert row["status"] in STATUSES, (run_id, row)
        assert row["status"] != "failed", (run_id, row)  # every scenario here is valid
        assert 0.0 <= row["progress"] <= 1.0, (run_id, row)
        if row["status"] == "done":
            assert row["metrics"] and row["series"] and row["finished"], (run_id, row)
    return found


def peek(path: Path, sql: str) -> int:
    """One count from the store, read-only (0 while the file is missing or busy)."""
    try:
        db = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=1.0)
        with contextlib.closing(db):
            return db.execute(sql).fetchone()[0]
    except sqlite3.OperationalError:
        return 0


def alive(process: psutil.Process) -> bool:
    try:
        return process.is_running() and process.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def kill(server: Server, *, group: bool) -> list[psutil.Process]:
    """SIGKILL the server, with its workers if `group`; the processes it had when it died
    (its workers among them; alone, they may have exited by the time this returns)."""
    children = psutil.Process(server.process.pid).children(recursive=True)
    if group:
        os.killpg(server.process.pid, signal.SIGKILL)
    else:
        server.process.send_signal(signal.SIGKILL)
    server.process.wait(10)
    return children


def test_sigkill_mid_write_keeps_the_store_consistent_and_restart_recovers(
    tmp_path: Path,
) -> None:
    """Servers killed mid-write lose no accepted run, leave no orphan worker, and a restart finishes
    every run."""
    began = time.monotonic()
    budget = scaled(BUDGET)  # the load now stretches it (tests/timing.py)
    database = tmp_path / "data" / "runs.sqlite"
    rng = random.Random(20250801)
    accepted: dict[str, int] = {}
    statuses: Counter[str] = Counter()
    servers: list[Server] = []
    orphans: list[psutil.Process] = []
    try:
        for moment in KILLS:
            server = Server(tmp_path, viewer=False)
            servers.append(server)
            server.wait_ready(timeout=scaled(45.0))
            submissions = Submissions(server.url)
            if moment == "burst":
                # at once after the restart: it requeues, its workers start the requeued runs,
                # and 8 connections insert new ones; die once half of those are stored
                half = peek(database, STORED) + 4
                for _ in range(8):
                    submissions.background(SHORT)
                assert wait_for(lambda h=half: peek(database, STORED) >= h, 10, poll=0.02)
                time.sleep(rng.uniform(0.0, 0.05))
            else:
                # the runs the last kill cut off finish first: one killed at every restart
                # would reach the restart cap (`store.MAX_ATTEMPTS`) and be failed, as it should
                # (short runs now run in the server at once, so nothing else makes them wait)
                assert wait_for(lambda: peek(database, UNFINISHED) == 0, scaled(30.0), poll=0.05)
                for _ in range(2):  # done (201) before anything dies
                    submissions.post(SHORT)
                if not accepted:
                    submissions.post(LONG)  # queued (202): requeued by every restart
                submissions.background(MEDIUM, SHORT, repeat=True)
                # progress being written
                assert wait_for(lambda: peek(database, RUNNING) > 0, 20, poll=0.02)
                time.sleep(rng.uniform(0.0, 0.5))  # somewhere between two progress writes
            had = kill(server, group=moment != "orphan")
            submissions.join()
            if moment == "orphan":
                # its workers were running when it died; how soon each notices is a race, so
                # each is waited for below, whether it is gone already or not
                assert had, "the server had no worker processes when it was killed"
                orphans += had
            accepted |= submissions.accepted
            statuses.update(submissions.statuses)

            found = rows(database)
            missing = set(accepted) - set(found)
            assert not missing, f"accepted runs lost by the {moment} kill: {sorted(missing)}"
            undone = [i for i, code in accepted.items() if code == 201
                      and found[i]["status"] != "done"]  # fmt: skip
            assert not undone, f"runs answered done are not done after the kill: {undone}"

        # orphaned workers notice their server is gone and exit by themselves (a Dask worker
        # process watches a pipe from its parent), and the resource tracker with them
        _, still = psutil.wait_procs(orphans, timeout=10)
        orphans_alive = len(still)
        assert not still, f"workers outlived their killed server: {still}"
        unfinished = {i for i, row in rows(database).items() if row["status"] != "done"}
        assert unfinished & {i for i, code in accepted.items() if code == 202}, (
            "the kills left no accepted run unfinished: nothing to recover"
        )

        # -- the last restart: everything unfinished is requeued and done ---------------------
        restarted = time.time()
        server = Server(tmp_path, viewer=False)
        servers.append(server)
        server.wait_ready(timeout=scaled(45.0))
        with httpx.Client(base_url=server.url, timeout=30.0) as client:
            pending = set(rows(database))
            while pending and time.monotonic() < began + budget - 5.0:
                budget = max(budget, scaled(BUDGET))  # the load as it is now, not at the start
                for run_id in sorted(pending):
                    run = client.get(f"/api/runs/{run_id}")
                    assert run.status_code == 200, (run_id, run.status_code, run.text)
                    assert run.json()["status"] != "failed", run.json()
                    if run.json()["status"] == "done":
                        pending.discard(run_id)
                time.sleep(0.5)
            assert not pending, f"runs not recovered within the budget: {sorted(pending)}"
            found = rows(database)
            assert set(accepted) <= set(found)
            for run_id in unfinished:  # requeued and run again, to the end
                assert found[run_id]["finished"] > restarted, run_id
            for run_id in found:
                series = client.get(f"/api/runs/{run_id}/series", params={"format": "parquet"})
                assert series.status_code == 200, (run_id, series.text)
                scenario = client.get(f"/api/runs/{run_id}").json()["scenario"]
                steps = round(scenario["duration"] / scenario["dt"])
                assert pq.read_table(io.BytesIO(series.content)).num_rows == steps + 1, run_id
            short = next(i for i, code in accepted.items() if code == 201)
            series = client.get(f"/api/runs/{short}/series")
            assert series.status_code == 200 and len(series.json()["series"]["t"]) == 41
        assert server.stop() == 0, server.log()
    finally:
        for server in servers:  # a failed assertion leaves one running: end it and its workers
            if server.process.poll() is None:
                os.killpg(server.process.pid, signal.SIGKILL)
                server.process.wait(10)
        for process in orphans:
            if alive(process):
                with contextlib.suppress(psutil.NoSuchProcess):
                    process.kill()
    duration = time.monotonic() - began

    record(
        "crash_recovery",
        kills=len(KILLS),
        kill_moments=list(KILLS),
        submissions=dict(sorted(statuses.items())),
        runs_accepted=len(accepted),
        runs_accepted_queued=sum(code == 202 for code in accepted.values()),
        runs_stored=len(found),
        runs_unfinished_at_last_kill=len(unfinished),
        runs_recovered=len(unfinished),
        orphaned_processes=len(orphans),
        orphans_alive_before_cleanup=orphans_alive,
        integrity="ok",
        journal_mode="wal",
        duration_s=round(duration, 1),
    )
    assert duration < max(budget, scaled(BUDGET)), duration

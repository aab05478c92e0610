"""Workability jobs of the REST API: one at a time, on the server's one executor.

`WorkabilityRunner` is modelled on `twin.web.jobs.SweepRunner`: a daemon thread drives
`twin.sim.workability.run_workability` on the server's executor (the workers simulate in chunks,
below single runs' priority; the thread only collects), stores progress (runs done of those
needed, cached ones counting as done), then draws the plots as a task on the executor (never in
the process that answers requests) and stores the result and its PNGs. Cancel marks the job
failed and stops the evaluation after the chunk in hand (`run_workability`'s `stop`). A stopped
server leaves its job queued; the next start queues it again, up to `store.MAX_ATTEMPTS` starts.

Operability cells are cached in the server's data dir (the run store's folder, `cells.sqlite`,
`twin.sim.workability.CellCache`), so a second record or a longer one reuses them.

Records: a shipped one by name (`shipped_records`, the files of `assets/site/`), or an uploaded
one's text (`record_csv`, at most `MAX_RECORD_BYTES`), written to a temporary file and read by the
same readers as the CLI (`twin.site.read_record`).
"""

from __future__ import annotations

import logging
import queue
import tempfile
import threading
from pathlib import Path
from typing import Any

import pandas as pd

from twin.assets import asset_path
from twin.errors import TwinError
from twin.sim.executor import Executor
from twin.site import SiteRecord, read_record
from twin.web.store import StoreUnavailable
from twin.web.workability_store import WorkabilityStore

log = logging.getLogger(__name__)

#: [bytes] largest uploaded record text (`record_csv`); the request body's cap
#: (`twin.web.limits.MAX_BODY`, 64 KiB) bounds it too: ~1,500 hourly rows of CSV. Longer
#: records: ship them under assets/site or use `twin workability` (the CLI reads 64 MB).
MAX_RECORD_BYTES = 60_000
#: most forecast steps a job's result lists (`forecast_steps`): 7 days at 3 h steps, and more
MAX_STEPS = 500
#: [s] how often the thread waiting for the plots looks whether to stop
POLL = 0.2
#: files of assets/site that are not records
_NOT_RECORDS = {"README.md"}


def shipped_records() -> list[str]:
    """Names of the records shipped under `assets/site/`, sorted."""
    folder = asset_path("site")
    return sorted(p.name for p in folder.iterdir() if p.is_file() and p.name not in _NOT_RECORDS)


def load_record(source: dict[str, Any]) -> SiteRecord:
    """A record from a job's source: `{"name": NAME}` (shipped) or `{"csv": TEXT, "kind": K}`.

    Raises:
        TwinError: an unknown name (naming the shipped ones), text over `MAX_RECORD_BYTES`, or
            malformed content (the reader's message, with its line).
    """
    if "name" in source:
        name = source["name"]
        names = shipped_records()
        if name not in names:
            raise TwinError(
                f"record: {name!r} is not a shipped record; allowed {names} "
                "(GET /api/workability/records), or upload one as record_csv"
            )
        return read_record(asset_path("site", name))
    text = source["csv"]
    size = len(text.encode())
    if size > MAX_RECORD_BYTES:
        raise TwinError(f"record_csv: {size} bytes; allowed at most {MAX_RECORD_BYTES}")
    with tempfile.TemporaryDirectory(prefix="twin-record-") as folder:
        path = Path(folder) / "upload.csv"  # the name the readers' messages show
        path.write_text(text, encoding="utf-8")
        return read_record(path, kind=source.get("kind"))


def forecast_steps(result: Any) -> dict[str, Any]:
    """A forecast's rows for the page's table: `{"steps": [{time, hs, tp, planner,
    probability, operable, limiting}, …]}` (at most `MAX_STEPS` rows × planners); {} for other
    records (their rows are the CLI's CSV)."""
    if result.record.kind != "forecast":
        return {}
    rows = result.rows.head(MAX_STEPS * len(result.spec.planners or [1]))
    steps = [
        {"time": pd.Timestamp(r.time).isoformat() + "Z", "hs": float(r.hs), "tp": float(r.tp),
         "planner": str(r.planner), "probability": float(r.probability),
         "operable": bool(r.operable), "limiting": str(r.limiting)}
        for r in rows.itertuples()
    ]  # fmt: skip
    return {"steps": steps}


def draw(result: Any) -> dict[str, bytes]:
    """A result's PNG plots (a task for a worker process: matplotlib stays out of the server)."""
    return result.pngs()


class WorkabilityRunner:
    """Workability jobs one at a time from a daemon thread on the server's executor.

    Args:
        store: where jobs are read from and written to.
        data_dir: folder of the cell cache (default: the store file's folder).
    """

    def __init__(self, store: WorkabilityStore, data_dir: str | Path | None = None) -> None:
        self.store = store
        self.data_dir = Path(data_dir) if data_dir is not None else store.path.parent
        self.executor: Executor | None = None
        self._queue: queue.Queue[str | None] = queue.Queue()
        self._thread: threading.Thread | None = None
        self._stopping = threading.Event()
        self._cancelled: set[str] = set()
        self._lock = threading.Lock()

    def start(self, executor: Executor) -> list[str]:
        """Start the thread on `executor`; queue jobs a previous server left unfinished.

        Returns:
            The ids queued again.
        """
        self.executor = executor
        self._stopping.clear()
        if self._thread is None or not self._thread.is_alive():
            self._thread = threading.Thread(target=self._loop, name="twin-workability",
                                            daemon=True)  # fmt: skip
            self._thread.start()
        recovered = self.store.requeue_unfinished()
        for job_id in recovered:
            self.submit(job_id)
        return recovered

    def submit(self, job_id: str) -> None:
        """Run a stored job after those queued (before `start`: `start` takes it from the store)."""
        if self.executor is not None:
            self._queue.put(job_id)

    def cancel(self, job_id: str, reason: str = "by request") -> bool:
        """Cancel a queued or running job (stored failed, "cancelled …"); the one in hand stops
        after its running chunk. Whether it was queued or running.

        Raises:
            WorkabilityNotFound: no job has this id.
        """
        cancelled = self.store.cancel(job_id, reason)
        if cancelled:
            with self._lock:
                self._cancelled.add(job_id)
        return cancelled

    def _stopped(self, job_id: str) -> bool:
        with self._lock:
            return self._stopping.is_set() or job_id in self._cancelled

    def shutdown(self, timeout: float = 2.0) -> None:
        """Stop the job in hand; it and the queued ones stay queued in the store."""
        self._stopping.set()
        self._queue.put(None)
        if self._thread is not None:
            self._thread.join(timeout)
            self._thread = None
        try:
            self.store.requeue_unfinished()
        except StoreUnavailable:
            log.warning("run store unavailable at shutdown: workability jobs not requeued")

    def _loop(self) -> None:
        while (job_id := self._queue.get()) is not None:
            if self._stopping.is_set():
                return
            if self._stopped(job_id):  # cancelled while queued
                with self._lock:
                    self._cancelled.discard(job_id)
                continue
            self.execute(job_id)

    def execute(self, job_id: str) -> None:
        """Run one stored job to the end, storing progress, result and plots (or the error)."""
        from twin.sim.workability import WorkabilitySpec, run_workability

        stop = lambda: self._stopped(job_id)  # noqa: E731
        try:
            fields, source = self.store.request(job_id)
            spec = WorkabilitySpec(**fields)
            record = load_record(source)
            if not self.store.running(job_id):
                return  # cancelled before it started
            result = run_workability(
                spec, record, executor=self.executor, data_dir=self.data_dir, stop=stop,
                on_progress=lambda done, total: self.store.progress(job_id, done, total),
            )  # fmt: skip
            plots = self._render(result, stop)
            self.store.finish(job_id, {**result.to_dict(), **forecast_steps(result)}, plots)
        except Exception as exc:  # a thread has no caller: the store is its report
            if stop():
                return  # a shutdown leaves it queued; a cancel has stored it already
            try:
                self.store.fail(job_id, f"{type(exc).__name__}: {exc}")
            except Exception:
                log.exception("workability %s failed and could not be stored as failed", job_id)
        finally:
            with self._lock:
                self._cancelled.discard(job_id)

    def _render(self, result: Any, stop: Any) -> dict[str, bytes]:
        """The plots drawn by a task on the executor, waited for in short steps."""
        if self.executor is None:
            raise RuntimeError("WorkabilityRunner.start(executor) first")
        future = self.executor.submit(draw, result)
        try:
            while True:
                if stop():
                    raise RuntimeError("stopped while the plots were drawn")
                try:
                    return future.result(timeout=POLL)
                except TimeoutError:
                    continue
        finally:
            self.executor.cancel([future])

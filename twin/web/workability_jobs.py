"""Workability jobs of the REST API: one at a time, each a task on the server's one executor.

`WorkabilityRunner` extends `twin.web.jobs.QueuedJobs`, as `SweepRunner` does: a daemon thread
takes a stored job, counts its attempt (`store.running`, before anything of it is read), and
hands the whole evaluation to a worker of the server's executor (`evaluate_job`): the record
unpacked, `twin.runs.workability.run_workability` driving its runs from there (a client of the
same cluster, `distributed.worker_client`: the chunks still spread over every worker, below
single runs' priority), the per-row table, the summary and the plots. None of it runs in the
process that answers requests (issue 43: on a 200,000-row record with 36 headings, the unique
over row-headings alone held the GIL for 16 s, and health waited as long). The thread only
waits, storing the progress the task reports (a Dask event topic of its own), and stores the
result, its PNGs and the per-row CSV. Cancel marks the job failed and sets the task's stop
event: it stops after the chunk in hand (`run_workability`'s `stop`). A stopped server leaves
its job queued; the next start queues it again, up to `twin.db.MAX_ATTEMPTS` starts.

Operability cells are cached in the server's data dir (the run store's folder, `cells.sqlite`,
`twin.runs.workability.CellCache`), written by the worker that runs the job.

Records: a shipped one by name (`shipped_records`, the files of `assets/site/`), or an uploaded
one's text (`record_csv`, at most `MAX_RECORD_BYTES`), priced and read at submission by
`read_upload` (`twin.web.upload_records`: a text scan, then the CLI's readers in a bounded
child process, `twin.web.upload_worker`); the job gets the record's columns, never the text.
"""

from __future__ import annotations

import gzip
import logging
import tempfile
import threading
import uuid
from collections.abc import Callable
from concurrent.futures import Future
from pathlib import Path
from typing import Any

import pandas as pd

from twin.errors import TwinError
from twin.site import SiteRecord, read_record
from twin.web.jobs import POLL, QueuedJobs
from twin.web.limits import MAX_BODY
from twin.web.upload_records import (
    DEFAULT_NAME,
    prescan,
    read_shipped,
    unpack_record,
)
from twin.web.upload_worker import BoundedWorker, Budget
from twin.web.workability_store import ROWS_FILE, WorkabilityStore

log = logging.getLogger(__name__)

#: [bytes] largest uploaded record text (`record_csv`): 4 MiB holds a 10-year hourly record
#: (87,600 rows of `time,hs,tp,direction` at about 40 bytes). Longer records: ship them under
#: assets/site or use `twin workability` (the CLI reads 64 MB).
MAX_RECORD_BYTES = 4 * 1024 * 1024
#: [bytes] the body cap of POST /api/workability (`twin.web.limits.BodyLimit`'s route limit):
#: the record, its JSON escapes (a newline is 2 bytes in JSON) and the spec's fields
UPLOAD_BODY = 2 * MAX_RECORD_BYTES + MAX_BODY
#: most forecast steps a job's result lists (`forecast_steps`): 7 days at 3 h steps, and more
MAX_STEPS = 500
#: what reading one record may take, in its child process: a 3 MB, 150,000-row hourly record
#: takes 0.45 s of one core (0.3 s for 10 years hourly)
READ_BUDGET = Budget(cpu=5.0, wall=20.0)
#: [s] how long a submission waits for its reading (the rest of its second goes to reading a
#: 4 MiB body and answering): done by then, it answers 422 for a bad
#: record or 202 for a job that may run; not done, it answers 202 with the job queued, and a
#: reading that fails later fails the job with the same message
ANSWER_WAIT = 0.7
#: [s] how long a submission waits for a free reading child (two, busy or starting: a child
#: imports the simulation layer's reader in about 5 s) before a 503
READ_WAIT = 10.0
def load_record(source: dict[str, Any]) -> SiteRecord:
    """A record from a job stored without its columns (before issue 43): `{"name": NAME}`
    (shipped) or `{"csv": TEXT, "kind": K}`, read where it is called (a worker's task).

    Raises:
        TwinError: an unknown name, or malformed content (the reader's message, with its line).
    """
    if "name" in source:
        return unpack_record(read_shipped(source["name"], {})["blob"])
    with tempfile.TemporaryDirectory(prefix="twin-record-") as folder:
        path = Path(folder) / DEFAULT_NAME
        path.write_text(source["csv"], encoding="utf-8")
        return read_record(path, kind=source.get("kind"))


def forecast_steps(result: Any) -> dict[str, Any]:
    """A forecast's rows for the page's table: `{"steps": [{time, hs, tp, planner,
    probability, operable, limiting}, …]}` (at most `MAX_STEPS` rows × planners); {} for other
    records (their rows are the per-row CSV)."""
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


def packed_rows(result: Any) -> bytes:
    """A result's per-row table (`twin.runs.workability.rows_csv`), gzip-compressed."""
    from twin.runs.workability import rows_csv

    return gzip.compress(str(rows_csv(result.rows)).encode(), compresslevel=6)


def evaluate_job(
    fields: dict[str, Any], record: bytes | dict[str, Any], *, data_dir: str, where: str,
    topic: str, job: str, stop_event: str, title: str | None = None,
) -> dict[str, Any]:  # fmt: skip
    """One job, a task on a worker of the executor: its result (with `forecast_steps`), its
    PNG plots and `ROWS_FILE` by name.

    Args:
        fields: the `WorkabilitySpec` fields.
        record: the record's packed columns (`pack_record`), or the source of a job stored
            before issue 43 (`load_record`).
        data_dir: folder of the cell cache.
        where: the executor's `where` (its runs' numba threads follow it).
        topic: the Dask event topic progress goes to, as {"job", "done", "total"}.
        job: the job's id, in the progress reports.
        stop_event: the Dask `Event` whose setting stops it after the chunk in hand.
        title: what the plots call the record (an uploaded file's name); None: its source.
    """
    from distributed import Event, worker_client

    from twin.runs.executor import Executor, report
    from twin.runs.workability import WorkabilitySpec, run_workability

    site = unpack_record(record) if isinstance(record, bytes) else load_record(record)
    with worker_client() as client:  # this task leaves its slot to the chunks it waits for
        stop = Event(stop_event, client=client)
        result = run_workability(
            WorkabilitySpec(**fields), site, executor=Executor(client, where=where),
            data_dir=data_dir, stop=stop.is_set,
            on_progress=lambda done, total: report(topic, {"job": job, "done": done,
                                                            "total": total}),
        )  # fmt: skip
    files = {**result.pngs(title=title), ROWS_FILE: packed_rows(result)}
    return {"result": {**result.to_dict(), **forecast_steps(result)}, "files": files}


class WorkabilityRunner(QueuedJobs):
    """Workability jobs one at a time from a daemon thread, each a task on the server's
    executor (`twin.web.jobs.QueuedJobs`), and the bounded reading of records at submission.

    Args:
        store: where jobs are read from and written to.
        data_dir: folder of the cell cache (default: the store file's folder).
    """

    thread_name = "twin-workability"
    kind = "workability"
    kinds = "workability jobs"
    store: WorkabilityStore

    def __init__(self, store: WorkabilityStore, data_dir: str | Path | None = None) -> None:
        super().__init__(store)
        self.data_dir = Path(data_dir) if data_dir is not None else store.path.parent
        self.topic = f"twin-workability-{uuid.uuid4().hex[:12]}"
        self._progress: dict[str, tuple[int, int]] = {}  # job id → (done, total), last reported
        self._reader: BoundedWorker | None = None
        self._reader_lock = threading.Lock()

    # -- reading records at submission ------------------------------------------------------
    def read(self, source: dict[str, Any], spec: dict[str, Any]) -> Future[dict[str, Any]]:
        """Start reading a request's record for the `WorkabilitySpec` fields `spec`, within
        `READ_BUDGET`, in a child process: a future of `{"blob", "summary"}`
        (`twin.web.upload_records.parse_record`). An upload's text is scanned first, here.
        `source`: `{"name": …}` or `{"csv": text, "kind": …, "upload": file name}`.

        Raises:
            TwinError: text over `MAX_RECORD_BYTES`, or over a limit of the scan
                (`UploadRefused`). The future's: the record is malformed, unknown, over the
                grid's limit or over its budget (`OverBudget`); `WorkerBusy`: no child free.
        """
        if "name" in source:
            return self._reader_worker().submit("read_shipped", source["name"], spec,
                                                budget=READ_BUDGET, wait=READ_WAIT)  # fmt: skip
        text = source["csv"]
        size = len(text.encode())
        if size > MAX_RECORD_BYTES:
            raise TwinError(f"record_csv: {size} bytes; allowed at most {MAX_RECORD_BYTES}")
        prescan(text)  # priced before any parser sees it
        return self._reader_worker().submit(
            "parse_record", text, source.get("kind"), source["upload"], spec,
            budget=READ_BUDGET, wait=READ_WAIT,
        )  # fmt: skip

    def adopt(
        self, job_id: str, reading: Future[dict[str, Any]],
        price: Callable[[int], tuple[list[dict[str, Any]], int]],
    ) -> None:  # fmt: skip
        """A job stored before its record was read: once `reading` ends, its columns are
        attached and it is queued to run, unless the reading failed or `price(rows)` (the
        limits it is over, its runs) names a limit; then it fails with that message."""

        def settle(done: Future[dict[str, Any]]) -> None:
            try:
                read = done.result()
                errors, runs = price(int(read["summary"]["rows"]))
                if errors:
                    raise TwinError("; ".join(str(e["msg"]) for e in errors))
            except Exception as exc:  # the job is the report: a thread has no caller
                self.store.fail(job_id, f"record: {exc}")
                return
            if self.store.attach(job_id, read["blob"], runs):
                self.submit(job_id)

        reading.add_done_callback(settle)

    def _reader_worker(self) -> BoundedWorker:
        with self._reader_lock:
            if self._reader is None:  # the first upload starts the children (1-2 s once)
                self._reader = BoundedWorker("twin.web.upload_records")
            return self._reader

    # -- jobs --------------------------------------------------------------------------------
    def start(self, executor: Any) -> list[str]:
        """Start on `executor` (`QueuedJobs.start`), listening for its jobs' progress; on a
        cluster (a server's), the reading children start now rather than at the first upload."""
        from twin.runs.executor import IN_PROCESS

        executor.client.subscribe_topic(self.topic, self._on_report)
        if executor.where != IN_PROCESS:
            self._reader_worker()
        return super().start(executor)

    def shutdown(self, timeout: float = 2.0) -> None:
        super().shutdown(timeout)
        with self._reader_lock:
            reader, self._reader = self._reader, None
        if reader is not None:
            reader.close()

    def _on_report(self, event: tuple[float, dict[str, Any]]) -> None:
        # in the client's event-loop thread: only noted here, stored by the runner's thread
        message = event[1]
        self._progress[message["job"]] = (int(message["done"]), int(message["total"]))

    def _requeue(self) -> list[str]:
        return self.store.requeue_unfinished()

    def _store_cancel(self, job_id: str, reason: str) -> bool:
        return self.store.cancel(job_id, reason)

    def _store_fail(self, job_id: str, error: str) -> None:
        self.store.fail(job_id, error)

    def _work(self, job_id: str, stop: Any) -> None:
        """Run one stored job to the end as a task on the executor, storing its progress while
        it runs, then its result and files."""
        from distributed import Event

        if self.executor is None:
            raise RuntimeError("WorkabilityRunner.start(executor) first")
        if not self.store.running(job_id):  # the attempt counts from here, before any reading
            return  # cancelled before it started
        fields, source, upload = self.store.request(job_id)
        flag = f"{self.topic}-stop-{job_id}"
        future = self.executor.submit(
            evaluate_job, fields, upload if upload is not None else source,
            data_dir=str(self.data_dir), where=self.executor.where, topic=self.topic,
            job=job_id, stop_event=flag, title=source.get("upload"),
        )  # fmt: skip
        try:
            while True:
                if stop():
                    Event(flag, client=self.executor.client).set()
                    raise RuntimeError("stopped while the job ran")
                try:
                    out = future.result(timeout=POLL)
                    break
                except TimeoutError:
                    if job_id in self._progress:
                        self.store.progress(job_id, *self._progress[job_id])
        finally:
            self.executor.cancel([future])
            self._progress.pop(job_id, None)
        self.store.finish(job_id, out["result"], out["files"])

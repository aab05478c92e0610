"""Workability jobs of the REST API: one at a time, on the server's one executor.

`WorkabilityRunner` extends `twin.web.jobs.QueuedJobs`, as `SweepRunner` does: a daemon thread
drives `twin.sim.workability.run_workability` on the server's executor (the workers simulate in
chunks, below single runs' priority; the thread only collects), stores progress (runs done of those
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
import tempfile
from pathlib import Path
from typing import Any

import pandas as pd

from twin.assets import asset_path
from twin.errors import TwinError
from twin.site import SiteRecord, read_record
from twin.web.jobs import POLL as POLL  # [s] the plots' stop poll, one value for both runners
from twin.web.jobs import QueuedJobs, wait_polling
from twin.web.limits import MAX_BODY
from twin.web.workability_store import WorkabilityStore

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


class WorkabilityRunner(QueuedJobs):
    """Workability jobs one at a time from a daemon thread on the server's executor
    (`twin.web.jobs.QueuedJobs`).

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

    def _requeue(self) -> list[str]:
        return self.store.requeue_unfinished()

    def _store_cancel(self, job_id: str, reason: str) -> bool:
        return self.store.cancel(job_id, reason)

    def _store_fail(self, job_id: str, error: str) -> None:
        self.store.fail(job_id, error)

    def _work(self, job_id: str, stop: Any) -> None:
        """Run one stored job to the end, storing progress, result and plots."""
        from twin.sim.workability import WorkabilitySpec, run_workability

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

    def _render(self, result: Any, stop: Any) -> dict[str, bytes]:
        """The plots drawn by a task on the executor, waited for in short steps."""
        if self.executor is None:
            raise RuntimeError("WorkabilityRunner.start(executor) first")
        return wait_polling(self.executor, draw, result, stop, "the plots")

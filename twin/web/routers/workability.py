"""Site workability jobs (issue 28): a record's workability per planner, with its PNG plots.

    GET    /api/workability/records            the shipped records (assets/site)
    POST   /api/workability                    queue a job (202, Location)
    GET    /api/workability/{id}               status, progress, then the result
    GET    /api/workability/{id}/{plot}.png    its plots (monthly, windows, strip, forecast)
    GET    /api/workability/{id}/rows.csv      its per-row table (each record row and planner)
    POST   /api/workability/{id}/cancel        cancel a queued or running job
    DELETE /api/workability/{id}               cancel and forget it

The body is a `WorkabilitySpec` plus the record: `record` (a shipped record's name) or
`record_csv` (an uploaded record's text, read by the CLI's readers; `record_kind` forces the
format, else it is sniffed; `record_name` is the file's name, which the plots' titles show).
Validated as a sweep's body (a 422 naming the field), admitted by the submission rate limit,
then priced and read before it runs (issue 43): the text is scanned for its lines and columns
before any parser sees it, read within a CPU, memory and wall budget in a child process
(`WorkabilityRunner.read`), and the job priced on the rows read (a 422 over `MAX_RUNS` runs,
`MAX_TOTAL_STEPS` steps or `MAX_ROW_WORK` row-headings, naming the limit). A malformed record is
a 422 naming its line; one without a usable row a 422 with the reasons its rows were skipped.
The request answers within `ANSWER_WAIT` (0.7 s) of its body's arrival, whatever it holds: a
reading not done by then goes on within its budget, its job stored queued (202) and run once
read, or failed with the same message as the 422 would have been. The job stores the record's
columns, not its text, and counts against the store's quota.
"""

from __future__ import annotations

import asyncio
import gzip
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Depends, HTTPException, Request, Response
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import FileResponse
from pydantic import Field, ValidationError, ValidationInfo, field_validator, model_validator

from twin.errors import TwinError
from twin.runs import sweep as sweep_module
from twin.runs.workability import WorkabilitySpec
from twin.sim.registries import get_planner
from twin.site.records import READ_KINDS
from twin.web.deps import GUARDED, AdmissionDep, ServicesDep
from twin.web.models import RANGES, RunRequest, _ranges, body_errors, unprocessable
from twin.web.routers.registries import STATIC_DIR
from twin.web.routers.responses import LIMITED, REFUSED, STORE
from twin.web.store import QueueFull, StoreFull
from twin.web.upload_records import DEFAULT_NAME, shipped_records
from twin.web.upload_worker import WorkerBusy
from twin.web.workability_jobs import ANSWER_WAIT, MAX_RECORD_BYTES, WorkabilityRunner
from twin.web.workability_store import ROWS_FILE, Workability

router = APIRouter(prefix="/api/workability", tags=["workability"])
#: the browser page and its script (not in the schema)
pages = APIRouter(include_in_schema=False)

#: most runs (new or cached) one job may need: the sweeps' cap
MAX_RUNS = sweep_module.MAX_RUNS
#: most simulated steps (runs × duration / dt) one job may need: the sweeps' cap
MAX_TOTAL_STEPS = sweep_module.MAX_TOTAL_STEPS
#: the plots a job may have
PLOTS = ("monthly", "windows", "strip", "forecast")
#: most row-headings one job may judge (rows × heading options × planners): the per-row work
#: of its evaluation, summary and table, besides its runs (10 years hourly, best of 12
#: headings, 3 planners, and more)
MAX_ROW_WORK = 4_000_000
#: fields of the body that are not the spec's
RECORD_FIELDS = {"record", "record_csv", "record_kind", "record_name"}


class WorkabilityRequest(WorkabilitySpec):
    """A workability request: the `WorkabilitySpec` fields and the record, by name or text."""

    record: str | None = Field(
        None, description="a shipped record's name (GET /api/workability/records)"
    )
    max_runs: int = Field(
        MAX_RUNS, ge=1, le=MAX_RUNS, description="most runs in all (the server's MAX_RUNS): "
        "more for the grid is a 422; a refinement of the cells that would pass it is not made",
    )  # fmt: skip
    record_csv: str | None = Field(
        None, max_length=MAX_RECORD_BYTES,
        description="an uploaded record's text (NDBC, time-series CSV, scatter CSV or "
        f"forecast), at most {MAX_RECORD_BYTES} characters",
    )  # fmt: skip
    record_kind: Literal["ndbc", "timeseries", "scatter", "forecast"] | None = Field(
        None, description=f"record_csv's format, one of {READ_KINDS}; None: sniffed"
    )
    record_name: str | None = Field(
        None, min_length=1, max_length=100, pattern=r"^[^/\\\x00-\x1f]+$",
        description="record_csv's file name (no folder), shown in the plots' titles; None: "
        f"{DEFAULT_NAME}",
    )  # fmt: skip

    @field_validator("planners")
    @classmethod
    def _known(cls, values: list[str] | None, info: ValidationInfo) -> list[str] | None:
        # located at `planners` (the spec's own check is a whole-body error saying "planner")
        mechanism = info.data.get("mechanism", "hybrid")
        for name in values or []:
            try:
                get_planner(name, mechanism)
            except ValueError as exc:
                raise ValueError(f"planners: {exc}") from None
        return values

    @model_validator(mode="after")
    def _one_record(self) -> WorkabilityRequest:
        if (self.record is None) == (self.record_csv is None):
            raise TwinError("record: give exactly one of record (a shipped record's name) or "
                            "record_csv (an uploaded record's text)")  # fmt: skip
        return self

    def source(self) -> dict[str, Any]:
        """The record to read: `{"name"}` of a shipped one, `{"csv", "kind", "upload"}` of an
        uploaded one (`upload`: its file name)."""
        if self.record is not None:
            return {"name": self.record}
        name = self.record_name if self.record_name not in (None, ".", "..") else DEFAULT_NAME
        return {"csv": self.record_csv, "kind": self.record_kind, "upload": name}

    def spec(self) -> WorkabilitySpec:
        return WorkabilitySpec(**self.model_dump(exclude=RECORD_FIELDS))


RANGES[("POST", "/api/workability")] = _ranges(WorkabilityRequest)


def options(spec: WorkabilitySpec) -> int:
    """Heading options each row is judged at."""
    return 1 if spec.heading.kind == "record" else len(spec.heading.headings)


def price(spec: WorkabilitySpec, rows: int) -> tuple[int, int]:
    """(runs, steps) a job on `rows` rows needs at most: rows × heading options × seeds ×
    planners for `direct`; for `cells`, the grid's cells (Hs × Tp × headings) and the cells its
    refinement may add, × seeds × planners (an upper bound: cells no row falls in, cached
    ones, and cells whose corners agree are not run).

    A refinement halves cells in Hs and Tp, so after `refine_levels` = L its points lie on the
    grid refined 2^L times; and it adds at most 3 points per row, heading option and level
    (the corners of the row's half-cell that are new). It is not made past `max_runs`, so a
    job's runs stay within the grid's or `max_runs`, whichever is more."""
    per_place = spec.seeds * len(spec.planners or [])
    if spec.method == "direct":
        runs = rows * options(spec) * per_place
    else:
        headings = (len(spec.heading_grid) if spec.heading.kind == "record"
                    else len(spec.heading.headings))  # fmt: skip
        hs, tp, levels = len(spec.hs_grid), len(spec.tp_grid), spec.refine_levels
        grid = hs * tp * headings
        lattice = (2**levels * (hs - 1) + 1) * (2**levels * (tp - 1) + 1) * headings
        places = min(lattice, grid + 3 * levels * rows * options(spec))
        runs = min(places * per_place, max(grid * per_place, spec.max_runs))
    return runs, runs * max(round(spec.duration / spec.dt), 1)


def over_limits(spec: WorkabilitySpec, rows: int) -> list[dict[str, Any]]:
    """The limits a job on `rows` rows is over, as 422 errors naming each (empty: it may
    run): its runs, its steps and its row-headings (`MAX_ROW_WORK`)."""
    runs, steps = price(spec, rows)
    what = ("rows × headings × seeds × planners" if spec.method == "direct"
            else "cells × seeds × planners")  # fmt: skip
    errors = []
    work = rows * options(spec) * len(spec.planners or [])
    if work > MAX_ROW_WORK:
        errors.append({
            "loc": ("body", "heading"), "type": "limit_exceeded",
            "msg": f"{work} row-headings ({rows} rows × {options(spec)} headings × planners); "
            f"allowed at most {MAX_ROW_WORK} (MAX_ROW_WORK): fewer headings or planners, or "
            "a shorter record",
        })  # fmt: skip
    if runs > MAX_RUNS:
        errors.append({
            "loc": ("body", "seeds"), "type": "limit_exceeded",
            "msg": f"{runs} runs ({what}); allowed at most {MAX_RUNS} (MAX_RUNS): fewer seeds, "
            "planners or cells, a shorter record, or the cells method",
        })  # fmt: skip
    elif steps > MAX_TOTAL_STEPS:
        errors.append({
            "loc": ("body", "duration"), "type": "limit_exceeded",
            "msg": f"{steps} steps ({runs} runs of duration / dt); allowed at most "
            f"{MAX_TOTAL_STEPS} (MAX_TOTAL_STEPS): shorter runs or fewer runs",
        })  # fmt: skip
    return errors


def stored_record(source: dict[str, Any], summary: dict[str, Any]) -> dict[str, Any]:
    """What a job shows of its record: `{"name"}` of a shipped one, `{"upload", "kind",
    "bytes"}` of an uploaded one (the text itself is not kept)."""
    if "name" in source:
        return {"name": source["name"]}
    return {"upload": source["upload"], "kind": source["kind"] or summary.get("kind"),
            "bytes": len(source["csv"].encode())}  # fmt: skip


def get_runner(services: ServicesDep) -> WorkabilityRunner:
    if services.workability is None:
        raise HTTPException(503, "this server runs no workability jobs")
    return services.workability


Runner = Annotated[WorkabilityRunner, Depends(get_runner)]


@pages.get("/workability")
def page() -> FileResponse:
    """The Workability page (static/workability.html)."""
    return FileResponse(STATIC_DIR / "workability.html")


@pages.get("/workability.js")
def page_script() -> FileResponse:
    return FileResponse(STATIC_DIR / "workability.js", media_type="text/javascript")


@router.get("/records")
def list_records() -> list[str]:
    """Names of the shipped site records (`assets/site/`) a request may give as `record`."""
    return shipped_records()


@router.post("", status_code=202, response_model=Workability, dependencies=GUARDED,
             responses={**LIMITED, 503: {"description": "every reader busy: retry"}})  # fmt: skip
async def create_workability(
    body: WorkabilityRequest,
    request: Request,
    response: Response,
    runner: Runner,
    admission: AdmissionDep,
) -> Any:
    """Queue a workability job: the `WorkabilitySpec` fields plus `record` or `record_csv`.

    Answers 202 once the record is read; poll `GET /api/workability/{id}` (the Location
    header) for status and progress (runs done of those needed) and, once done, the result
    (`WorkabilityResult.to_dict()`: workability per planner and month, the Hs-threshold
    baseline, limiting constraints, weather windows) and the names of its PNG plots. A malformed
    record is a 422 naming its line, one without usable rows a 422 with the reasons; a record
    over `MAX_LINES` lines or `MAX_COLUMNS` columns, or whose reading goes over its budget, and
    a job over `MAX_RUNS` runs, `MAX_TOTAL_STEPS` steps or `MAX_ROW_WORK` row-headings, is a 422
    naming the limit. Jobs share the runs' rate limit, counted before the record is read; at
    most `MAX_PENDING_WORKABILITY` wait at a time.
    """
    ranges = RANGES[("POST", "/api/workability")]
    try:
        RunRequest(**body.scenario)  # the rules of a run's body: no vessel paths
    except ValueError as exc:
        errors = body_errors(exc)
        for e in errors:
            e["loc"] = ("body", "scenario", *e["loc"][1:])
        return unprocessable(errors, ranges)
    try:
        spec = body.spec()
    except ValidationError as exc:
        return unprocessable(body_errors(exc, ranges), ranges)
    store = runner.store
    admission.admit(request, "workability", await run_in_threadpool(store.pending))  # first
    source, fields = body.source(), spec.model_dump(mode="json")
    field = "record" if body.record is not None else "record_csv"
    try:
        reading = runner.read(source, fields)  # the text scan, here; the rest in a child
        read = await asyncio.wait_for(asyncio.shield(asyncio.wrap_future(reading)), ANSWER_WAIT)
    except TimeoutError:
        read = None  # still reading: the job is stored now and runs once it is read
    except WorkerBusy as exc:
        raise HTTPException(503, str(exc), headers={"Retry-After": "2"}) from None
    except TwinError as exc:  # the reader's message names the line; a limit names itself
        return unprocessable([{"loc": ("body", field), "msg": str(exc), "type": "value_error"}],
                             ranges)  # fmt: skip
    if read is not None:
        over = over_limits(spec, int(read["summary"]["rows"]))
        if over:
            return unprocessable(over, ranges)
    try:
        job = await run_in_threadpool(_store_job, runner, admission, spec, source, read, reading)
    except QueueFull as exc:
        raise HTTPException(429, str(exc), headers={"Retry-After": "5"}) from None
    except StoreFull as exc:  # the quota (--max-store, --max-runs): nothing stored
        raise HTTPException(507, str(exc)) from None
    response.headers["Location"] = f"/api/workability/{job.id}"
    return job


def _store_job(
    runner: WorkabilityRunner, admission: Any, spec: WorkabilitySpec, source: dict[str, Any],
    read: dict[str, Any] | None, reading: Any,
) -> Workability:  # fmt: skip
    """Store a job whose record is read (`read`), and queue it; or one still being read
    (`reading`), with the quota held for its text, queued once the reading ends well."""
    store, cap = runner.store, admission.caps["workability"]
    fields = spec.model_dump(mode="json")
    if read is not None:
        rows = int(read["summary"]["rows"])
        job = store.create(fields, stored_record(source, read["summary"]),
                           price(spec, rows)[0], read["blob"], cap)  # fmt: skip
        runner.submit(job.id)
        return job
    text = source.get("csv", "")
    lines = text.count("\n") + 1  # an upper bound of its rows, for the price shown meanwhile
    job = store.create(fields, stored_record(source, {"kind": source.get("kind")}),
                       price(spec, lines)[0], None, cap, reserve=len(text.encode()))  # fmt: skip
    runner.adopt(job.id, reading, lambda rows: (over_limits(spec, rows), price(spec, rows)[0]))
    return job


@router.get("/{job_id}", responses={404: {"description": "no workability job"}, **STORE})
def get_workability(job_id: str, runner: Runner) -> Workability:
    """A job's status and progress and, once done, its result and the names of its plots."""
    return runner.store.get(job_id)


@router.get(
    "/{job_id}/{plot}.png",
    response_class=Response,
    responses={
        200: {"content": {"image/png": {}}, "description": "a plot of the result"},
        404: {"description": "no job, or no such plot for it"},
        409: {"description": "the job is not done"},
        **STORE,
    },
)
def get_workability_plot(job_id: str, plot: str, runner: Runner) -> Response:
    """A done job's plot: `monthly` (bars per month and planner), `windows` (weather-window
    histogram), `strip` (operable / not in time) or `forecast` (a forecast's bars per 3 h
    step and planner)."""
    job = runner.store.get(job_id)
    if plot not in PLOTS:
        raise HTTPException(404, f"no plot {plot!r}; allowed {', '.join(PLOTS)}")
    if job.status != "done":
        raise HTTPException(409, f"workability {job_id} is {job.status}; plots once done")
    if f"{plot}.png" not in job.plots:
        raise HTTPException(404, f"workability {job_id} has no {plot} plot; it has {job.plots}")
    return Response(runner.store.plot(job_id, f"{plot}.png"), media_type="image/png")


@router.get(
    "/{job_id}/rows.csv",
    response_class=Response,
    responses={
        200: {"content": {"text/csv": {}}, "description": "one line per record row and planner"},
        404: {"description": "no job, or a job done before the table was kept"},
        409: {"description": "the job is not done"},
        **STORE,
    },
)
def get_workability_rows(job_id: str, request: Request, runner: Runner) -> Response:
    """A done job's per-row table (`WorkabilityResult.to_csv`): each record row and planner,
    its cell, probability of operable, whether operable and what limited it. Sent gzip-encoded
    to a client that accepts it (as every browser does)."""
    job = runner.store.get(job_id)
    if job.status != "done":
        raise HTTPException(409, f"workability {job_id} is {job.status}; rows.csv once done")
    if not job.rows:
        raise HTTPException(404, f"workability {job_id} has no per-row table; resubmit it")
    packed = runner.store.plot(job_id, ROWS_FILE)
    name = f"workability-{job_id[:8]}-rows.csv"
    headers = {"Content-Disposition": f'attachment; filename="{name}"', "Vary": "Accept-Encoding"}
    if "gzip" in request.headers.get("accept-encoding", ""):
        return Response(packed, media_type="text/csv", headers={**headers,
                        "Content-Encoding": "gzip"})  # fmt: skip
    return Response(gzip.decompress(packed), media_type="text/csv", headers=headers)


_CANCEL = {404: {"description": "no workability job"}, **REFUSED, **STORE}


@router.post("/{job_id}/cancel", dependencies=GUARDED, responses=_CANCEL)
def cancel_workability(job_id: str, runner: Runner) -> Workability:
    """Cancel a queued or running job: it becomes `failed` with `error` "cancelled by
    request"; one running stops after the chunk in hand. A finished job stays as it is."""
    runner.cancel(job_id)
    return runner.store.get(job_id)


@router.delete("/{job_id}", status_code=204, dependencies=GUARDED, responses=_CANCEL)
def delete_workability(job_id: str, runner: Runner) -> Response:
    """Cancel the job if it is queued or running, then delete it with its result and plots."""
    runner.cancel(job_id)  # WorkabilityNotFound: 404
    runner.store.delete(job_id)
    return Response(status_code=204)

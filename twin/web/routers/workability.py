"""Site workability jobs (issue 28): a record's workability per planner, with its PNG plots.

    GET    /api/workability/records            the shipped records (assets/site)
    POST   /api/workability                    queue a job (202, Location)
    GET    /api/workability/{id}               status, progress, then the result
    GET    /api/workability/{id}/{plot}.png    its plots (monthly, windows, strip, forecast)
    POST   /api/workability/{id}/cancel        cancel a queued or running job
    DELETE /api/workability/{id}               cancel and forget it

The body is a `WorkabilitySpec` plus the record: `record` (a shipped record's name) or
`record_csv` (an uploaded record's text, read by the CLI's readers; `record_kind` forces the
format, else it is sniffed). Validated as a sweep's body (a 422 naming the field; a malformed
record is a 422 naming its line), priced before it starts (a 422 over `MAX_RUNS` runs or
`MAX_TOTAL_STEPS` steps, naming the limit), and guarded like every route that changes something.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Depends, HTTPException, Request, Response
from fastapi.responses import FileResponse
from pydantic import Field, ValidationError, ValidationInfo, field_validator, model_validator

from twin.errors import TwinError
from twin.planners import get_planner
from twin.sim import sweep as sweep_module
from twin.sim.workability import WorkabilitySpec
from twin.site import SiteRecord
from twin.site.records import READ_KINDS
from twin.web.deps import GUARDED, AdmissionDep, ServicesDep
from twin.web.models import RANGES, RunRequest, _ranges, body_errors, unprocessable
from twin.web.routers.registries import STATIC_DIR
from twin.web.routers.responses import LIMITED, REFUSED, STORE
from twin.web.store import QueueFull
from twin.web.workability_jobs import (
    MAX_RECORD_BYTES,
    WorkabilityRunner,
    load_record,
    shipped_records,
)
from twin.web.workability_store import Workability

router = APIRouter(prefix="/api/workability", tags=["workability"])
#: the browser page and its script (not in the schema)
pages = APIRouter(include_in_schema=False)

#: most runs (new or cached) one job may need: the sweeps' cap
MAX_RUNS = sweep_module.MAX_RUNS
#: most simulated steps (runs × duration / dt) one job may need: the sweeps' cap
MAX_TOTAL_STEPS = sweep_module.MAX_TOTAL_STEPS
#: the plots a job may have
PLOTS = ("monthly", "windows", "strip", "forecast")
#: fields of the body that are not the spec's
RECORD_FIELDS = {"record", "record_csv", "record_kind"}


class WorkabilityRequest(WorkabilitySpec):
    """A workability request: the `WorkabilitySpec` fields and the record, by name or text."""

    record: str | None = Field(
        None, description="a shipped record's name (GET /api/workability/records)"
    )
    record_csv: str | None = Field(
        None, max_length=MAX_RECORD_BYTES,
        description="an uploaded record's text (NDBC, time-series CSV, scatter CSV or "
        f"forecast), at most {MAX_RECORD_BYTES} characters",
    )  # fmt: skip
    record_kind: Literal["ndbc", "timeseries", "scatter", "forecast"] | None = Field(
        None, description=f"record_csv's format, one of {READ_KINDS}; None: sniffed"
    )

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
        """The record as a job stores it."""
        if self.record is not None:
            return {"name": self.record}
        return {"csv": self.record_csv, "kind": self.record_kind}

    def spec(self) -> WorkabilitySpec:
        return WorkabilitySpec(**self.model_dump(exclude=RECORD_FIELDS))


RANGES[("POST", "/api/workability")] = _ranges(WorkabilityRequest)


def price(spec: WorkabilitySpec, record: SiteRecord) -> tuple[int, int]:
    """(runs, steps) a job needs at most: rows × heading options × seeds × planners for
    `direct`, cells (Hs × Tp × headings) × seeds × planners for `cells` (an upper bound: cells
    no row falls in, and cached ones, are not run)."""
    planners = len(spec.planners or [])
    if spec.method == "direct":
        options = 1 if spec.heading.kind == "record" else len(spec.heading.headings)
        places = record.n * options
    else:
        headings = (len(spec.heading_grid) if spec.heading.kind == "record"
                    else len(spec.heading.headings))  # fmt: skip
        places = len(spec.hs_grid) * len(spec.tp_grid) * headings
    runs = places * spec.seeds * planners
    return runs, runs * max(round(spec.duration / spec.dt), 1)


def over_limits(spec: WorkabilitySpec, record: SiteRecord) -> list[dict[str, Any]]:
    """The limits a job is over, as 422 errors naming each (empty: it may run)."""
    runs, steps = price(spec, record)
    what = ("rows × headings × seeds × planners" if spec.method == "direct"
            else "cells × seeds × planners")  # fmt: skip
    errors = []
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
             responses=LIMITED)  # fmt: skip
def create_workability(
    body: WorkabilityRequest,
    request: Request,
    response: Response,
    runner: Runner,
    admission: AdmissionDep,
) -> Any:
    """Queue a workability job: the `WorkabilitySpec` fields plus `record` or `record_csv`.

    Answers 202 at once; poll `GET /api/workability/{id}` (the Location header) for status and
    progress (runs done of those needed) and, once done, the result (`WorkabilityResult.
    to_dict()`: workability per planner and month, the Hs-threshold baseline, limiting
    constraints, weather windows) and the names of its PNG plots. A malformed record is a 422
    naming its line; a job over `MAX_RUNS` runs or `MAX_TOTAL_STEPS` steps is a 422 naming the
    limit. Jobs share the runs' rate limit; at most `MAX_PENDING_WORKABILITY` wait at a time.
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
        record = load_record(body.source())
    except ValidationError as exc:
        return unprocessable(body_errors(exc, ranges), ranges)
    except TwinError as exc:  # the reader's message names the file's line and column
        field = "record" if body.record is not None else "record_csv"
        return unprocessable([{"loc": ("body", field), "msg": str(exc), "type": "value_error"}],
                             ranges)  # fmt: skip
    over = over_limits(spec, record)
    if over:
        return unprocessable(over, ranges)
    store = runner.store
    admission.admit(request, "workability", store.pending())
    try:
        job = store.create(spec.model_dump(mode="json"), body.source(), price(spec, record)[0],
                           max_pending=admission.caps["workability"])  # fmt: skip
    except QueueFull as exc:
        raise HTTPException(429, str(exc), headers={"Retry-After": "5"}) from None
    runner.submit(job.id)
    response.headers["Location"] = f"/api/workability/{job.id}"
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

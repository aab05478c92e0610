"""Onboard reports (issue 40): a vessel's motion log in, the sea it met, operability now and
heading advice out (`twin.runs.onboard`).

    POST /api/onboard                    upload a log and the report's fields (202, Location)
    GET  /api/onboard/{id}               status, then the report (windows, advice, alerts)
    GET  /api/onboard/{id}/timeline.png  its timeline plot, once done

The body is an `OnboardSpec` plus the log, uploaded as the samples its reader gave
(`twin.motion`): `time` [s] and `motion`, one list per motion present (`surge`, `sway`, `heave`
[m], `roll`, `pitch`, `yaw` in `angles`, rad or deg; heave, roll and pitch required), at most
`twin.web.routers.motion.MAX_SAMPLES` samples, and `start`, the UTC time of t = 0 if known.
The body cap and the pricing are workability's: at most `UPLOAD_BODY` bytes, and the cells
the report may need (every Hs × Tp cell at each heading of the strategy grid, seeds, planners)
within `MAX_RUNS` runs and `MAX_TOTAL_STEPS` steps (`twin.web.routers.workability.over_limits`,
a 422 naming the limit). A submission counts against the workability jobs' cap and rate
(`Admission`, "workability").

The report runs as one task on the server's executor (`twin.runs.onboard.onboard_task`), never
in the process that answers. Jobs are kept in memory, the newest `MAX_JOBS`: a restarted server
forgets them (the cells they ran stay cached in the data dir).
"""

from __future__ import annotations

import threading
import time
import uuid
from datetime import UTC
from typing import Any

import numpy as np
from fastapi import APIRouter, HTTPException, Request, Response
from pydantic import model_validator

from twin.errors import TwinError
from twin.runs.onboard import OnboardSpec, onboard_task
from twin.runs.workability import HeadingStrategy
from twin.web.deps import GUARDED, AdmissionDep, ExecutorDep, ServicesDep
from twin.web.models import RANGES, _ranges, unprocessable
from twin.web.routers.motion import MotionLogBody
from twin.web.routers.responses import LIMITED
from twin.web.routers.workability import over_limits, price

router = APIRouter(prefix="/api/onboard", tags=["onboard"])

#: reports kept in memory (the oldest finished ones go first)
MAX_JOBS = 50
#: [s] the longest sample step: an MRU logs at 1 Hz or faster (5-50 Hz usually)
MAX_STEP = 1.0
#: motions the estimate needs
REQUIRED = ("heave", "roll", "pitch")


class OnboardRequest(OnboardSpec, MotionLogBody):
    """An onboard report's request: the `OnboardSpec` fields and the log's samples
    (`MotionLogBody`: the motion-log upload's, heave, roll and pitch required here)."""

    @model_validator(mode="after")
    def _estimable(self) -> OnboardRequest:
        lacking = [m for m in REQUIRED if m not in self.motion]
        if lacking:
            raise TwinError(f"motion: {lacking} missing; heave, roll and pitch are required")
        return self

    def spec(self) -> OnboardSpec:
        return OnboardSpec(**self.model_dump(include=set(OnboardSpec.model_fields)))


RANGES[("POST", "/api/onboard")] = _ranges(OnboardRequest)


def log_errors(t: np.ndarray, window: float) -> list[dict[str, Any]]:
    """What is wrong with the log's times for a report of `window` [s] windows, as 422 errors
    (empty: nothing): uneven or decreasing steps, steps over `MAX_STEP`, no whole window."""
    steps = np.diff(t)
    step = float(np.median(steps))
    if np.any(steps <= 0) or np.ptp(steps) > 0.01 * step:
        msg = "uniform, strictly increasing sample times are needed; resample the log first"
    elif step > MAX_STEP:
        msg = f"samples {step:g} s apart; at most {MAX_STEP:g} s (1 Hz or faster)"
    elif t[-1] - t[0] + step < window:
        msg = f"{t[-1] - t[0] + step:.0f} s of motion; at least one window of {window:g} s"
    else:
        return []
    return [{"loc": ("body", "time"), "msg": msg, "type": "value_error"}]


def priced(spec: OnboardSpec, windows: int) -> list[dict[str, Any]]:
    """The limits a report on `windows` windows is over (workability's, at the best-of-grid
    strategy that runs every heading's cells)."""
    grid = list(spec.workability.heading_grid)
    best = HeadingStrategy(kind="best", headings=grid)
    cells = spec.workability.model_copy(update={"heading": best})
    return over_limits(cells, windows)


class _Jobs:
    """The app's onboard jobs in memory: id → {status, created, future or result}."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.items: dict[str, dict[str, Any]] = {}

    def pending(self) -> int:
        with self.lock:
            return sum(1 for j in self.items.values() if j["future"] is not None
                       and not j["future"].done())  # fmt: skip

    def add(self, future: Any, runs: int) -> str:
        job_id = uuid.uuid4().hex
        with self.lock:
            done = [k for k, j in self.items.items() if j["future"] is None or j["future"].done()]
            for key in done[: max(0, len(self.items) + 1 - MAX_JOBS)]:
                del self.items[key]
            self.items[job_id] = {"created": time.time(), "future": future, "runs": runs}
        return job_id

    def get(self, job_id: str) -> dict[str, Any]:
        with self.lock:
            job = self.items.get(job_id)
        if job is None:
            raise HTTPException(404, f"no onboard report {job_id!r}")
        return job


def jobs_of(request: Request) -> _Jobs:
    """The app's `_Jobs`, made on first use."""
    state = request.app.state
    with _MAKE:
        if not hasattr(state, "onboard_jobs"):
            state.onboard_jobs = _Jobs()
    return state.onboard_jobs


_MAKE = threading.Lock()


@router.post("", status_code=202, dependencies=GUARDED,
             responses={**LIMITED, 503: {"description": "the executor is not running yet, or "
                                         "the run store's file is gone: retry"}})  # fmt: skip
def create_onboard(
    body: OnboardRequest, request: Request, response: Response, services: ServicesDep,
    executor: ExecutorDep, admission: AdmissionDep,
) -> Any:  # fmt: skip
    """Queue an onboard report of the uploaded log; poll `GET /api/onboard/{id}` (Location).

    A log without heave, roll or pitch, with motions of other lengths, with uneven times,
    samples over 1 s apart or under one window, or a report over the workability limits, is a
    422 saying what is allowed."""
    ranges = RANGES[("POST", "/api/onboard")]
    spec = body.spec()
    t, motion = body.arrays()
    errors = log_errors(t, spec.window)
    windows = int((t[-1] - t[0] + np.median(np.diff(t))) // spec.window)
    errors = errors or priced(spec, windows)
    if errors:
        return unprocessable(errors, ranges)
    jobs = jobs_of(request)
    admission.admit(request, "workability", jobs.pending())
    if executor is None:
        raise HTTPException(503, "the server's executor is not running yet; retry",
                            headers={"Retry-After": "5"})  # fmt: skip
    runner = services.workability
    data_dir = runner.data_dir if runner is not None else services.store.path.parent
    start = None
    if body.start is not None:  # naive times are UTC already; others are converted to it
        utc = body.start.astimezone(UTC) if body.start.tzinfo else body.start
        start = np.datetime64(utc.replace(tzinfo=None), "ns")
    future = executor.submit(onboard_task, t, motion, spec.model_dump(mode="json"),
                             start=None if start is None else str(start),
                             data_dir=str(data_dir), where=executor.where)  # fmt: skip
    job_id = jobs.add(future, price(spec.workability, windows)[0])
    response.headers["Location"] = f"/api/onboard/{job_id}"
    return {"id": job_id, "status": "running", "windows": windows}


@router.get("/{job_id}", responses={404: {"description": "no onboard report"}})
def get_onboard(job_id: str, request: Request) -> dict[str, Any]:
    """A report's status (running, done, failed) and, once done, the report: per window the
    sea, each planner's probability at the current heading, the best heading and the turn to
    it, alerts, the ranked advice and notes (`twin.runs.onboard.OnboardReport`)."""
    job = jobs_of(request).get(job_id)
    out: dict[str, Any] = {"id": job_id, "created": job["created"]}
    future = job["future"]
    if not future.done():
        return out | {"status": "running"}
    try:
        done = future.result()
    except TwinError as exc:  # a refusal of the log itself (no window estimated, …)
        return out | {"status": "failed", "error": str(exc)}
    except Exception as exc:  # a worker's failure: said, never a traceback
        return out | {"status": "failed", "error": f"{type(exc).__name__}: {exc}"}
    return out | {"status": "done", "result": done["result"]}


@router.get("/{job_id}/timeline.png", response_class=Response,
            responses={200: {"content": {"image/png": {}}, "description": "the plot"},
                       404: {"description": "no onboard report"},
                       409: {"description": "the report is not done"}})  # fmt: skip
def get_onboard_timeline(job_id: str, request: Request) -> Response:
    """A done report's timeline plot (Hs, Tp, direction and operability per window)."""
    future = jobs_of(request).get(job_id)["future"]
    if not future.done() or future.status != "finished":
        raise HTTPException(409, f"onboard report {job_id} is not done; its plot once done")
    return Response(future.result()["png"], media_type="image/png")

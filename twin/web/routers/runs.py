"""Scripted runs: submitted to the executor, stored, and their series served."""

from __future__ import annotations

import asyncio
import tempfile
import threading
from concurrent.futures import CancelledError, Future
from pathlib import Path
from typing import Annotated, Any, Literal

from fastapi import APIRouter, HTTPException, Query, Request, Response
from fastapi.responses import JSONResponse
from starlette.concurrency import run_in_threadpool

from twin.web.deps import GUARDED, AdmissionDep, Jobs, ServicesDep, Store
from twin.web.models import RANGES, RunRequest, body_errors, unprocessable
from twin.web.routers.responses import LIMITED, STORE
from twin.web.store import Run

router = APIRouter(prefix="/api/runs", tags=["runs"])

#: [s] how often a waiting request looks whether the server is stopping
POLL = 0.2


class _Stopping(Exception):
    """The server began to stop while a request waited for its run."""


async def _outcome(done: Future[Run], timeout: float, stopping: threading.Event) -> Run | None:
    """The stored run once `done` resolves; None after `timeout` s (still running)."""
    waiting = asyncio.wrap_future(done)
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout
    while True:
        # not `wait_for`: a client hanging up (or a timeout) must not cancel a stored run
        finished, _ = await asyncio.wait({waiting}, timeout=POLL)
        if finished:
            try:
                return waiting.result()
            except (CancelledError, asyncio.CancelledError):
                raise _Stopping from None
        if stopping.is_set():
            raise _Stopping
        if loop.time() > deadline:
            return None


@router.post(
    "",
    status_code=201,
    response_model=Run,
    dependencies=GUARDED,
    responses={
        201: {"description": "the run, done (with metrics) or failed (with its error, e.g. "
              "over the wall-clock budget)"},
        202: {"model": Run, "description": "longer than the synchronous cap, or still waiting "
              "for a worker: queued; poll the Location"},
        **LIMITED,
    },
)  # fmt: skip
async def create_run(
    scenario: RunRequest,
    request: Request,
    response: Response,
    services: ServicesDep,
    store: Store,
    jobs: Jobs,
    admission: AdmissionDep,
) -> Any:
    """Run a scenario (the flat `Scenario` fields; omitted ones take their defaults).

    Up to `jobs.SYNC_MAX_STEPS` steps (duration / dt; 600 s at dt 0.05 s) the answer comes
    when the run is done or failed (201); a run over its wall-clock budget fails with a message.
    Longer runs answer 202 at once; poll `GET /api/runs/{id}` (the Location header) for status
    and progress. A scenario refused before its first step is a 422 and leaves nothing stored.
    Each client may submit `run_burst` runs at once, then `run_rate` per second (429 with
    Retry-After). A server that starts to stop answers a waiting request 503: the run stays
    queued and runs when the server starts again.
    """
    admission.admit(request, "runs", await run_in_threadpool(store.pending))
    run = await run_in_threadpool(store.create, scenario)
    response.headers["Location"] = f"/api/runs/{run.id}"
    done = jobs.submit(run.id)
    if not jobs.is_sync(scenario):
        response.status_code = 202
        return run
    try:
        stored = await _outcome(done, jobs.sync_wait, services.stopping)
    except ValueError as exc:  # input the scenario's own checks let through: refused
        await run_in_threadpool(store.delete, run.id)
        return unprocessable(body_errors(exc, RANGES[("POST", "/api/runs")]),
                             RANGES[("POST", "/api/runs")])  # fmt: skip
    except _Stopping:
        message = f"server stopping: run {run.id} stays queued and runs when it starts again"
        return JSONResponse(
            {"detail": message, "message": message, "id": run.id},
            status_code=503,
            headers={"Location": f"/api/runs/{run.id}", "Retry-After": "10"},
        )
    if stored is None:  # queued behind others for longer than a request waits
        response.status_code = 202
        return await run_in_threadpool(store.get, run.id)
    return stored


@router.get("", responses=STORE)
def list_runs(store: Store, limit: Annotated[int, Query(ge=1, le=500)] = 50) -> list[Run]:
    """The newest runs first, without series."""
    return store.list_runs(limit)


@router.get("/{run_id}", responses={404: {"description": "no run"}, **STORE})
def get_run(run_id: str, store: Store) -> Run:
    """A run's status, progress, scenario and (once done) metrics."""
    return store.get(run_id)


@router.get(
    "/{run_id}/series",
    responses={
        200: {
            "content": {"text/csv": {}, "application/vnd.apache.parquet": {}},
            "description": "json: {scenario, metrics, series: {name: nested lists}}; csv, "
            "parquet: one row per sample, one column per scalar (xi_0 … xi_8)",
        },
        404: {"description": "no run"},
        409: {"description": "the run is not done"},
        **STORE,
    },
)
def get_series(
    run_id: str,
    store: Store,
    fmt: Annotated[Literal["json", "csv", "parquet"], Query(alias="format")] = "json",
) -> Response:
    """A done run's time series, written by `SimulationResult`'s own exporters."""
    run = store.get(run_id)
    if run.status != "done":
        raise HTTPException(409, f"run {run_id} is {run.status}; series exist once done")
    result = store.result(run_id)
    if fmt == "json":
        return JSONResponse(result.to_dict())
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"run-{run_id}.{fmt}"
        (result.to_csv if fmt == "csv" else result.to_parquet)(path)
        content = path.read_bytes()
    media = "text/csv" if fmt == "csv" else "application/vnd.apache.parquet"
    return Response(
        content,
        media_type=media,
        headers={"Content-Disposition": f'attachment; filename="{path.name}"'},
    )


"""Scripted runs: submitted to the executor, stored, and their series served."""

from __future__ import annotations

import asyncio
import json
import threading
import weakref
from collections.abc import Iterator
from concurrent.futures import CancelledError, Future
from typing import Annotated, Any, Literal

from fastapi import APIRouter, HTTPException, Query, Request, Response
from fastapi.responses import JSONResponse, StreamingResponse
from starlette.concurrency import run_in_threadpool

from twin.errors import TwinError
from twin.web import export
from twin.web.deps import GUARDED, AdmissionDep, Jobs, ServicesDep, Store
from twin.web.models import RANGES, RunRequest, body_errors, unprocessable
from twin.web.routers.responses import LIMITED, REFUSED, STORE
from twin.web.store import QueueFull, Run, StoreFull

router = APIRouter(prefix="/api/runs", tags=["runs"])

#: [s] how often a waiting request looks whether the server is stopping
POLL = 0.2
#: series exports streaming at once (each costs a core while it encodes); more answer 429
EXPORT_SLOTS = 2
_exports = threading.BoundedSemaphore(EXPORT_SLOTS)


class _Slot:
    """One export slot, given back once (when its chunks end, or when they are dropped
    without ever being read: a client that went away before the first byte)."""

    def __init__(self) -> None:
        self._held = True
        self._lock = threading.Lock()

    def release(self) -> None:
        with self._lock:
            held, self._held = self._held, False
        if held:
            _exports.release()


def _slot(chunks: Iterator[bytes]) -> Iterator[bytes]:
    """`chunks`, holding an export slot (taken by the caller) until they end, fail, or are
    dropped unread."""
    slot = _Slot()

    def holding() -> Iterator[bytes]:
        try:
            yield from chunks
        finally:
            slot.release()

    generator = holding()
    weakref.finalize(generator, slot.release)
    return generator


class _Stopping(Exception):
    """The server began to stop while a request waited for its run."""


async def _outcome(done: Future[Run], timeout: float, stopping: threading.Event) -> Run | None:
    """The stored run once `done` resolves; None after `timeout` s (still running)."""
    if done.done():  # run on the request's own thread (`JobRunner.run_here`): nothing to await
        if done.cancelled():
            raise _Stopping
        return done.result()
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
    queued and runs when the server starts again. While the server warms up (`/api/health`
    says `warming`) every run answers 202 at once and runs when it is ready.
    """

    def admit_store_and_run() -> tuple[Run, Future[Run] | None]:
        # one trip to the thread pool, not two or three: under load each trip waits for the
        # GIL (issue 30: a 60 s run's POST p50); a short run runs on this same thread
        admission.admit(request, "runs", store.pending())
        run = store.create(scenario, admission.caps["runs"])
        if services.warming:  # stored queued: `Services.attach` runs it once kernels are ready
            return run, None
        return run, jobs.run_here(run.id) if jobs.is_sync(scenario) else jobs.submit(run.id)

    try:
        run, done = await run_in_threadpool(admit_store_and_run)
    except QueueFull as exc:  # the cap, checked with the insert: no race past it
        raise HTTPException(429, str(exc), headers={"Retry-After": "5"}) from None
    except StoreFull as exc:  # the quota (--max-store, --max-runs): nothing stored
        raise HTTPException(507, str(exc)) from None
    response.headers["Location"] = f"/api/runs/{run.id}"
    if done is None or not jobs.is_sync(scenario):
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


#: what cancelling and deleting answer
_CANCEL = {404: {"description": "no run"}, **REFUSED, **STORE}


@router.post("/{run_id}/cancel", dependencies=GUARDED, responses=_CANCEL)
def cancel_run(run_id: str, jobs: Jobs, store: Store) -> Run:
    """Cancel a queued or running run: it becomes `failed` with `error` "cancelled by
    request" (a run already on a worker ends within its budget; its outcome is dropped). A
    finished run stays as it is."""
    jobs.cancel(run_id)
    return store.get(run_id)


@router.post("/{run_id}/pin", dependencies=GUARDED, responses=_CANCEL)
def pin_run(run_id: str, store: Store, pinned: bool = True) -> Run:
    """Keep a run from retention (`twin serve --retain` deletes the oldest finished unpinned
    results when the store is full); `?pinned=false` lets it go again."""
    store.pin("runs", run_id, pinned)
    return store.get(run_id)


@router.delete("/{run_id}", status_code=204, dependencies=GUARDED, responses=_CANCEL)
def delete_run(run_id: str, jobs: Jobs, store: Store) -> Response:
    """Cancel the run if it is queued or running, then delete it with its series."""
    jobs.cancel(run_id)  # RunNotFound: 404
    store.delete(run_id)
    return Response(status_code=204)


@router.get(
    "/{run_id}/series",
    responses={
        200: {
            "content": {"text/csv": {}, "application/vnd.apache.parquet": {}},
            "description": "json: {scenario, metrics, series: {name: nested lists}}; csv, "
            "parquet: one row per sample, one column per scalar (xi_0 … xi_8); streamed",
        },
        404: {"description": "no run"},
        409: {"description": "the run is not done"},
        422: {"description": "an unknown column, every < 1 or t1 < t0"},
        429: {"description": "EXPORT_SLOTS exports are streaming: retry after Retry-After"},
        **STORE,
    },
)
def get_series(
    run_id: str,
    store: Store,
    fmt: Annotated[Literal["json", "csv", "parquet"], Query(alias="format")] = "json",
    columns: Annotated[
        str | None, Query(max_length=1000, description="series to include, comma-separated "
                          "(e.g. t,xi,legs; t always); default all")
    ] = None,
    every: Annotated[int, Query(ge=1, le=1_000_000, description="every n-th sample")] = 1,
    t0: Annotated[float | None, Query(ge=0, allow_inf_nan=False, description="[s] from")] = None,
    t1: Annotated[float | None, Query(ge=0, allow_inf_nan=False, description="[s] to")] = None,
) -> Response:
    """A done run's time series (as `SimulationResult`'s exporters write them), streamed in
    chunks of `export.CHUNK_ROWS` samples read a row group at a time: memory stays bounded by
    the stored (compressed) run and one chunk, not by the size of the answer
    (`export.memory_bound`). `columns`, `t0`/`t1` and `every` select part of a long run."""
    run = store.get(run_id)
    if run.status != "done":
        raise HTTPException(409, f"run {run_id} is {run.status}; series exist once done")
    names = None if columns is None else [c.strip() for c in columns.split(",") if c.strip()]
    try:
        scenario, metrics, blob = store.series_blob(run_id)
        series = export.Series(blob, names).select(t0, t1, every)
    except TwinError as exc:
        field = "columns" if str(exc).startswith("columns") else str(exc).split(":", 1)[0]
        return unprocessable(
            [{"loc": ["query", field], "msg": str(exc), "type": "value_error"}], {}
        )
    name = f"run-{run_id}.{fmt}"
    if not _exports.acquire(blocking=False):
        raise HTTPException(
            429, f"{EXPORT_SLOTS} series exports are streaming; retry in a few seconds",
            headers={"Retry-After": "5"},
        )  # fmt: skip
    if fmt == "json":
        chunks = export.json_chunks(scenario, metrics, series)
        return StreamingResponse(_slot(chunks), media_type="application/json")
    if fmt == "csv":
        chunks, media = export.csv_chunks(series), "text/csv"
    else:
        chunks = export.parquet_chunks(json.dumps(scenario), metrics, series)
        media = "application/vnd.apache.parquet"
    return StreamingResponse(
        _slot(chunks), media_type=media,
        headers={"Content-Disposition": f'attachment; filename="{name}"'},
    )  # fmt: skip


"""The REST API: registries, scripted runs, sweeps and the live session; OpenAPI at `/docs`.

`create_app` wires the routers of `twin.web.routers` (registries, runs, sweeps, live) to the
services they take as dependencies (`twin.web.deps`): the live session, the run store, the
runners of runs and sweeps on the one executor, and the access policy.

Every request's Host must name the server (`twin.web.access`); mutating ones (POST, PATCH)
take `Authorization: Bearer <token>` when the app has a token, and refuse browser requests
from any origin but the server's own: no CORS headers are sent, so other sites can neither
read answers nor drive the twin. Bad input is a 422 whose `detail` lists each field (`loc`),
what is wrong (`msg`) and, for scenario and live fields, the `allowed` range; `message` says
the same in one line; a refused request changes nothing. No endpoint takes a path: a vessel is
one of the shipped RAO tables by name. A body over `limits.MAX_BODY` is a 413; run and sweep
submissions are rate-limited per client and capped while queued (429). A run store whose file
was deleted or replaced answers 503.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.concurrency import run_in_threadpool

import twin
from twin.sim.executor import IN_PROCESS, Executor
from twin.sim.live import LiveSession
from twin.web import routers
from twin.web.access import Access, Guard
from twin.web.deps import (
    MAX_PENDING_RUNS,
    MAX_PENDING_SWEEPS,
    RUN_BURST,
    RUN_RATE,
    Admission,
    Services,
)
from twin.web.jobs import JobRunner, SweepRunner
from twin.web.limits import MAX_BODY, BodyLimit
from twin.web.models import (
    LIVE_FIELDS,
    RANGES,
    Health,
    LivePatch,
    LiveState,
    Registries,
    RunRequest,
    locate,
    unprocessable,
)
from twin.web.routers.registries import STATIC_DIR
from twin.web.store import RunNotFound, RunStore, StoreUnavailable

__all__ = [
    "LIVE_FIELDS",
    "MAX_PENDING_RUNS",
    "MAX_PENDING_SWEEPS",
    "RANGES",
    "RUN_BURST",
    "RUN_RATE",
    "STATIC_DIR",
    "Health",
    "LivePatch",
    "LiveState",
    "RunRequest",
    "create_app",
]


def create_app(
    session: LiveSession,
    store: RunStore,
    *,
    access: Access | None = None,
    executor: Executor | None = None,
    jobs: JobRunner | None = None,
    sweeps: SweepRunner | None = None,
    viewer_port: int | None = None,
    run_rate: float = RUN_RATE,
    run_burst: int = RUN_BURST,
    max_pending_runs: int = MAX_PENDING_RUNS,
    max_pending_sweeps: int = MAX_PENDING_SWEEPS,
    max_body: int = MAX_BODY,
) -> FastAPI:
    """The REST app over a live session and a run store.

    Args:
        session: the live session `/api/live` reads and patches (started or not).
        store: where runs and sweeps are stored.
        access: who may talk to it (`Access.for_server` of the server's bind address and
            ports, with its token); default: loopback names only, no token, and no browser
            origin trusted for mutations.
        executor: where runs and sweeps execute; the caller keeps it (a server starts it once
            and closes it after the app). None: the app starts an in-process one with its
            lifespan and closes it at shutdown.
        jobs: the runner of scripted runs (default: a `JobRunner` on `store`); started on the
            executor and shut down with the app.
        sweeps: the runner of operability sweeps (default: a `SweepRunner` on `store`); the
            same.
        viewer_port: the 3D viewer's port, shown by `/api/health` and the landing page.
        run_rate: [1/s] sustained run and sweep submissions per client address (429 beyond).
        run_burst: submissions a client may make at once.
        max_pending_runs: runs queued or running at most (429 beyond, until some finish).
        max_pending_sweeps: sweeps queued or running at most.
        max_body: [bytes] largest request body (413 beyond).

    Returns:
        The FastAPI app (serve it with uvicorn); `app.state.services` holds what it runs on,
        `services.stopping` is set when it starts to shut down.
    """
    services = Services(
        session=session,
        store=store,
        jobs=jobs if jobs is not None else JobRunner(store),
        sweeps=sweeps if sweeps is not None else SweepRunner(store),
        access=access if access is not None else Access(),
        admission=Admission(run_rate, run_burst, max_pending_runs, max_pending_sweeps),
        registries=Registries.build(),
        viewer_port=viewer_port,
    )

    @asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        own = None
        if executor is None:
            own = await run_in_threadpool(Executor.start, IN_PROCESS)
        services.executor = executor if executor is not None else own
        services.stopping.clear()
        await run_in_threadpool(services.jobs.start, services.executor)
        await run_in_threadpool(services.sweeps.start, services.executor)
        try:
            yield
        finally:
            services.stopping.set()
            await run_in_threadpool(services.sweeps.shutdown)
            await run_in_threadpool(services.jobs.shutdown)
            if own is not None:
                await run_in_threadpool(own.close)

    app = FastAPI(
        title="wave-twin",
        version=twin.__version__,
        summary="Digital twin of offshore wave-motion compensation: runs and the live session",
        lifespan=lifespan,
    )
    app.state.services = services
    app.add_middleware(BodyLimit, max_bytes=max_body)
    # the outermost: refused before anything is read
    app.add_middleware(Guard, access=services.access)

    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        ranges = RANGES.get((request.method, request.url.path), {})
        return unprocessable(locate(list(exc.errors()), ranges), ranges)

    @app.exception_handler(RunNotFound)
    async def _not_found(_: Request, exc: RunNotFound) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=404)

    @app.exception_handler(StoreUnavailable)
    async def _unavailable(_: Request, exc: StoreUnavailable) -> JSONResponse:
        return JSONResponse({"detail": str(exc), "message": str(exc)}, status_code=503)

    for module in (routers.registries, routers.runs, routers.sweeps, routers.live):
        app.include_router(module.router)
    return app

"""The REST API: registries, scripted runs, sweeps and the live session; OpenAPI at `/docs`.

`/docs` (Swagger UI) and `/redoc` load their scripts and styles from this server, out of the
installed `fastapi-offline` package, never from a CDN: they render on a machine without
internet access.

`create_app` wires the routers of `twin.web.routers` (registries, runs, sweeps, live) to the
services they take as dependencies (`twin.web.deps`): the live session, the run store, the
runners of runs and sweeps on the one executor, and the access policy.

Every request's Host must name the server (`twin.web.access`); mutating ones (POST, PATCH)
take `Authorization: Bearer <token>` when the app has a token, and refuse browser requests
from any origin but the server's own: no CORS headers are sent, so other sites can neither
read answers nor drive the twin. Bad input is a 422 whose `detail` lists each field (`loc`),
what is wrong (`msg`) and, for scenario and live fields, the `allowed` range; `message` says
the same in one line; a refused request changes nothing. No endpoint takes a path: a vessel is
one of the shipped RAO tables by name. A body over `limits.MAX_BODY` (a site record's upload:
`workability_jobs.UPLOAD_BODY`) is a 413; run and sweep
submissions are rate-limited per client and capped while queued (429). A run store whose file
was deleted or replaced answers 503.
"""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator, Callable
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from pathlib import Path

import fastapi_offline
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.openapi.docs import (
    get_redoc_html,
    get_swagger_ui_html,
    get_swagger_ui_oauth2_redirect_html,
)
from fastapi.responses import HTMLResponse, JSONResponse
from fastapi.staticfiles import StaticFiles
from starlette.concurrency import run_in_threadpool

import twin
from twin.db import StoreUnavailable
from twin.runs.executor import IN_PROCESS, Executor
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
from twin.web.routers import motion as motion_routes
from twin.web.routers import onboard as onboard_routes
from twin.web.routers.registries import STATIC_DIR
from twin.web.store import RunNotFound, RunStore
from twin.web.warmup import Warmup
from twin.web.workability_jobs import UPLOAD_BODY, WorkabilityRunner
from twin.web.workability_store import WorkabilityStore

log = logging.getLogger(__name__)

#: Swagger UI's and ReDoc's files, as the `fastapi-offline` package ships them
DOCS_ASSETS = Path(fastapi_offline.__file__).resolve().parent / "static"
#: where the app serves them
DOCS_STATIC = "/docs-static"
#: the docs pages may load nothing from elsewhere (ReDoc would fetch its vendor's logo)
DOCS_POLICY = (
    "default-src 'self'; script-src 'self' 'unsafe-inline'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data:; font-src 'self' data:; worker-src 'self' blob:; connect-src 'self'"
)

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
    session: LiveSession | None,
    store: RunStore,
    *,
    access: Access | None = None,
    executor: Executor | None = None,
    jobs: JobRunner | None = None,
    sweeps: SweepRunner | None = None,
    workability: WorkabilityRunner | None = None,
    viewer_port: int | None = None,
    run_rate: float = RUN_RATE,
    run_burst: int = RUN_BURST,
    max_pending_runs: int = MAX_PENDING_RUNS,
    max_pending_sweeps: int = MAX_PENDING_SWEEPS,
    max_body: int = MAX_BODY,
    warmup: Warmup | None = None,
) -> FastAPI:
    """The REST app over a live session and a run store.

    Args:
        session: the live session `/api/live` reads and patches (started or not); None with
            `warmup`, until the server attaches it (`Services.attach`).
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
        workability: the runner of site-workability jobs (default: a `WorkabilityRunner` on
            the store's file, its cell cache in the store's folder); the same.
        viewer_port: the 3D viewer's port, shown by `/api/health` and the landing page.
        run_rate: [1/s] sustained run and sweep submissions per client address (429 beyond).
        run_burst: submissions a client may make at once.
        max_pending_runs: runs queued or running at most (429 beyond, until some finish).
        max_pending_sweeps: sweeps queued or running at most.
        max_body: [bytes] largest request body (413 beyond).
        warmup: a server still starting up (`twin.web.warmup`): the app answers at once, the
            live routes 503 and runs queue until `services.attach(session, executor)`; the
            app then neither starts nor closes an executor of its own.

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
        warmup=warmup,
        workability=workability if workability is not None
        else WorkabilityRunner(WorkabilityStore(store.path, store.quota)),
    )
    app = FastAPI(
        title="wave-twin",
        version=twin.__version__,
        summary="Digital twin of offshore wave-motion compensation: runs and the live session",
        lifespan=_lifespan(services, executor, warmup),
        docs_url=None,  # served below from local files
        redoc_url=None,
    )
    _offline_docs(app)
    app.state.services = services
    _add_middleware(app, services.access, max_body)
    _add_exception_handlers(app)
    _add_routers(app)
    return app


def _lifespan(
    services: Services, executor: Executor | None, warmup: Warmup | None
) -> Callable[[FastAPI], AbstractAsyncContextManager[None]]:
    """The app's lifespan: at start-up (unless a server still `warmup`s, which attaches its
    executor later) the runners start on `executor`, or on an in-process one the app starts
    and so closes; at shutdown `services.stopping` is set and the runners shut down."""

    @asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        own: Executor | None = None  # an executor this app started, and so closes
        services.stopping.clear()
        if warmup is None:
            running = executor
            if running is None:
                running = own = await run_in_threadpool(Executor.start, IN_PROCESS)
            services.executor = running
            await run_in_threadpool(services.jobs.start, running)
            await run_in_threadpool(services.sweeps.start, running)
            if services.workability is not None:
                await run_in_threadpool(services.workability.start, running)
        try:
            yield
        finally:
            services.stopping.set()
            # runs first (what most clients wait on), and each runner whatever another raised:
            # one that fails to stop must not leave the others' jobs marked running
            stops: list[Callable[[], None]] = [services.jobs.shutdown, services.sweeps.shutdown]
            if services.workability is not None:
                stops.append(services.workability.shutdown)
            for stop in stops:
                try:
                    await run_in_threadpool(stop)
                except Exception:
                    log.exception("%s failed", getattr(stop, "__qualname__", stop))
            if own is not None:
                await run_in_threadpool(own.close)

    return lifespan


def _add_middleware(app: FastAPI, access: Access, max_body: int) -> None:
    """The body limit, then, outermost, the access guard (Host, token, origin)."""
    # an upload (a site record, a motion log) takes more than a scenario; the rest keep max_body
    app.add_middleware(
        BodyLimit,
        max_bytes=max_body,
        route_limits={
            ("POST", "/api/workability"): max(UPLOAD_BODY, max_body),
            ("POST", "/api/onboard"): max(UPLOAD_BODY, max_body),
            ("POST", "/api/motion-logs"): max(UPLOAD_BODY, max_body),
            ("POST", "/api/motion-logs/file"): max(UPLOAD_BODY, max_body),
        },
    )
    # the outermost: refused before anything is read
    app.add_middleware(Guard, access=access)


def _add_exception_handlers(app: FastAPI) -> None:
    """Bad input is a 422 naming each field and its allowed range; an unknown run a 404; a
    store whose file was deleted or replaced a 503."""

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


def _add_routers(app: FastAPI) -> None:
    """The routers of `twin.web.routers`, then the Workability page."""
    for module in (routers.registries, routers.runs, routers.sweeps, routers.workability,
                   routers.live):  # fmt: skip
        app.include_router(module.router)
    app.include_router(onboard_routes.router)  # issue 40: onboard reports of motion logs
    app.include_router(motion_routes.router)  # issue 40: stored motion logs
    app.include_router(routers.workability.pages)  # the Workability page


def _offline_docs(app: FastAPI) -> None:
    """`/docs` and `/redoc` with their assets served by the app itself (FastAPI's "self-hosting
    JavaScript and CSS for docs"), so they render offline; a Content-Security-Policy keeps
    them from loading anything from elsewhere."""
    app.mount(DOCS_STATIC, StaticFiles(directory=DOCS_ASSETS), name="docs-static")
    openapi_url = app.openapi_url or "/openapi.json"
    redirect = app.swagger_ui_oauth2_redirect_url or "/docs/oauth2-redirect"

    def local(page: HTMLResponse) -> HTMLResponse:
        page.headers["Content-Security-Policy"] = DOCS_POLICY
        return page

    @app.get("/docs", include_in_schema=False)
    def swagger_ui() -> HTMLResponse:
        return local(get_swagger_ui_html(
            openapi_url=openapi_url,
            title=f"{app.title} - Swagger UI",
            oauth2_redirect_url=redirect,
            swagger_js_url=f"{DOCS_STATIC}/swagger-ui-bundle.js",
            swagger_css_url=f"{DOCS_STATIC}/swagger-ui.css",
            swagger_favicon_url=f"{DOCS_STATIC}/favicon.png",
            # no badge that asks an online validator about the schema
            swagger_ui_parameters={"validatorUrl": None},
        ))

    @app.get(redirect, include_in_schema=False)
    def swagger_ui_redirect() -> HTMLResponse:
        return get_swagger_ui_oauth2_redirect_html()

    @app.get("/redoc", include_in_schema=False)
    def redoc() -> HTMLResponse:
        return local(get_redoc_html(
            openapi_url=openapi_url,
            title=f"{app.title} - ReDoc",
            redoc_js_url=f"{DOCS_STATIC}/redoc.standalone.js",
            redoc_favicon_url=f"{DOCS_STATIC}/favicon.png",
            with_google_fonts=False,
        ))

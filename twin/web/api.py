"""The REST API: registries, scripted runs and the live session; OpenAPI at `/docs`.

Read-only endpoints are open. Mutating ones (POST, PATCH) take `Authorization: Bearer <token>`
when the app has a token, and refuse browser requests from another origin: no CORS headers
are sent, so other sites can neither read answers nor drive the twin. Bad input is a 422
whose `detail` lists each field (`loc`), what is wrong (`msg`) and, for scenario and live
fields, the `allowed` range; `message` says the same in one line. No endpoint takes a path:
a vessel is one of the shipped RAO tables by name. A body over `limits.MAX_BODY` is a 413;
run and sweep submissions are rate-limited per client and capped while queued (429).
"""

from __future__ import annotations

import asyncio
import math
import tempfile
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Annotated, Any, Literal

from fastapi import Depends, FastAPI, HTTPException, Query, Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse
from fastapi.security import HTTPBearer
from pydantic import BaseModel, ConfigDict, Field, ValidationError, create_model
from starlette.concurrency import run_in_threadpool

import twin
from twin.mechanisms import MECHANISMS
from twin.planners import PLANNERS, PlannerParameters
from twin.sea.sea_states import WMO_SEA_STATES
from twin.sim import Scenario
from twin.sim.live import LiveControls, LiveSession
from twin.sim.scenario import DEFAULT_PLANNER
from twin.sim.sweep import AXES, SweepSpec
from twin.vessel.rao import available_raos
from twin.web.access import Guard
from twin.web.jobs import JobRunner, SweepRunner
from twin.web.limits import MAX_BODY, BodyLimit, RateLimit
from twin.web.store import Run, RunNotFound, RunStore, Sweep

_HERE = Path(__file__).resolve().parent
#: the landing page: `twin/_static` in a wheel (pyproject `force-include`), else the
#: repository's `static/` (a checkout or editable install)
STATIC_DIR: Path = next(
    (p for p in (_HERE.parent / "_static", _HERE.parents[1] / "static") if p.is_dir()),
    _HERE.parents[1] / "static",
)

# -- response models -------------------------------------------------------------------------


class Health(BaseModel):
    """The server is up."""

    status: Literal["ok"] = "ok"
    version: str = Field(description="wave-twin version")
    viewer_port: int | None = Field(description="port of the 3D viewer on this host, if any")


class MechanismInfo(BaseModel):
    """A mechanism of `twin.mechanisms.MECHANISMS` and the planners it can run."""

    name: str = Field(description="registry name, the scenario's `mechanism`")
    description: str
    state_size: int = Field(description="values in the scenario's `initial_state`")
    default_planner: str
    planners: list[str] = Field(description="planners that plan for it")


class PlannerInfo(BaseModel):
    """A planner of `twin.planners.PLANNERS` and the knobs it reads."""

    name: str = Field(description="registry name, the scenario's `planner`")
    title: str
    mechanisms: list[str]
    source: str = Field(description="paper and equations")
    default_for: list[str] = Field(description="mechanisms that use it when none is named")
    parameters: dict[str, dict[str, Any]] = Field(
        description="the scenario fields it reads, each with default, range and unit "
        "(JSON schema of PlannerParameters)"
    )


class SeaStateInfo(BaseModel):
    """A row of WMO code table 3700 with its representative sea."""

    code: int = Field(description="WMO sea-state code, the scenario's `sea_state`")
    description: str
    hs_min: float = Field(description="[m] lower bound of the code's Hs range")
    hs_max: float | None = Field(description="[m] upper bound; null: open (code 9)")
    hs: float = Field(description="[m] representative significant wave height")
    tp: float = Field(description="[s] representative peak period (fully developed sea)")


# -- request models ----------------------------------------------------------------------------

#: [1/s] sustained run (and sweep) submissions per client, and how many at once
RUN_RATE = 5.0
RUN_BURST = 20
#: most runs, and sweeps, queued or running at a time; more are refused until some finish
MAX_PENDING_RUNS = 200
MAX_PENDING_SWEEPS = 4

#: the shipped RAO tables: over REST a vessel is named, never a path (a path would let a
#: request make the server open any file it can read)
VesselName = Literal[tuple(available_raos())]


class RunRequest(Scenario):
    """A scenario as a request gives it: the `Scenario` fields, `vessel` by name only."""

    vessel: VesselName | None = Field(  # type: ignore[valid-type]
        None,
        description="shipped RAO table by name (assets/vessels); default: the mechanism's "
        "mount. Your own .nc table is loaded from Python (`Scenario(vessel=path)`), not REST.",
    )


# -- live models: the scenario's fields, flat, plus the session's controls ---------------------

#: Scenario fields the live session exposes (`duration` means nothing live).
LIVE_FIELDS = tuple(
    name for name in Scenario.model_fields if name not in {"duration", *LiveControls.model_fields}
)


def _optional(model: type[BaseModel], name: str) -> tuple[Any, Any]:
    """(annotation, field) of `model.name` made optional, its range kept."""
    info = model.model_fields[name]
    annotation = Annotated[info.annotation, *info.metadata] if info.metadata else info.annotation
    return annotation | None, Field(None, description=info.description)


LivePatch = create_model(
    "LivePatch",
    __config__=ConfigDict(extra="forbid", allow_inf_nan=False),
    __doc__="Fields to change in the live session; omitted fields stay as they are.",
    **{name: _optional(RunRequest, name) for name in LIVE_FIELDS},
    **{name: _optional(LiveControls, name) for name in LiveControls.model_fields},
)

LiveState = create_model(
    "LiveState",
    __doc__="The live session: its scenario fields, flat, with time, controls and metrics.",
    **{
        name: (info.annotation, Field(description=info.description))
        for name, info in Scenario.model_fields.items()
        if name in LIVE_FIELDS
    },
    t=(float, Field(description="[s] simulated time")),
    **{
        name: (info.annotation, Field(description=info.description))
        for name, info in LiveControls.model_fields.items()
    },
    metrics=(dict[str, Any], Field(description="metrics over the live history")),
    faults=(
        dict[str, Any],
        Field(
            description="numerical faults since the last (re)start: `counts` per kind "
            "(base_motion, planner, kinematics: the step was held; joint_limit: shortened at a "
            "limit; singular: damped), `held` steps, the newest `events` (t, kinds, message) "
            "and `loop_errors`"
        ),
    ),
)

# -- errors ------------------------------------------------------------------------------------


#: JSON-schema bound → how it reads on either side of the field's name
_LOWER = {"minimum": "≤", "exclusiveMinimum": "<"}
_UPPER = {"maximum": "≤", "exclusiveMaximum": "<"}


def _allowed(name: str, schema: dict[str, Any]) -> str:
    """A field's allowed values from its JSON schema, e.g. `0 ≤ beta ≤ 1 or null`."""
    parts = []
    for branch in schema.get("anyOf", [schema]):
        if "enum" in branch:
            parts.append("one of " + ", ".join(f"{v!r}" for v in branch["enum"]))
            continue
        low = "".join(f"{branch[k]:g} {op} " for k, op in _LOWER.items() if k in branch)
        high = "".join(f" {op} {branch[k]:g}" for k, op in _UPPER.items() if k in branch)
        parts.append(f"{low}{name}{high}" if low or high else branch.get("type", "any"))
    return " or ".join(parts)


def _ranges(*models: type[BaseModel]) -> dict[str, str]:
    """Field name → allowed values of every field of the models."""
    ranges: dict[str, str] = {}
    for model in models:
        for name, schema in model.model_json_schema()["properties"].items():
            ranges[name] = _allowed(name, schema)
    return ranges


#: allowed values per body field, by the endpoint that receives the body
RANGES = {
    ("POST", "/api/runs"): _ranges(RunRequest),
    ("PATCH", "/api/live"): _ranges(RunRequest, LiveControls),
    ("POST", "/api/sweeps"): _ranges(SweepSpec),
}


def unprocessable(
    errors: list[dict[str, Any]], ranges: dict[str, str], **extra: Any
) -> JSONResponse:
    """A 422 listing every error with its field, message and allowed values.

    Args:
        errors: pydantic-style errors (`loc`, `msg`, `type`); the request's input is not
            echoed back (it may be large, or NaN, which JSON cannot carry).
        ranges: field name → allowed values, for body fields.
        extra: more top-level keys of the answer.
    """
    detail, lines = [], []
    for error in errors:
        loc = list(error["loc"])
        item = {"loc": loc, "msg": error["msg"], "type": error["type"]}
        field = loc[1] if len(loc) > 1 and loc[0] == "body" else None
        if field in ranges:
            item["allowed"] = ranges[field]
        detail.append(item)
        name = ".".join(map(str, loc[1:] or loc))
        lines.append(f"{name}: {error['msg']}" + (f" (allowed: {item['allowed']})"
                                                  if "allowed" in item else ""))  # fmt: skip
    return JSONResponse({"detail": detail, "message": "; ".join(lines), **extra}, status_code=422)


def _body_errors(exc: ValueError) -> list[dict[str, Any]]:
    """A model's ValidationError or a TwinError as errors located in the request body."""
    if isinstance(exc, ValidationError):
        return [
            {"loc": ("body", *e["loc"]), "msg": e["msg"], "type": e["type"]} for e in exc.errors()
        ]
    return [{"loc": ("body",), "msg": str(exc), "type": "value_error"}]


# -- the app -----------------------------------------------------------------------------------


def _registries() -> tuple[list[MechanismInfo], list[PlannerInfo], list[SeaStateInfo]]:
    """The read-only registries as response models, built once per app."""
    schema = PlannerParameters.model_json_schema()["properties"]
    mechanisms = [
        MechanismInfo(
            name=name,
            description=(cls.__doc__ or name).strip().splitlines()[0],
            state_size=cls().working_state.size,
            default_planner=DEFAULT_PLANNER[name],
            planners=[p for p, spec in PLANNERS.items() if name in spec.mechanisms],
        )
        for name, cls in MECHANISMS.items()
    ]
    planners = [
        PlannerInfo(
            name=spec.name,
            title=spec.title,
            mechanisms=list(spec.mechanisms),
            source=spec.source,
            default_for=[m for m, p in DEFAULT_PLANNER.items() if p == spec.name],
            parameters={
                p: {k: v for k, v in schema[p].items() if k != "title"} for p in spec.parameters
            },
        )
        for spec in PLANNERS.values()
    ]
    sea_states = [
        SeaStateInfo(
            code=s.code,
            description=s.description,
            hs_min=s.hs_min,
            hs_max=s.hs_max if s.hs_max != float("inf") else None,
            hs=s.hs,
            tp=s.tp,
        )
        for s in WMO_SEA_STATES
    ]
    return mechanisms, planners, sea_states


#: declares the token in the OpenAPI schema; `access.Guard` checks it before a body is read
_BEARER = HTTPBearer(
    auto_error=False,
    description="required on POST and PATCH when the server runs with a token (TWIN_TOKEN)",
)


def create_app(
    session: LiveSession,
    store: RunStore,
    *,
    token: str | None = None,
    jobs: JobRunner | None = None,
    sweeps: SweepRunner | None = None,
    viewer_port: int | None = None,
    run_rate: float = RUN_RATE,
    run_burst: int = RUN_BURST,
    max_pending_runs: int = MAX_PENDING_RUNS,
    max_body: int = MAX_BODY,
) -> FastAPI:
    """The REST app over a live session and a run store.

    Args:
        session: the live session `/api/live` reads and patches (started or not).
        store: where runs are stored.
        token: if set, POST and PATCH need `Authorization: Bearer <token>`.
        jobs: the runner of scripted runs (default: a `JobRunner` on `store`); started and
            shut down with the app.
        sweeps: the runner of operability sweeps (default: a `SweepRunner` on `store`, a
            Dask LocalCluster per sweep); started and shut down with the app.
        viewer_port: the 3D viewer's port, shown by `/api/health` and the landing page.
        run_rate: [1/s] sustained run and sweep submissions per client address (429 beyond).
        run_burst: submissions a client may make at once.
        max_pending_runs: runs queued or running at most (429 beyond, until some finish).
        max_body: [bytes] largest request body (413 beyond).

    Returns:
        The FastAPI app (serve it with uvicorn).
    """
    jobs = jobs if jobs is not None else JobRunner(store)
    sweeps = sweeps if sweeps is not None else SweepRunner(store)
    mechanisms, planners, sea_states = _registries()

    @asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        await run_in_threadpool(jobs.start)
        await run_in_threadpool(sweeps.start)
        yield
        sweeps.shutdown()
        jobs.shutdown()

    app = FastAPI(
        title="wave-twin",
        version=twin.__version__,
        summary="Digital twin of offshore wave-motion compensation: runs and the live session",
        lifespan=lifespan,
    )
    app.add_middleware(BodyLimit, max_bytes=max_body)
    app.add_middleware(Guard, token=token)  # the outermost: refused before anything is read
    guarded = [Depends(_BEARER)]
    refused: dict[int | str, dict[str, Any]] = {
        400: {"description": "a body that is not UTF-8 JSON text, or a bad Content-Length"},
        401: {"description": "missing or wrong token (the server has one)"},
        403: {"description": "a browser request from another origin"},
        413: {"description": f"body over {max_body} bytes"},
    }
    bad_input = {
        **refused,
        422: {"description": "bad input: each field, its problem and allowed range"},
    }
    limited = {
        **bad_input,
        429: {"description": "too many submissions from this client, or the queue is full: "
              "retry after the Retry-After header's seconds"},
    }  # fmt: skip
    submissions = RateLimit(run_rate, run_burst)

    def admit(request: Request, pending: int, cap: int, what: str) -> None:
        """429 unless this client may submit now and the queue has room."""
        client = request.client.host if request.client else "unknown"
        wait = submissions.acquire(client)
        if wait > 0:
            raise HTTPException(
                429,
                f"too many submissions from {client}: at most {run_burst} at once, then "
                f"{run_rate:g} per second; retry in {wait:.1f} s",
                headers={"Retry-After": str(math.ceil(wait))},
            )
        if pending >= cap:
            raise HTTPException(
                429,
                f"{pending} {what} queued or running (at most {cap}); retry once some finish",
                headers={"Retry-After": "5"},
            )

    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        ranges = RANGES.get((request.method, request.url.path), {})
        return unprocessable(list(exc.errors()), ranges)

    @app.exception_handler(RunNotFound)
    async def _not_found(_: Request, exc: RunNotFound) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=404)

    @app.get("/", include_in_schema=False)
    def index() -> FileResponse:
        return FileResponse(STATIC_DIR / "index.html")

    @app.get("/api/health", tags=["registries"])
    def health() -> Health:
        return Health(version=twin.__version__, viewer_port=viewer_port)

    @app.get("/api/mechanisms", tags=["registries"])
    def list_mechanisms() -> list[MechanismInfo]:
        return mechanisms

    @app.get("/api/planners", tags=["registries"])
    def list_planners() -> list[PlannerInfo]:
        return planners

    @app.get("/api/sea-states", tags=["registries"])
    def list_sea_states() -> list[SeaStateInfo]:
        return sea_states

    # -- runs ------------------------------------------------------------------------------
    @app.post(
        "/api/runs",
        status_code=201,
        response_model=Run,
        dependencies=guarded,
        tags=["runs"],
        responses={
            202: {"model": Run, "description": "longer than the synchronous cap: queued"},
            **limited,
        },
    )
    async def create_run(scenario: RunRequest, request: Request, response: Response) -> Any:
        """Run a scenario (the flat `Scenario` fields; omitted ones take their defaults).

        Up to `jobs.SYNC_MAX_STEPS` steps (duration / dt; 600 s at dt 0.05 s) the answer comes
        when the run is done (201, with metrics). Longer runs answer 202 at once; poll
        `GET /api/runs/{id}` (the Location header) for status and progress. Each client may
        submit `run_burst` runs at once, then `run_rate` per second (429 with Retry-After).
        """
        pending = await run_in_threadpool(store.pending)
        admit(request, pending, max_pending_runs, "runs")
        run = await run_in_threadpool(store.create, scenario)
        response.headers["Location"] = f"/api/runs/{run.id}"
        future = jobs.submit(run.id)
        if not jobs.is_sync(scenario):
            response.status_code = 202
            return run
        try:
            # shield: a client hanging up must not cancel a run that is already stored
            await asyncio.shield(asyncio.wrap_future(future))
        except ValueError as exc:  # input the scenario's own checks let through
            return unprocessable(_body_errors(exc), RANGES[("POST", "/api/runs")], id=run.id)
        except Exception as exc:
            raise HTTPException(500, f"run {run.id} failed: {exc}") from exc
        return await run_in_threadpool(store.get, run.id)

    @app.get("/api/runs", tags=["runs"])
    def list_runs(limit: Annotated[int, Query(ge=1, le=500)] = 50) -> list[Run]:
        """The newest runs first, without series."""
        return store.list_runs(limit)

    @app.get("/api/runs/{run_id}", tags=["runs"], responses={404: {"description": "no run"}})
    def get_run(run_id: str) -> Run:
        """A run's status, progress, scenario and (once done) metrics."""
        return store.get(run_id)

    @app.get(
        "/api/runs/{run_id}/series",
        tags=["runs"],
        responses={
            200: {
                "content": {"text/csv": {}, "application/vnd.apache.parquet": {}},
                "description": "json: {scenario, metrics, series: {name: nested lists}}; csv, "
                "parquet: one row per sample, one column per scalar (xi_0 … xi_8)",
            },
            404: {"description": "no run"},
            409: {"description": "the run is not done"},
        },
    )
    def get_series(
        run_id: str,
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

    # -- operability sweeps ------------------------------------------------------------------
    @app.post(
        "/api/sweeps",
        status_code=202,
        response_model=Sweep,
        dependencies=guarded,
        tags=["sweeps"],
        responses=limited,
    )
    def create_sweep(spec: SweepSpec, request: Request, response: Response) -> Any:
        """Queue an operability sweep (the `SweepSpec` fields; omitted ones take defaults).

        Answers 202 at once; poll `GET /api/sweeps/{id}` (the Location header) for status and
        progress (runs done of total) and, once done, the operability table. An empty axis or
        a grid over the caps (`twin.sim.sweep.MAX_CELLS`, `MAX_RUNS`, `MAX_TOTAL_STEPS`) is a
        422 naming the field. Sweeps share the runs' rate limit; at most `MAX_PENDING_SWEEPS`
        wait at a time.
        """
        try:
            RunRequest(**spec.scenario)  # the same rules as a run's body: no vessel paths
        except ValueError as exc:
            errors = _body_errors(exc)
            for e in errors:
                e["loc"] = ("body", "scenario", *e["loc"][1:])
            return unprocessable(errors, RANGES[("POST", "/api/sweeps")])
        admit(request, store.pending("sweeps"), MAX_PENDING_SWEEPS, "sweeps")
        total = math.prod(len(getattr(spec, axis)) for axis in AXES) * spec.seeds
        sweep = store.create_sweep(spec.model_dump(), total)
        sweeps.submit(sweep.id)
        response.headers["Location"] = f"/api/sweeps/{sweep.id}"
        return sweep

    @app.get(
        "/api/sweeps/{sweep_id}", tags=["sweeps"], responses={404: {"description": "no sweep"}}
    )
    def get_sweep(sweep_id: str) -> Sweep:
        """A sweep's status, progress and (once done) operability table with its criterion."""
        return store.get_sweep(sweep_id)

    @app.get(
        "/api/sweeps/{sweep_id}/heatmap.png",
        tags=["sweeps"],
        response_class=Response,
        responses={
            200: {"content": {"image/png": {}}, "description": "operability heatmaps"},
            404: {"description": "no sweep"},
            409: {"description": "the sweep is not done"},
        },
    )
    def get_sweep_heatmap(sweep_id: str) -> Response:
        """A done sweep's heatmap: Hs × Tp per planner, heading and (β, k_e, k_c)."""
        sweep = store.get_sweep(sweep_id)
        if sweep.status != "done":
            raise HTTPException(409, f"sweep {sweep_id} is {sweep.status}; heatmap once done")
        return Response(store.sweep_heatmap(sweep_id), media_type="image/png")

    # -- the live session ------------------------------------------------------------------
    @app.get("/api/live", tags=["live"])
    def get_live() -> LiveState:
        """The live session: scenario fields, `t` [s], `speed`, `playing` and metrics."""
        return session.snapshot()

    @app.patch(
        "/api/live",
        response_model=LiveState,
        dependencies=guarded,
        tags=["live"],
        responses=bad_input,
    )
    def patch_live(changes: LivePatch) -> Any:
        """Change any scenario field and/or `speed`, `playing`; effective on the next step.

        All fields are checked before any applies: one bad value is a 422 and changes nothing.
        `mechanism`, `vessel`, `dt` or `initial_state` restart the session at t = 0.
        """
        try:
            session.patch(changes.model_dump(exclude_unset=True))
        except ValueError as exc:
            return unprocessable(_body_errors(exc), RANGES[("PATCH", "/api/live")])
        return session.snapshot()

    @app.post(
        "/api/live/reset",
        response_model=LiveState,
        dependencies=guarded,
        tags=["live"],
        responses=bad_input,
    )
    def reset_live() -> Any:
        """Start the current scenario again from t = 0."""
        try:
            session.reset()
        except ValueError as exc:  # the scenario in force cannot start (nothing changed)
            return unprocessable(_body_errors(exc), {})
        return session.snapshot()

    @app.post("/api/live/pause", dependencies=guarded, tags=["live"], responses=refused)
    def pause_live() -> LiveState:
        session.pause()
        return session.snapshot()

    @app.post("/api/live/play", dependencies=guarded, tags=["live"], responses=refused)
    def play_live() -> LiveState:
        session.play()
        return session.snapshot()

    @app.post("/api/live/step", dependencies=guarded, tags=["live"], responses=bad_input)
    def step_live(n: Annotated[int, Query(ge=1, le=1000)] = 1) -> LiveState:
        """Advance n steps now, also while paused."""
        session.step(n)
        return session.snapshot()

    return app

"""What the REST API takes and answers: request and response models, and its 422s.

Bad input is a 422 whose `detail` lists each field (`loc`), what is wrong (`msg`) and, for
scenario and live fields, the `allowed` range; `message` says the same in one line. No model
takes a path: a vessel is one of the shipped RAO tables by name.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Annotated, Any, Literal

from fastapi.responses import JSONResponse
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    create_model,
    field_validator,
    model_validator,
)
from pydantic.fields import FieldInfo

from twin.runs.sweep import SweepSpec
from twin.sim import Scenario
from twin.sim.live import COMPARE, MOTION_SOURCE, LiveControls, LiveMotionSource
from twin.sim.live import LIVE_FIELDS as SESSION_FIELDS
from twin.sim.registries import (
    MECHANISMS,
    PLANNERS,
    WMO_SEA_STATES,
    PlannerParameters,
    available_raos,
    get_planner,
)
from twin.sim.scenario import DEFAULT_PLANNER, check_one_sea
from twin.validation import error_message

# -- response models -------------------------------------------------------------------------


class ExecutorInfo(BaseModel):
    """The executor every run and sweep runs on: started once with the server."""

    scheduler: str = Field(description="'local cluster', 'in-process' or the Dask address")
    workers: int = Field(description="worker threads (one per core on a local cluster)")
    started: float = Field(description="[s] when it started (Unix time)")


class WarmupInfo(BaseModel):
    """A server's start-up progress (`twin.web.warmup.Warmup`)."""

    stage: str = Field(description="what it is doing: compiling kernels, starting the executor …")
    kernels_done: int = Field(description="lane sets of the kernels compiled or loaded so far")
    kernels_total: int
    last_kernel: str | None = Field(description="the last one done, e.g. 'hybrid mtmp'")
    elapsed_s: float = Field(description="[s] since start-up began")
    error: str | None = Field(description="why start-up failed, if it did")


class Health(BaseModel):
    """The server is up: `ok` once it runs, `warming` while its kernels compile (REST answers;
    runs queue and the live routes answer 503 until then), `failed` if start-up failed."""

    status: Literal["ok", "warming", "failed"] = "ok"
    version: str = Field(description="wave-twin version")
    viewer_port: int | None = Field(description="port of the 3D viewer on this host, if any")
    executor: ExecutorInfo | None = Field(None, description="where runs and sweeps execute")
    warming: WarmupInfo | None = Field(None, description="start-up progress, until `ok`")


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


class Registries(BaseModel):
    """The read-only registries, built once per app."""

    mechanisms: list[MechanismInfo]
    planners: list[PlannerInfo]
    sea_states: list[SeaStateInfo]

    @classmethod
    def build(cls) -> Registries:
        schema = PlannerParameters.model_json_schema()["properties"]
        mechanisms = [
            MechanismInfo(
                name=name,
                description=(mechanism.__doc__ or name).strip().splitlines()[0],
                state_size=mechanism().working_state.size,
                default_planner=DEFAULT_PLANNER[name],
                planners=[p for p, spec in PLANNERS.items() if name in spec.mechanisms],
            )
            for name, mechanism in MECHANISMS.items()
        ]
        planners = [
            PlannerInfo(
                name=spec.name,
                title=spec.title,
                mechanisms=list(spec.mechanisms),
                source=spec.source,
                default_for=[m for m, p in DEFAULT_PLANNER.items() if p == spec.name],
                parameters={
                    p: {k: v for k, v in schema[p].items() if k != "title"}
                    for p in spec.parameters
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
        return cls(mechanisms=mechanisms, planners=planners, sea_states=sea_states)


# -- request models ----------------------------------------------------------------------------

#: the shipped RAO tables: over REST a vessel is named, never a path (a path would let a
#: request make the server open any file it can read)
if TYPE_CHECKING:  # the tables are found at import: to mypy a name is a str
    VesselName = str
else:
    VesselName = Literal[tuple(available_raos())]


def _known_planner(value: str | None) -> str | None:
    """A planner name is a registered one (an empty name included: refused, not defaulted)."""
    if value is not None and value not in PLANNERS:
        raise ValueError(f"unknown name {value!r}; allowed: {sorted(PLANNERS)}")
    return value


class RunRequest(Scenario):
    """A scenario as a request gives it: the `Scenario` fields, `vessel` by name only."""

    vessel: VesselName | None = Field(
        None,
        description="shipped RAO table by name (assets/vessels); default: the mechanism's "
        "mount. Your own .nc table is loaded from Python (`Scenario(vessel=path)`), not REST.",
    )

    @model_validator(mode="before")
    @classmethod
    def _one_sea(cls, data: Any) -> Any:
        if isinstance(data, dict):
            check_one_sea(data)
        return data

    @field_validator("planner")
    @classmethod
    def _planner_for_mechanism(cls, value: str | None, info: Any) -> str | None:
        if value is not None:
            get_planner(value, info.data.get("mechanism", "hybrid"))  # names the allowed ones
        return value

    @model_validator(mode="after")
    def _at_least_one_step(self) -> RunRequest:
        if round(self.duration / self.dt) < 1:
            raise ValueError(
                f"duration: {self.duration:g} s at dt = {self.dt:g} s is zero steps; allowed: "
                "duration ≥ dt"
            )
        return self


# -- live models: the scenario's fields, flat, plus the session's controls ---------------------

#: Scenario fields the live session exposes (`duration` means nothing live).
LIVE_FIELDS = tuple(name for name in SESSION_FIELDS if name not in LiveControls.model_fields)


def _optional(model: type[BaseModel], name: str) -> tuple[Any, Any]:
    """(annotation, field) of `model.name` made optional, its range kept."""
    info = model.model_fields[name]
    annotation: Any = (
        Annotated[info.annotation, *info.metadata] if info.metadata else info.annotation
    )
    return annotation | None, Field(None, description=info.description)


def _one_sea_patch(cls: type, data: Any) -> Any:
    """A PATCH sets the sea once: `sea_state`, or `hs`/`tp` (`check_one_sea`)."""
    if isinstance(data, dict):
        check_one_sea(data)
    return data


#: LivePatch's fields (annotation, field) by name and its validators
_PATCH_FIELDS: dict[str, Any] = {
    **{name: _optional(RunRequest, name) for name in LIVE_FIELDS},
    COMPARE: (
        str | None,
        Field(None, description="a second planner run beside the first on the same vessel "
              "motion, with the same knobs (the viewer draws it as a ghost); null stops it. "
              "Setting or changing it restarts the session at t = 0"),
    ),
    MOTION_SOURCE: (
        LiveMotionSource | None,
        Field(None, description='where the hull motion comes from: {"kind": "sea"} the '
              'synthesised sea; {"kind": "udp"} the live motion input (twin serve --motion-udp '
              'PORT; the stream\'s clock drives the session, which holds while it is stale); '
              '{"kind": "log", "log": ID, "speed": 1-8} a stored log replayed (pausing at its '
              "end). Restarts the session at t = 0"),
    ),
    **{name: _optional(LiveControls, name) for name in LiveControls.model_fields},
}  # fmt: skip
_PATCH_VALIDATORS: dict[str, Any] = {
    "_known_planner": field_validator("planner", COMPARE)(_known_planner),
    "_one_sea": model_validator(mode="before")(_one_sea_patch),
}
LivePatch = create_model(
    "LivePatch",
    __config__=ConfigDict(extra="forbid", allow_inf_nan=False),
    __doc__="Fields to change in the live session; omitted fields stay as they are.",
    __validators__=_PATCH_VALIDATORS,
    **_PATCH_FIELDS,
)


class LiveCompare(BaseModel):
    """The comparison lane: the same scenario and vessel motion under another planner."""

    planner: str = Field(description="its planner")
    metrics: dict[str, Any] = Field(description="metrics over its live history")
    faults: dict[str, Any] = Field(description="its numerical faults (as the live `faults`)")


class ReplayState(BaseModel):
    """A stored run shown in the viewer instead of the live simulation."""

    run_id: str = Field(description="the run replayed")
    t: float = Field(description="[s] replay time")
    duration: float = Field(description="[s] time of its last sample")


class ReplayRequest(BaseModel):
    """Play a stored run in the viewer (again with the same id: seek)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    run_id: str = Field(min_length=1, max_length=64, description="a done run's id")
    t: float = Field(0.0, ge=0.0, description="[s] where to start (at most the run's end)")
    playing: bool = Field(True, description="play (true) or stay paused (false)")

def _described(info: FieldInfo) -> tuple[Any, Any]:
    """(annotation, field) of a model's field as `create_model` takes it: required, its
    description kept."""
    return info.annotation, Field(description=info.description)


#: LiveState's fields, (annotation, field) by name, in the schema's order
_STATE_FIELDS: dict[str, Any] = dict(
    **{
        name: _described(info)
        for name, info in Scenario.model_fields.items()
        if name in LIVE_FIELDS
    },
    t=(float, Field(description="[s] simulated time")),
    **{
        name: _described(info)
        for name, info in LiveControls.model_fields.items()
    },
    metrics=(dict[str, Any], Field(description="metrics over the live history (a replay: "
             "over the stored run)")),
    compare=(LiveCompare | None, Field(None, description="the comparison lane, if any")),
    restarts=(int, Field(0, description="times live time restarted at t = 0 since the server "
              "started (a mechanism, vessel, dt, initial_state or compare_planner change, or a "
              "reset)")),
    restart_reason=(str | None, Field(None, description="why it last restarted, e.g. "
                    "'compare_planner changed'")),
    restarted=(bool | None, Field(None, description="PATCH's answer only: whether this change "
               "restarted live time at t = 0")),
    replay=(ReplayState | None, Field(None, description="the stored run replayed, if any; "
            "scenario fields, `t` and metrics are then the run's")),
    motion_source=(dict[str, Any] | None, Field(None, description="the hull motion's source: "
                   "`kind` (sea, udp, log), `log`, `speed`, `status` (synthesised; a stream's "
                   "waiting, live or stale; a log's playing or ended), `input` (the live "
                   "motion input's source, live, age_s, counts, latest sample) and `resyncs`")),
    faults=(
        dict[str, Any],
        Field(
            description="numerical faults since the last (re)start: `counts` per kind "
            "(base_motion, planner, kinematics: the step was held; joint_limit: shortened at a "
            "limit; singular: damped; infeasible: the qp planner took the closest feasible "
            "rates; tracking_diverged: 1 once the tip error reached 0.25 m), `held` steps, the "
            "newest `events` (t, kinds, message) "
            "and `loop_errors`"
        ),
    ),
)
LiveState = create_model(
    "LiveState",
    __doc__="The live session: its scenario fields, flat, with time, controls and metrics.",
    **_STATE_FIELDS,
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
    ("PATCH", "/api/live"): {
        **_ranges(RunRequest, LiveControls),
        COMPARE: "a planner of the mechanism (GET /api/mechanisms) or null",
        MOTION_SOURCE: '{"kind": "sea"}, {"kind": "udp"} (with twin serve --motion-udp) or '
        '{"kind": "log", "log": ID (GET /api/motion-logs), "speed": 1 ≤ speed ≤ 8}',
    },
    ("POST", "/api/live/replay"): _ranges(ReplayRequest),
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
        if error["type"] == "json_invalid":  # loc is (body, character offset): say what it is
            reason = error.get("ctx", {}).get("error", error["msg"])
            lines.append(f"the body is not valid JSON: {reason} (at character {loc[-1]})")
            continue
        name = _dotted(loc[1:] or loc)
        message = error_message(error["msg"], name)  # as the CLI says it (`explain`)
        allowed = item.get("allowed")
        lines.append(f"{name}: {message}" + (f" (allowed: {allowed})"
                                             if _adds(allowed, message) else ""))  # fmt: skip
    return JSONResponse({"detail": detail, "message": "; ".join(lines), **extra}, status_code=422)


#: JSON-schema type names: an allowed text made of these alone says no more than pydantic's
#: own "Input should be a valid …"
_TYPES = {"string", "number", "integer", "array", "boolean", "object", "null", "any"}


def _dotted(loc: list[Any]) -> str:
    """A location as a dotted name, a part repeated by a nested validator said once
    (`("hs", "hs", 0)` → "hs.0")."""
    parts = [str(part) for i, part in enumerate(loc) if i == 0 or part != loc[i - 1]]
    return ".".join(parts)


def _adds(allowed: str | None, message: str) -> bool:
    """Whether "(allowed: …)" tells more than the message: not when the message already
    lists what is allowed (pydantic's "Input should be 'a', 'b' or 'c'", a TwinError's
    "allowed: …"), nor when it names types only ("string or null")."""
    if allowed is None or "allowed" in message or message.startswith("Input should be '"):
        return False
    return not set(allowed.split(" or ")) <= _TYPES


#: a TwinError's message names its field first: "planner: unknown name ''; …"
_FIELD_FIRST = re.compile(r"^(?:Value error, )?([a-z_][a-z0-9_]*)(?:\[\d+\])?: ")


def locate(errors: list[dict[str, Any]], fields: dict[str, str]) -> list[dict[str, Any]]:
    """Errors of the whole body (a model's cross-field check) whose message starts with one
    of `fields` ("duration: … zero steps") located at that field."""
    out = []
    for error in errors:
        match = _FIELD_FIRST.match(error["msg"])
        if tuple(error["loc"]) == ("body",) and match and match.group(1) in fields:
            error = {**error, "loc": ("body", match.group(1))}
        out.append(error)
    return out


def body_errors(exc: ValueError, fields: dict[str, str] | None = None) -> list[dict[str, Any]]:
    """A model's ValidationError or a TwinError as errors located in the request body; one
    whose message starts with one of `fields` is located at that field."""
    if isinstance(exc, ValidationError):
        errors = [
            {"loc": ("body", *e["loc"]), "msg": e["msg"], "type": e["type"]} for e in exc.errors()
        ]
    else:
        errors = [{"loc": ("body",), "msg": str(exc), "type": "value_error"}]
    return locate(errors, fields or {})

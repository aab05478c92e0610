"""Fuzz every REST operation from the app's own OpenAPI schema with schemathesis (issue 8).

schemathesis reads `/openapi.json` from the app and sends, in process (ASGI), what it derives
from it for each operation: boundary, missing and wrong-typed values of every parameter and
body field and probes of undeclared methods (its coverage phase, deterministic), then
`MAX_EXAMPLES` drawn requests, valid and invalid (its fuzzing phase, derandomized, from a fixed
seed, no example database), so CI sends the same requests on every run. Every answer must:

- never be a 5xx;
- have a status code its operation documents, and a body, media type and headers as the
  schema describes them;
- be strict JSON (UTF-8; no NaN, no Infinity, no number that overflows a float) when it says
  it is JSON, and say what is wrong in `detail` when it is a 4xx;
- as a 422, carry a non-empty `detail` list of {loc, msg, ...} and a one-line `message`;
- as a 4xx, or as the answer to a read, leave the live session and the runs and sweeps
  submitted as they were;
- when it carries the token, never be a 401 or 403 (so the mutating endpoints are really
  exercised); accepted runs and sweeps are at their Location, a run's scenario valid.

Without the token, every POST and PATCH must be a 401 asking for a Bearer token, and nothing
changes. After the fuzz, `GET /api/live` still answers finite numbers, before and after
stepping whatever scenario the fuzz left, which is still a valid `Scenario`.

The apps are built when the module is imported: schemathesis's pytest plugin makes one test
per operation from a loaded schema (its fixture-based `schemathesis.pytest.from_fixture`
fails on pytest 9.2, whose nodes no longer have `_nodeid`). Each app has a token, its own
live session (never started: only requests move it), run store, and job and sweep runners
that record what is submitted and execute nothing: the fuzz is of the HTTP layer, not of the
simulation (tests/web/test_api.py runs those). The rate limit and the body cap are the app's
defaults, so a 429 (or a 413) is checked as the app serves it.
"""

from __future__ import annotations

import json
import math
import sqlite3
import tempfile
from collections import Counter
from concurrent.futures import Future
from pathlib import Path
from typing import Any

import pytest
import schemathesis
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    response_headers_conformance,
    response_schema_conformance,
    status_code_conformance,
)

from tests.figures import record
from tests.web.support import access
from twin.runs.sweep import SweepSpec, heatmap_png, run_sweep
from twin.sim import Scenario, simulate
from twin.sim.live import LiveSession
from twin.web import JobRunner, RunStore, SweepRunner, create_app

TOKEN = "fuzz-token-0123456"
#: drawn requests per operation in the fuzzing phase (the coverage phase adds its own cases)
MAX_EXAMPLES = 50
#: `POST /api/live/step` steps the live simulation up to 1000 times per request (2-5 s)
MAX_STEP_EXAMPLES = 3
SEED = 20260808
LIVE = {"sea_state": 3}
BEARER = {"Authorization": f"Bearer {TOKEN}"}


class RecordingJobs(JobRunner):
    """Scripted runs recorded, never executed: no executor is started.

    `submit` answers a future already resolved with the run as stored, so a run under the
    synchronous cap answers 201 at once (and stays queued); a longer one answers 202 as usual.
    """

    def __init__(self, store: RunStore) -> None:
        super().__init__(store)
        self.submitted: list[str] = []

    def start(self, executor: object = None) -> list[str]:
        return []

    def submit(self, run_id: str) -> Future:
        self.submitted.append(run_id)
        future: Future = Future()
        future.set_result(self.store.get(run_id))
        return future

    def shutdown(self) -> None:
        pass


class RecordingSweeps(SweepRunner):
    """Operability sweeps recorded, never run: no thread, no executor."""

    def __init__(self, store: RunStore) -> None:
        super().__init__(store)
        self.submitted: list[str] = []

    def start(self, executor: object = None) -> list[str]:
        return []

    def submit(self, sweep_id: str) -> None:
        self.submitted.append(sweep_id)

    def shutdown(self) -> None:
        pass


class Twin:
    """An app with a token over its own live session, store and recording runners, and what
    the fuzz sent to it."""

    def __init__(self, folder: Path) -> None:
        folder.mkdir()
        self.live = LiveSession(LIVE)
        self.store = RunStore(folder / "runs.sqlite")
        self.jobs = RecordingJobs(self.store)
        self.sweeps = RecordingSweeps(self.store)
        # every wrong token is answered 401 (the fuzz sends thousands from one client; the
        # failure limit is tested in test_api.py)
        self.app = create_app(
            self.live, self.store, access=access(TOKEN, failure_burst=10**6),
            jobs=self.jobs, sweeps=self.sweeps,
        )  # fmt: skip
        self.sent: Counter[str] = Counter()  # requests per operation
        self.statuses: Counter[int] = Counter()
        self.initial = self.state()

    def state(self) -> tuple[Any, ...]:
        """What a refused request or a read must not change (cheap: taken around every
        request; the store's own rows are compared with the submissions after the fuzz)."""
        live = self.live
        return (
            live.scenario,
            live.controls.model_dump(),
            live.version,
            float(live.latest()["t"]),
            len(self.jobs.submitted),
            len(self.sweeps.submitted),
        )

    def rows(self, table: str) -> int:
        """Rows of a table of the store's SQLite file (runs or sweeps), read on their own."""
        with sqlite3.connect(self.store.path) as db:
            return db.execute(f"SELECT count(*) FROM {table}").fetchone()[0]


def _config(**extra: Any) -> schemathesis.Config:
    """Bounded and reproducible: a fixed seed, derandomized, no example database."""
    return schemathesis.Config.from_dict(
        {
            "seed": SEED,
            "suppress-health-check": ["too_slow"],  # timing differs from machine to machine
            "generation": {
                "max-examples": MAX_EXAMPLES,
                "deterministic": True,
                "database": "none",
            },
            "operations": [
                {
                    "include-name": "POST /api/live/step",
                    "generation": {"max-examples": MAX_STEP_EXAMPLES},
                }
            ],
            **extra,
        }
    )


_FOLDER = tempfile.TemporaryDirectory(prefix="twin-fuzz-")  # removed at exit
AUTHORIZED = Twin(Path(_FOLDER.name) / "authorized")
UNAUTHORIZED = Twin(Path(_FOLDER.name) / "unauthorized")
#: every request carries the token (but a few probes of schemathesis's without credentials)
authorized = schemathesis.openapi.from_asgi(
    "/openapi.json", AUTHORIZED.app, config=_config(headers=BEARER)
)
#: no request carries the token (schemathesis may send a made-up one)
unauthorized = schemathesis.openapi.from_asgi("/openapi.json", UNAUTHORIZED.app, config=_config())

# -- checks: schemathesis's, and ours in its form (ctx, response, case) ------------------------


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"number {text} overflows a float")
    return value


def _constant(name: str) -> float:
    raise ValueError(f"{name} is not JSON")


def _json(response: schemathesis.Response) -> Any:
    """The body parsed strictly: UTF-8, and no NaN, Infinity or overflowing number."""
    return json.loads(
        response.content.decode("utf-8"), parse_constant=_constant, parse_float=_finite
    )


def _is_json(response: schemathesis.Response) -> bool:
    media = response.headers.get("content-type", [""])[0].split(";")[0].strip().lower()
    return media == "application/json" or media.endswith("+json")


def strict_json(ctx: Any, response: schemathesis.Response, case: schemathesis.Case) -> None:
    """A JSON answer is strict JSON; a 4xx is JSON that says what is wrong in `detail`."""
    if not _is_json(response):
        assert response.status_code < 400, f"a {response.status_code} that is not JSON"
        return
    try:
        body = _json(response)
    except ValueError as exc:
        raise AssertionError(f"not strict JSON: {exc}: {response.content[:300]!r}") from exc
    if response.status_code >= 400:
        assert isinstance(body, dict) and body.get("detail"), f"a 4xx without detail: {body}"


def unprocessable_shape(ctx: Any, response: schemathesis.Response, case: schemathesis.Case) -> None:
    """A 422 lists each problem (`loc`, `msg`) in `detail` and says them in `message`."""
    if response.status_code != 422:
        return
    try:
        body = _json(response)
    except ValueError:
        return  # strict_json reports it
    assert isinstance(body, dict), f"a 422 that is not an object: {body!r}"
    detail = body.get("detail")
    assert isinstance(detail, list) and detail, f"422 detail is not a non-empty list: {body}"
    for item in detail:
        assert isinstance(item, dict), f"422 detail item is not an object: {item!r}"
        assert isinstance(item.get("loc"), list), f"422 detail item without a loc list: {item}"
        assert isinstance(item.get("msg"), str), f"422 detail item without a msg: {item}"
    message = body.get("message")
    assert isinstance(message, str) and message, f"422 without a message string: {body}"


def token_accepted(ctx: Any, response: schemathesis.Response, case: schemathesis.Case) -> None:
    """A request that carries the token (and no Origin) is not refused for who sent it."""
    if response.request.headers.get("Authorization") != BEARER["Authorization"]:
        return  # one of schemathesis's probes without credentials
    assert response.status_code not in (401, 403), (
        f"{response.status_code} although the token was sent: {response.content[:300]!r}"
    )


def created_where_it_says(
    ctx: Any, response: schemathesis.Response, case: schemathesis.Case
) -> None:
    """An accepted run or sweep is at its Location and was submitted; a run's scenario, as
    stored, is a valid `Scenario`."""
    if case.method.upper() != "POST" or response.status_code not in (201, 202):
        return
    body = _json(response)
    kind = case.operation.path.rsplit("/", 1)[-1]  # runs | sweeps
    assert response.headers.get("location") == [f"/api/{kind}/{body['id']}"], response.headers
    if kind == "runs":
        assert body["id"] in AUTHORIZED.jobs.submitted, "an accepted run was not submitted"
        Scenario.model_validate(body["scenario"])
    else:
        assert body["id"] in AUTHORIZED.sweeps.submitted, "an accepted sweep was not submitted"


CHECKS = [
    not_a_server_error,
    status_code_conformance,
    content_type_conformance,
    response_headers_conformance,
    response_schema_conformance,
    strict_json,
    unprocessable_shape,
]


def _send(twin: Twin, case: schemathesis.Case) -> tuple[schemathesis.Response, tuple[Any, ...]]:
    """Send a case, counting it; the answer and the twin's state before it."""
    before = twin.state()
    twin.sent[case.operation.label] += 1
    response = case.call()
    twin.statuses[response.status_code] += 1
    return response, before


def _unchanged(twin: Twin, before: tuple[Any, ...], case: schemathesis.Case, status: int) -> None:
    after = twin.state()
    assert after == before, (
        f"{case.method} {case.formatted_path} answered {status} but changed the twin:\n"
        f"before {before}\nafter  {after}\n{case.as_curl_command()}"
    )


# -- the fuzz -----------------------------------------------------------------------------------


@authorized.parametrize()
def test_fuzz_with_the_token(case: schemathesis.Case) -> None:
    """Any schema-valid or invalid request with the token conforms to the API schema, and a refused
    or GET request changes nothing."""
    response, before = _send(AUTHORIZED, case)
    case.validate_response(response, checks=[*CHECKS, token_accepted, created_where_it_says])
    if response.status_code >= 400 or case.method.upper() == "GET":
        _unchanged(AUTHORIZED, before, case, response.status_code)


# `exclude`, not `include(method=...)`: the config's per-operation entry adds an include
# filter that matches every operation, and includes are alternatives.
@unauthorized.exclude(method="GET").parametrize()
def test_fuzz_without_the_token_is_refused(case: schemathesis.Case) -> None:
    """Any request without the token is refused 401 with a Bearer challenge and changes nothing."""
    response, before = _send(UNAUTHORIZED, case)
    if case.method.upper() == case.operation.method.upper():  # not a probe of another method
        assert response.status_code == 401, (
            f"{response.status_code} without the token: {response.content[:300]!r}\n"
            f"{case.as_curl_command()}"
        )
        assert response.headers.get("www-authenticate") == ["Bearer"], response.headers
    case.validate_response(response, checks=CHECKS)
    _unchanged(UNAUTHORIZED, before, case, response.status_code)


# -- what the fuzz cannot reach: ids of done runs and sweeps ------------------------------------


def test_a_done_run_and_sweep_answer_as_documented(tmp_path: Path) -> None:
    """The fuzz never guesses a run or sweep id, so the answers about done ones (series in
    three formats, heatmap) are checked here, against the same schema, with the same checks."""
    with RunStore(tmp_path / "runs.sqlite") as store:
        scenario = Scenario(**LIVE, duration=1.0)
        run = store.create(scenario)
        store.finish(run.id, simulate(scenario))
        spec = SweepSpec(hs=[0.5, 2.0], tp=[8.0], seeds=1, duration=1.0)
        sweep = store.create_sweep(spec.model_dump(), 2)
        result = run_sweep(spec, scheduler="in-process", progress=False)
        png = heatmap_png(result, tmp_path / "heatmap.png").read_bytes()
        store.finish_sweep(sweep.id, result.to_dict(), png)
        app = create_app(
            AUTHORIZED.live,  # only read, by no request here
            store,
            access=access(TOKEN),
            jobs=RecordingJobs(store),
            sweeps=RecordingSweeps(store),
        )
        requests = [
            ("/api/runs/{run_id}", {"run_id": run.id}, {}),
            *(
                ("/api/runs/{run_id}/series", {"run_id": run.id}, {"format": fmt})
                for fmt in ("json", "csv", "parquet")
            ),
            ("/api/sweeps/{sweep_id}", {"sweep_id": sweep.id}, {}),
            ("/api/sweeps/{sweep_id}/heatmap.png", {"sweep_id": sweep.id}, {}),
        ]
        for path, parameters, query in requests:
            case = authorized[path]["GET"].Case(path_parameters=parameters, query=query)
            response = case.call(app=app)
            case.validate_response(response, checks=CHECKS)
            assert response.status_code == 200, (path, query, response.content[:300])


# -- after the fuzz -----------------------------------------------------------------------------


def _numbers(value: Any) -> list[float]:
    if isinstance(value, dict):
        return [x for v in value.values() for x in _numbers(v)]
    if isinstance(value, list):
        return [x for v in value for x in _numbers(v)]
    return [value] if isinstance(value, int | float) and not isinstance(value, bool) else []


def _call(schema: schemathesis.BaseSchema, method: str, path: str, **kwargs: Any) -> Any:
    """One request, checked like every fuzzed one; its JSON body, once it is a 200."""
    case = schema[path][method].Case(**kwargs)
    response = case.call()
    case.validate_response(response, checks=CHECKS)
    assert response.status_code == 200, response.content[:300]
    return _json(response)


def test_after_the_fuzz_the_twin_is_sound_and_the_figures_are_recorded() -> None:
    """Runs after the fuzz tests above (file order). Records how much was fuzzed; then the
    live session still answers finite numbers, before and after stepping what the fuzz left,
    and holds a valid `Scenario`; the store holds exactly the runs and sweeps the app
    accepted; the twin fuzzed without the token is as it was built."""
    if not (AUTHORIZED.sent and UNAUTHORIZED.sent):
        pytest.skip("the fuzz tests of this file did not run")
    record(
        "rest_fuzz",
        operations=len(AUTHORIZED.sent),
        requests=sum(AUTHORIZED.sent.values()),
        statuses={str(k): v for k, v in sorted(AUTHORIZED.statuses.items())},
        per_operation=dict(AUTHORIZED.sent),
        max_examples=MAX_EXAMPLES,
        seed=SEED,
        unauthorized={
            "operations": len(UNAUTHORIZED.sent),
            "requests": sum(UNAUTHORIZED.sent.values()),
            "statuses": {str(k): v for k, v in sorted(UNAUTHORIZED.statuses.items())},
        },
    )

    for _ in range(2):
        state = _call(authorized, "GET", "/api/live")
        assert all(math.isfinite(x) for x in _numbers(state)), state
        Scenario.model_validate(AUTHORIZED.live.scenario.model_dump())
        _call(authorized, "POST", "/api/live/step", query={"n": 20}, headers=BEARER)

    assert AUTHORIZED.rows("runs") == len(AUTHORIZED.jobs.submitted)
    assert {run.id for run in AUTHORIZED.store.list_runs(500)} <= set(AUTHORIZED.jobs.submitted)
    assert AUTHORIZED.rows("sweeps") == len(AUTHORIZED.sweeps.submitted)

    assert UNAUTHORIZED.state() == UNAUTHORIZED.initial
    assert UNAUTHORIZED.rows("runs") == UNAUTHORIZED.rows("sweeps") == 0
    assert _call(unauthorized, "GET", "/api/live")["t"] == 0.0

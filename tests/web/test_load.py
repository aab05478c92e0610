"""Load and soak on loopback: a real `twin serve` (viewer included) under concurrent clients.

For a bounded time, threads of this process hold the server busy all at once:

- 3D viewers: `CLIENTS` websocket clients of the viser port connect, read messages and hang
  up, `WS_ROUNDS` times each;
- live patches: `PATCHES` PATCH /api/live of random fields and values, valid and invalid
  (out of range, huge, non-finite, wrong types, unknown fields and planners): each answers
  200, or 422 whose message names a field it was sent, never anything else;
- runs: `RUN_THREADS` × `RUNS_PER_THREAD` short POST /api/runs over the mechanisms and
  planners; a 429 (rate limit) or 413 refuses a run, every accepted one (201/202) must be
  stored and done afterwards;
- health: GET /api/health polled throughout, each answer within `HEALTH_LATENCY` s;
- a sweep: `SWEEP` (1,000 runs of 200 s) submitted with the runs, on the same executor.

Every run and the sweep execute on the one executor the server started (a Dask LocalCluster):
its start time and worker processes are the same before and after, so no request started a
cluster.

Afterwards the server process's memory has grown by less than `RSS_GROWTH_MB`, the live state
is finite JSON, the live loop still advances and the server stops cleanly on Ctrl-C. The whole
test ends by itself within `BUDGET` s. The server shows no sample count, so that the live
history stays the `HISTORY` ring buffer through patches and restarts is checked in process.
"""

from __future__ import annotations

import json
import math
import os
import random
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from concurrent.futures import Future, ThreadPoolExecutor
from datetime import datetime
from importlib.metadata import version
from pathlib import Path
from statistics import median
from typing import Any

import httpx
import psutil
from websockets.sync.client import connect

from tests.figures import record
from tests.timing import scaled, slowdown
from tests.web.support import free_port
from twin.planners import PLANNERS
from twin.sim import Scenario
from twin.sim.live import HISTORY, LiveSession
from twin.web.api import LivePatch

#: [s] the whole test, server start to stop, must end within this
BUDGET = 120.0
#: [s] longest the server may take to answer its first health check (viewer meshes included)
STARTUP = 45.0
#: simultaneous websocket clients of the 3D viewer, and the rounds each connects for
CLIENTS = 10
WS_ROUNDS = 5
#: messages each websocket connection reads before hanging up (or `WS_READ` s, if sooner);
#: the first must come within `WS_READ` s (the scene's backlog, then frames at 40 fps)
WS_MESSAGES = 20
WS_READ = 10.0
#: random PATCH /api/live requests, spread over `PATCH_THREADS` threads
PATCHES = 1000
PATCH_THREADS = 4
#: [s] slowest answer allowed to a PATCH. A patch waits for the live loop's lock, which a tick
#: holds for at most half a tick of stepping (`LiveSession.advance`'s budget; before that
#: budget, speed 8 at small dt held it for 12-17 s), then for its own work: a new sea of up to
#: 2048 components, or a restart, on a machine shared with the 3D viewer and the run workers
PATCH_TIMEOUT = 10.0
#: threads submitting runs, and runs each submits
RUN_THREADS = 4
RUNS_PER_THREAD = 10
#: [s] slowest answer allowed of GET /api/health, and its polling period
HEALTH_LATENCY = 2.0
HEALTH_PERIOD = 0.1
#: [MB] most the server process's RSS may grow over its warmed-up level. Measured on 2 cores:
#: +55 to +150 MB after one load, nearly all from the live patches (a session of up to 2048
#: wave components, a fine dt or another vessel allocates its sea, RAOs and base-motion chunks
#: anew, and glibc keeps its high-water mark) - over 10 rounds of patches alone it fluctuates
#: between +50 and +110 MB without a trend; 30 rounds of the 50 websocket connections add ~70
#: MB, flattening to < 1 MB a round; 10 rounds of the 40 runs add ~9 MB. The ring buffer itself
#: is `HISTORY` samples of ~2.5 kB: 5 MB. A leak of ≥ 200 kB per patch, ≥ 4 MB per viewer
#: connection or ≥ 5 MB per run fails this within the one load.
RSS_GROWTH_MB = 200.0

#: patches of the warm-up, each path once (a restart, a new sea, a 422), and their answers
WARM_UP = [
    ({"beta": 0.5, "playing": True}, 200),
    ({"mechanism": "upr4", "planner": "pid"}, 200),
    ({"sea_state": 5.0, "n_components": 128}, 200),
    ({"mechanism": "hybrid", "planner": "mtmp", "sea_state": 4.0}, 200),
    ({"beta": 2.0}, 422),
    ({"bogus": 1}, 422),
]
#: a run the load submits: short (2-5 s simulated, synchronous: 201 when done)
RUN_DURATION = (2.0, 5.0)
#: the sweep submitted with the runs: 10 Hs × 5 Tp × 2 planners × 10 seeds = 1,000 runs of 200 s
SWEEP = {
    "hs": [0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 3.0], "tp": [6.0, 7.0, 8.0, 9.0, 10.0],
    "planner": ["mtmp", "pi"], "seeds": 10, "duration": 200.0,
}  # fmt: skip
#: [s] longest the sweep may take once the load is over
SWEEP_WAIT = 60.0


# -- the server --------------------------------------------------------------------------------


class Server:
    """`twin serve` as a user starts it, in its own process group, logging to a file."""

    def __init__(self, folder: Path, *, viewer: bool = True) -> None:
        self.port = free_port()
        self.viser_port = free_port()
        self.log_path = folder / "server.log"
        args = [
            sys.executable, "-m", "twin.cli", "serve", "--host", "127.0.0.1",
            "--port", str(self.port), "--viser-port", str(self.viser_port),
            "--data-dir", str(folder / "data"),
        ]  # fmt: skip
        if not viewer:
            args.append("--no-viewer")
        env = {k: v for k, v in os.environ.items() if k != "TWIN_TOKEN"}  # loopback: no token
        with self.log_path.open("wb") as log:
            self.process = subprocess.Popen(
                args, cwd=folder, stdout=log, stderr=subprocess.STDOUT, env=env,
                start_new_session=True,
            )  # fmt: skip
        self.url = f"http://127.0.0.1:{self.port}"

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")[-4000:]

    def wait_ready(self, timeout: float = STARTUP) -> dict[str, Any]:
        """The first health answer that says `ok` (not `warming`: the kernels are loaded, the
        executor and live session run); fails if the process exits or `timeout` passes first."""
        deadline = time.monotonic() + scaled(timeout)
        while time.monotonic() < deadline:
            assert self.process.poll() is None, f"server exited early:\n{self.log()}"
            try:
                response = httpx.get(f"{self.url}/api/health", timeout=2.0)
                if response.status_code == 200 and response.json()["status"] == "ok":
                    return response.json()
            except httpx.TransportError:
                pass
            time.sleep(0.2)
        raise AssertionError(f"server not answering after {timeout} s:\n{self.log()}")

    def rss_mb(self) -> float:
        return psutil.Process(self.process.pid).memory_info().rss / 2**20

    def stop(self, timeout: float = 20.0) -> int:
        """Ctrl-C, as a user stops it; its return code (the group is killed if it hangs)."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout)
            except subprocess.TimeoutExpired as exc:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait(5)
                raise AssertionError(
                    f"server ignored Ctrl-C for {timeout} s:\n{self.log()}"
                ) from exc
        return self.process.returncode


# -- random live patches -----------------------------------------------------------------------

#: the live fields and their JSON schema (the non-null branch of each optional field)
FIELDS: dict[str, dict[str, Any]] = {
    name: next(b for b in prop["anyOf"] if b.get("type") != "null")
    for name, prop in LivePatch.model_json_schema()["properties"].items()
}
#: live fields that may be null (the scenario's optional ones); null is a bad value elsewhere
NULLABLE = {
    name
    for name, prop in Scenario.model_json_schema()["properties"].items()
    if any(b.get("type") == "null" for b in prop.get("anyOf", []))
} & set(FIELDS) | {"compare_planner"}
#: mechanism → planners that plan for it
PLANNERS_OF = {
    m: [p for p, spec in PLANNERS.items() if m in spec.mechanisms]
    for m in FIELDS["mechanism"]["enum"]
}
#: fields whose valid values are drawn apart (`valid_patch`)
COUPLED = {"mechanism", "planner", "initial_state", "compare_planner"}
#: JSON bodies no parser may turn into a number of a field: (raw body, the field)
RAW_INVALID = [
    ('{"beta": NaN}', "beta"),
    ('{"speed": Infinity}', "speed"),
    ('{"k_e": -Infinity}', "k_e"),
    ('{"heading": 1e999}', "heading"),
    ('{"sea_state": 1e400, "beta": 0.5}', "sea_state"),
]


def _low_high(schema: dict[str, Any]) -> tuple[float, float]:
    low = schema.get("minimum", schema.get("exclusiveMinimum"))
    high = schema.get("maximum", schema.get("exclusiveMaximum"))
    return float(low), float(high)


def valid_value(rng: random.Random, name: str) -> Any:
    """A value of a (non-coupled) live field inside its range."""
    schema = FIELDS[name]
    if name in NULLABLE and rng.random() < 0.2:
        return None
    if "enum" in schema:
        return rng.choice(schema["enum"])
    kind = schema["type"]
    if kind == "boolean":
        return rng.random() < 0.8  # mostly playing
    low, high = _low_high(schema)
    if kind == "integer":
        return rng.randint(int(low), int(min(high, low + 4000)))
    if name == "dt":  # small steps cost the live loop most: keep them a minority
        return rng.choice([0.05, 0.1, 0.2, round(rng.uniform(0.01, 0.2), 4)])
    value = rng.uniform(low, high)
    if "exclusiveMinimum" in schema and value <= low:
        value = high
    return value


def invalid_value(rng: random.Random, name: str) -> Any:
    """A value of a live field that no lax parsing makes valid."""
    schema = FIELDS[name]
    wrong_types: list[Any] = [[1.0, 2.0], {"value": 1}, "", "NaN"]
    if name not in NULLABLE:
        wrong_types.append(None)
    if name == "initial_state":
        return rng.choice([[1.0] * 3, [1e6] * 9, [[0.0]] * 9, "working", 7.5, [1.0] * 12])
    if name in ("planner", "compare_planner"):
        return rng.choice(["bogus", "MTMP ", "pid; DROP TABLE runs", 12, ["mtmp"], "x" * 300])
    if name == "motion_source":  # a kind, speed or log refused, or udp without an input
        return rng.choice([{"kind": "wind"}, {"kind": "log", "log": "0" * 16, "speed": 9},
                           {"kind": "log", "log": "0" * 16}, {"kind": "udp"}, {"kind": "sea",
                           "log": "0" * 16}, "sea", 3])  # fmt: skip
    if "enum" in schema:
        return rng.choice(["bogus", "HYBRID", "state9", "../sov", 3, *wrong_types])
    if schema["type"] == "boolean":
        return rng.choice(["perhaps", 2, -1, 0.5, *wrong_types])
    low, high = _low_high(schema)
    span = high - low
    out_of_range = [
        low - rng.uniform(0.01, 10.0) * span - 1e-6,
        high + rng.uniform(0.01, 10.0) * span + 1e-6,
        1e308,
        -1e308,
        10**30,
        -(10**30),
        "a lot",
    ]
    if "exclusiveMinimum" in schema:
        out_of_range.append(low)
    if schema["type"] == "integer":
        out_of_range.append(low + 0.5)
    return rng.choice(out_of_range + wrong_types)


def valid_patch(rng: random.Random) -> dict[str, Any]:
    """1-3 random fields within their ranges; a mechanism comes with a planner of its own."""
    patch: dict[str, Any] = {}
    for name in rng.sample(sorted(FIELDS), rng.randint(1, 3)):
        if name == "compare_planner":
            patch.setdefault(name, None)  # a second planner comes with a mechanism, below
        elif name == "motion_source":  # the sea: the load's server has no stream nor logs
            if rng.random() < 0.1:  # and it restarts the session: not too often
                patch[name] = {"kind": "sea"}
        elif name in COUPLED:
            if rng.random() < 0.3:  # a mechanism switch restarts the session: not too often
                mechanism = rng.choice(sorted(PLANNERS_OF))
                patch["mechanism"] = mechanism
                patch["planner"] = rng.choice(PLANNERS_OF[mechanism])
                if rng.random() < 0.3:  # and a second planner beside it
                    patch["compare_planner"] = rng.choice(PLANNERS_OF[mechanism])
        else:
            patch[name] = valid_value(rng, name)
    if patch.get("hs") is not None or patch.get("tp") is not None:
        patch.pop("sea_state", None)  # the sea is set once: a code, or hs/tp (issue 27)
    return patch or {"speed": rng.uniform(0.25, 8.0)}


def invalid_patch(rng: random.Random) -> tuple[dict[str, Any], set[str]]:
    """A valid patch spoilt by 1-2 bad fields (values or unknown names); (patch, bad fields)."""
    patch = valid_patch(rng) if rng.random() < 0.5 else {}
    bad: set[str] = set()
    for _ in range(rng.randint(1, 2)):
        if rng.random() < 0.15:
            name = rng.choice(["duration", "Beta", "bogus_field", "speed_", "__class__"])
            patch[name] = rng.choice([1.0, "x", None, [1]])
        else:
            name = rng.choice(sorted(FIELDS))
            patch[name] = invalid_value(rng, name)
        bad.add(name)
    return patch, bad


# -- the load ------------------------------------------------------------------------------------


class Load:
    """What the load threads saw; each thread appends under the lock."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.failures: list[str] = []
        self.patch_statuses: Counter[int] = Counter()
        self.run_statuses: Counter[int] = Counter()
        self.accepted: dict[str, int] = {}  # run id → 201/202
        self.ws_connections = 0
        self.ws_messages = 0
        self.ws_bytes = 0
        self.health: list[float] = []
        self.patch_latency: list[float] = []
        self.ws_first: list[float] = []  # [s] connect → first message, per connection
        #: [-] the time limits' stretch for the machine's load when the load began
        self.stretch = slowdown()

    def fail(self, message: str) -> None:
        with self.lock:
            self.failures.append(message)


def websocket_client(load: Load, port: int, rounds: int) -> None:
    """A 3D-viewer client: connect, read some messages, hang up; `rounds` times."""
    protocol = f"viser-v{version('viser')}"  # viser refuses other client versions (close 1002)
    for _ in range(rounds):
        if load.stop.is_set():
            return
        start = time.monotonic()
        with connect(
            f"ws://127.0.0.1:{port}/", subprotocols=[protocol], open_timeout=10, max_size=None
        ) as ws:
            if ws.subprotocol != protocol:
                load.fail(f"websocket: subprotocol {ws.subprotocol!r}, not {protocol!r}")
            messages = size = 0
            first = None
            end = time.monotonic() + WS_READ * load.stretch
            while messages < WS_MESSAGES and (left := end - time.monotonic()) > 0:
                try:
                    message = ws.recv(timeout=left)
                except TimeoutError:
                    break
                if first is None:
                    first = time.monotonic() - start
                messages += 1
                size += len(message)
            if first is None:
                waited = WS_READ * load.stretch
                load.fail(f"websocket: no message within {waited:.1f} s of connecting")
        with load.lock:
            load.ws_connections += 1
            load.ws_messages += messages
            load.ws_bytes += size
            load.ws_first.append(WS_READ if first is None else first)


def patcher(load: Load, url: str, seed: int, count: int) -> None:
    """`count` random PATCH /api/live: a valid patch answers 200, an invalid one 422."""
    rng = random.Random(seed)
    with httpx.Client(base_url=url, timeout=PATCH_TIMEOUT) as client:
        for _ in range(count):
            if load.stop.is_set():
                return
            draw = rng.random()
            start = time.monotonic()
            if draw < 0.05:
                raw, field = rng.choice(RAW_INVALID)
                response = client.patch(
                    "/api/live", content=raw, headers={"content-type": "application/json"}
                )
                body, bad, expected = raw, {field}, 422
            elif draw < 0.5:
                patch, bad = invalid_patch(rng)
                response = client.patch("/api/live", json=patch)
                body, expected = json.dumps(patch), 422
            else:
                patch = valid_patch(rng)
                response = client.patch("/api/live", json=patch)
                body, bad, expected = json.dumps(patch), set(), 200
            with load.lock:
                load.patch_statuses[response.status_code] += 1
                load.patch_latency.append(time.monotonic() - start)
            if response.status_code != expected:
                load.fail(f"PATCH {body[:200]}: {response.status_code}, expected {expected}: "
                          f"{response.text[:300]}")  # fmt: skip
            elif expected == 422:
                message = response.json().get("message", "")
                if not any(name in message for name in bad):
                    load.fail(f"PATCH {body[:200]}: 422 names none of {sorted(bad)}: {message}")


def runner(load: Load, url: str, seed: int, count: int) -> None:
    """`count` short runs; 201/202 accepted, 429/413 refused, anything else a failure."""
    rng = random.Random(seed)
    with httpx.Client(base_url=url, timeout=60.0) as client:
        for _ in range(count):
            if load.stop.is_set():
                return
            mechanism = rng.choice(sorted(PLANNERS_OF))
            scenario = {
                "mechanism": mechanism,
                "planner": rng.choice(PLANNERS_OF[mechanism]),
                "sea_state": round(rng.uniform(1.0, 5.0), 2),
                "heading": rng.choice([90.0, 150.0, 180.0]),
                "seed": rng.randint(0, 1000),
                "n_components": rng.choice([64, 128, 200]),
                "duration": round(rng.uniform(*RUN_DURATION), 2),
            }
            response = client.post("/api/runs", json=scenario)
            with load.lock:
                load.run_statuses[response.status_code] += 1
            if response.status_code in (201, 202):
                run = response.json()
                with load.lock:
                    load.accepted[run["id"]] = response.status_code
                if response.status_code == 201 and run["status"] != "done":
                    load.fail(f"run {run['id']}: 201 but {run['status']}: {run.get('error')}")
            elif response.status_code == 429:  # refused: wait as told (bounded), go on
                time.sleep(min(float(response.headers.get("retry-after", 1)), 2.0))
            elif response.status_code != 413:
                load.fail(f"POST /api/runs {scenario}: {response.status_code} "
                          f"{response.text[:300]}")  # fmt: skip


def health_poller(load: Load, url: str) -> None:
    """GET /api/health until the load stops; every answer a 200 within `HEALTH_LATENCY`."""
    with httpx.Client(base_url=url, timeout=HEALTH_LATENCY * load.stretch + 3.0) as client:
        while not load.stop.is_set():
            start = time.monotonic()
            try:
                response = client.get("/api/health")
                status = response.status_code
            except httpx.TimeoutException:
                status = -1
            latency = time.monotonic() - start
            with load.lock:
                load.health.append(latency)
            if status != 200 or latency > HEALTH_LATENCY * load.stretch:
                load.fail(f"GET /api/health: {status} after {latency:.2f} s")
            load.stop.wait(HEALTH_PERIOD)


def finite_numbers(value: Any, path: str = "") -> list[str]:
    """Paths of every number in a JSON value that is not finite (none, if all are)."""
    if isinstance(value, dict):
        return [p for k, v in value.items() for p in finite_numbers(v, f"{path}.{k}")]
    if isinstance(value, list):
        return [p for i, v in enumerate(value) for p in finite_numbers(v, f"{path}[{i}]")]
    if isinstance(value, float) and not math.isfinite(value):
        return [path]
    return []


def test_live_history_is_a_ring_buffer_through_patches_and_restarts() -> None:
    """The live session keeps at most `HISTORY` samples, whatever patches did to it."""
    session = LiveSession({"mechanism": "upr4", "n_components": 16})
    for patch in (
        {"mechanism": "hybrid", "planner": "pi"},  # a restart: a new Simulation
        {"dt": 0.1},  # a restart too
        {"sea_state": 6.0, "speed": 8.0},  # a new sea, without a restart
        {"vessel": "barge"},
        {"beta": 0.2, "n_components": 64},
        {"mechanism": "upr4", "planner": "pid", "n_components": 16},
    ):
        session.patch(patch)
        session.step(HISTORY // 20)
        assert session._sim.history.capacity == HISTORY, patch  # the bound survives restarts
    session.step(HISTORY)
    assert len(session.series()["t"]) == HISTORY
    assert session.snapshot()["t"] > HISTORY * session.scenario.dt


def test_load_and_soak(tmp_path: Path) -> None:
    """Under concurrent viewers, patches, runs and a sweep the server fails nothing, loses no run,
    starts no process and stays finite."""
    began = time.monotonic()
    budget = scaled(BUDGET)  # the load now stretches it (tests/timing.py)
    server = Server(tmp_path)
    try:
        health = server.wait_ready()
        viser_port = health["viewer_port"]
        assert viser_port is not None, health
        started = time.monotonic() - began

        # -- warm-up: every path once, so imports, meshes and workers are loaded ----------------
        warm = Load()
        websocket_client(warm, viser_port, 1)
        with httpx.Client(base_url=server.url, timeout=PATCH_TIMEOUT) as client:
            for patch, status in WARM_UP:
                response = client.patch("/api/live", json=patch)
                assert response.status_code == status, (patch, response.text)
        runner(warm, server.url, seed=0, count=2)
        assert not warm.failures, warm.failures
        time.sleep(1.0)
        rss_before = server.rss_mb()
        warmed = time.monotonic() - began - started
        executor_before = httpx.get(f"{server.url}/api/health").json()["executor"]
        processes_before = {p.pid for p in psutil.Process(server.process.pid).children(True)}

        # -- the load: all at once ----------------------------------------------------------------
        load = Load()
        load_began = time.monotonic()
        submitted = httpx.post(f"{server.url}/api/sweeps", json=SWEEP, timeout=PATCH_TIMEOUT)
        assert submitted.status_code == 202, submitted.text
        sweep_id = submitted.json()["id"]
        jobs: list[tuple[str, Future[None]]] = []
        with ThreadPoolExecutor(CLIENTS + PATCH_THREADS + RUN_THREADS + 1) as pool:
            poller = pool.submit(health_poller, load, server.url)
            jobs += [(f"viewer {i}", pool.submit(websocket_client, load, viser_port, WS_ROUNDS))
                     for i in range(CLIENTS)]  # fmt: skip
            jobs += [(f"patcher {i}", pool.submit(patcher, load, server.url, 100 + i,
                                                  PATCHES // PATCH_THREADS))
                     for i in range(PATCH_THREADS)]  # fmt: skip
            jobs += [(f"runner {i}", pool.submit(runner, load, server.url, 200 + i,
                                                 RUNS_PER_THREAD))
                     for i in range(RUN_THREADS)]  # fmt: skip
            try:
                for name, job in jobs:  # a thread's exception (refused connection, ...) fails here
                    # the budget read again under the test's own load: read only at the start,
                    # an idle machine gave the jobs the least time (49.6 s, one plain CI run)
                    budget = max(budget, scaled(BUDGET))
                    wait = max(1.0, began + budget - 25.0 - time.monotonic())
                    try:
                        job.result(timeout=wait)
                    except TimeoutError:
                        late = [n for n, j in jobs if not j.done()]
                        raise AssertionError(
                            f"{name} not done {time.monotonic() - load_began:.1f} s into the load"
                            f" (waited {wait:.1f} s, budget {budget:.1f} s); still running: {late};"
                            f" {len(load.accepted)} runs accepted, {len(load.failures)} failures"
                        ) from None
            finally:
                load.stop.set()
                poller.result(timeout=HEALTH_LATENCY * load.stretch + 5.0)
        load_duration = time.monotonic() - load_began

        # -- afterwards ----------------------------------------------------------------------------
        with httpx.Client(base_url=server.url, timeout=PATCH_TIMEOUT) as client:
            deadline = time.monotonic() + scaled(20.0)
            pending = set(load.accepted)
            while pending and time.monotonic() < deadline:
                for run_id in sorted(pending):
                    run = client.get(f"/api/runs/{run_id}")
                    assert run.status_code == 200, (run_id, run.status_code, run.text)
                    if run.json()["status"] == "done":
                        pending.discard(run_id)
                    elif run.json()["status"] == "failed":
                        load.fail(f"run {run_id} failed: {run.json()['error']}")
                        pending.discard(run_id)
                time.sleep(0.2)
            assert not pending, f"accepted runs not done after the load: {sorted(pending)}"
            sweep: dict[str, Any] = {}

            def sweep_done() -> bool:
                nonlocal sweep
                sweep = client.get(f"/api/sweeps/{sweep_id}").json()
                return sweep["status"] in ("done", "failed")

            deadline = time.monotonic() + scaled(SWEEP_WAIT)
            while not sweep_done() and time.monotonic() < deadline:
                time.sleep(0.5)
            assert sweep["status"] == "done", sweep
            sweep_s = (datetime.fromisoformat(sweep["finished"])
                       - datetime.fromisoformat(sweep["created"])).total_seconds()  # fmt: skip
            assert (sweep["done"], sweep["total"]) == (1000, 1000)
            health = client.get("/api/health").json()
            assert health["executor"] == executor_before  # no cluster started since
            processes_after = {
                p.pid for p in psutil.Process(server.process.pid).children(True)
            }
            assert processes_after == processes_before, (processes_before, processes_after)
            listed = client.get("/api/runs", params={"limit": 500})
            assert listed.status_code == 200
            stored = set(load.accepted) & {run["id"] for run in listed.json()}

            # the live session: finite JSON (NaN would be parsed, then caught), still advancing
            live = client.get("/api/live")
            assert live.status_code == 200, live.text
            state = json.loads(live.text, parse_constant=float)
            assert not finite_numbers(state), finite_numbers(state)
            calm = client.patch("/api/live", json={"playing": True, "speed": 1.0, "dt": 0.05})
            assert calm.status_code == 200, calm.text
            time.sleep(1.0)
            later = client.get("/api/live").json()
            assert later["t"] >= calm.json()["t"] + 0.5, (calm.json()["t"], later["t"])
            assert not finite_numbers(later), finite_numbers(later)
            assert client.get("/api/health").status_code == 200
        time.sleep(1.0)
        rss_after = server.rss_mb()
    finally:
        stopping = time.monotonic()
        code = server.stop()
    duration = time.monotonic() - began

    record(
        "load_soak",
        clients=CLIENTS,
        websocket_connections=load.ws_connections,
        websocket_messages=load.ws_messages,
        websocket_mb=round(load.ws_bytes / 2**20, 1),
        websocket_first_message_max_s=round(max(load.ws_first), 3),
        websocket_first_message_median_s=round(median(load.ws_first), 4),
        patches=sum(load.patch_statuses.values()),
        patch_statuses={str(k): v for k, v in sorted(load.patch_statuses.items())},
        runs_submitted=sum(load.run_statuses.values()),
        run_statuses={str(k): v for k, v in sorted(load.run_statuses.items())},
        runs_accepted=len(load.accepted),
        runs_stored=len(stored),
        sweep_runs=sweep["total"],
        sweep_s=round(sweep_s, 1),
        executor=executor_before["scheduler"],
        executor_workers=executor_before["workers"],
        executor_starts=1,
        processes_started_during_load=len(processes_after - processes_before),
        startup_s=round(started, 1),
        warmup_s=round(warmed, 1),
        load_s=round(load_duration, 1),
        stop_s=round(time.monotonic() - stopping, 1),
        duration_s=round(duration, 1),
        rss_before_mb=round(rss_before, 1),
        rss_after_mb=round(rss_after, 1),
        rss_bound_mb=RSS_GROWTH_MB,
        patch_max_latency_s=round(max(load.patch_latency), 3),
        patch_median_latency_s=round(median(load.patch_latency), 4),
        health_polls=len(load.health),
        health_max_latency_s=round(max(load.health), 3),
        health_median_latency_s=round(median(load.health), 4),
    )
    assert not load.failures, f"{len(load.failures)} failures, first ones:\n" + "\n".join(
        load.failures[:15]
    )
    assert load.ws_connections == CLIENTS * WS_ROUNDS
    assert sum(load.patch_statuses.values()) == PATCHES
    assert set(load.patch_statuses) <= {200, 422}, load.patch_statuses
    assert load.accepted and stored == set(load.accepted)
    assert rss_after - rss_before < RSS_GROWTH_MB, (rss_before, rss_after)
    assert code == 0, server.log()
    assert duration < max(budget, scaled(BUDGET)), duration

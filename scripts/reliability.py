"""Run the reliability tests and write docs/reliability.md from the figures they measure.

python scripts/reliability.py [--out docs/reliability.md]

Runs the fuzzing, fault-injection, load, crash and attack tests with `TWIN_RELIABILITY_LOG`
set, so each records what it tried (`tests/figures.py`), and renders those figures as the
tables of docs/reliability.md. The tests are the same ones `make test` runs; only the figures
are new.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]

#: the tests that record figures, by section
FUZZ_TESTS = (
    "tests/sea/test_fuzz_sea.py",
    "tests/vessel/test_fuzz_vessel.py",
    "tests/mechanisms/test_fuzz_kinematics.py",
    "tests/planners/test_fuzz_planners.py",
    "tests/web/test_fuzz_api.py",
)
FAULT_TESTS = ("tests/sim/test_faults.py",)
LOAD_TESTS = ("tests/web/test_load.py", "tests/web/test_crash.py")
BOUNDARY_TESTS = ("tests/web/test_limits.py", "tests/web/test_cli.py")
#: issue 30's tests (bounded work, fair limits, connections, exports, disk)
ISSUE30_TESTS = (
    "tests/web/test_jobs.py",
    "tests/web/test_access.py",
    "tests/web/test_connections.py",
    "tests/web/test_export.py",
    "tests/web/test_store.py",
)
ATTACK_TESTS = (
    "tests/web/test_api.py",
    "tests/web/viewer/test_handshake.py",
    "tests/web/viewer/test_panel.py",
    "tests/web/viewer/test_readout.py",
    "tests/web/viewer/test_browser.py",
    "tests/sim/test_live.py",
)

#: the attacks of issue 13, by the figure their test records: (attack, what happens now, test)
ATTACKS = {
    "attack_cross_origin_websocket": (
        "a page from another origin opens the 3D viewer's websocket (no token: the loopback "
        "default) to change the sea, the planner, play/pause",
        "the handshake is refused (403) unless its Origin is one of the server's own (http on an "
        "allowed host at the viewer or REST port) or `--allow-origin`; nothing is read or sent",
        "viewer/test_handshake.py (raw websocket client)",
    ),
    "attack_cross_origin_websocket_browser": (
        "the same from a real page of another origin in Chromium",
        "the browser's WebSocket fails at the handshake; the session is untouched",
        "viewer/test_browser.py",
    ),
    "attack_locked_widget_write": (
        "a browser that has not entered the token writes widgets: values, any property of a "
        "shared handle (`update_cb`, `removed`), another browser's widget ids, a share-tunnel "
        "request",
        "every browser has its own widgets (viser client handles), read-only until it unlocks; "
        "its writes are undone on its own widgets and reach neither the session nor another "
        "browser; share-tunnel requests are not handled at all",
        "viewer/test_panel.py (raw websocket client), viewer/test_browser.py",
    ),
    "attack_host_spoofing": (
        "DNS rebinding: a request whose Host names another site and whose Origin matches it",
        "400 before anything is read (Host allow-list: loopback names, the bind address, "
        "`--allow-host`); Origin is compared as scheme + host + port with the server's own "
        "origins, never with Host (403)",
        "test_api.py",
    ),
    "attack_viewer_host_spoofing": (
        "DNS rebinding or a spoofed Host on the 3D viewer's port: a websocket handshake or a "
        "page request whose Host names another site (`evil.example`, `evil.example:PORT`, "
        "whatever its Origin), or carries no Host",
        "400 naming the Host, before viser serves anything (the REST API's Host allow-list: "
        "loopback names, the bind address, `--allow-host`): the page is not served, no "
        "websocket opens, no panel is built, a warning is logged; its own names "
        "(`127.0.0.1:PORT`, `localhost:PORT`, an `--allow-host` name) are served",
        "viewer/test_handshake.py (raw websocket client, http.client)",
    ),
    "attack_refused_patch": (
        "`PATCH /api/live` with an empty or unknown name (`{\"planner\": \"\"}`), a bad "
        "name beside a good field, `playing` as a string or number",
        "422 naming the field; the session, its planner and its controls are unchanged, reset "
        "and stepping go on; `playing` is a strict bool",
        "test_api.py, tests/sim/test_live.py",
    ),
    "attack_refused_run": (
        "a run the request's checks let through but the engine refuses before its first step "
        "(and runs of zero steps, empty planner names)",
        "422 naming the field, and nothing stored (no run left behind as failed)",
        "test_api.py",
    ),
    "attack_costly_sync_run": (
        "a synchronous run within the step cap but with the costliest knobs (200 000 steps, "
        "2048 wave components)",
        "each run has a wall-clock budget (`--run-budget`, 60 s) besides the step cap: past it "
        "the worker stops it, it is stored as failed saying how far it got, and the request is "
        "answered",
        "test_api.py (a 0.05 s budget)",
    ),
    "attack_sigterm_with_run_open": (
        "SIGTERM (`docker stop`) while both workers run long runs and a synchronous request "
        "waits behind them",
        "the waiting request is answered 503 (its run stays queued), futures are cancelled, "
        "busy workers killed, and the server exits 0 well within 10 s; unfinished runs are left "
        "queued and run on the next start",
        "test_cli.py",
    ),
    "attack_two_servers": (
        "a second `twin serve` on the same data directory",
        "it exits 2 before starting anything, naming the pid of the server holding the "
        "directory's OS file lock (`flock`); the first is untouched",
        "test_cli.py",
    ),
    "attack_deleted_store": (
        "the run store's file deleted, or replaced by another, while the server runs",
        "the store notices (device and inode) and answers every access 503 saying so, health "
        "too; nothing is written where nobody could read it back; the live twin goes on",
        "test_api.py",
    ),
    "attack_long_step": (
        "`POST /api/live/step?n=1000` on costly steps while others read `GET /api/live`",
        "the lock is taken 16 steps at a time and let go between; stepping stops at a "
        "wall-clock cap (2 s) and says how many steps it took (`X-Steps-Taken`)",
        "test_api.py, tests/sim/test_live.py",
    ),
    "attack_token_guessing": (
        "short tokens, and guessing the token",
        "a token needs ≥ 16 characters (exit 2 otherwise); past 10 wrong tokens like one "
        "another (the same client and token prefix) a client is refused (429, Retry-After) "
        "before its next such guess is compared; the right token never is (issue 30); the "
        "viewer's unlock likewise",
        "test_api.py, viewer/test_panel.py, test_cli.py",
    ),
    "load_soak": (
        "four executors (a process pool for runs, a Dask cluster per sweep, a pool in "
        "reproduce.py, numba threads)",
        "one Dask executor started once with the server (a LocalCluster of one worker per core, "
        "kernels warmed on each, or `--scheduler`); runs and sweeps are futures on it with "
        "progress from the workers; `twin sweep` uses the same code, and scripts map over "
        "it with `twin.runs.executor.map_unordered`",
        "test_load.py",
    ),
}

#: what each injected fault is, and what the twin does about it
FAULTS = {
    "fault_nan_base_hybrid": "NaN base motion for 0.5 s, hybrid system",
    "fault_nan_base_upu3up": "NaN base motion for 0.5 s, 3UPU_UP",
    "fault_nan_base_upr4": "NaN base motion for 0.5 s, 4-UPR",
    "fault_near_singular": "tip Jacobian forced near-singular (σ_min = 1e-9), MTMP",
    "fault_joint_limit": 'PI driving the legs past their stroke, `joint_limits="hold"`',
}

#: (boundary, what is checked, what a bad value gets, tests)
BOUNDARIES = (
    (
        "REST bodies (`POST /api/runs`, `PATCH /api/live`, `POST /api/sweeps`)",
        "pydantic models with a range on every number, finite numbers only "
        "(`allow_inf_nan=False`), names from the registries (an empty name is refused, not "
        "defaulted), `duration ≤ 3600 s`, 1 ≤ `duration/dt` ≤ 200 000 steps, `initial_state` "
        "within the mechanism's state limits (≤ 9 values), `playing` strictly true or false, "
        "sweep grids within `MAX_CELLS`, `MAX_RUNS`, `MAX_TOTAL_STEPS`, no unknown field",
        "422: each field's `loc`, `msg` and `allowed` range, `message` in one line; nothing "
        "stored or changed",
        "tests/web/test_api.py, test_limits.py, test_fuzz_api.py",
    ),
    (
        "request size",
        "body ≤ 64 KiB, on the declared length and while a chunked body streams",
        "413 before the app reads it",
        "test_limits.py",
    ),
    (
        "run submission",
        "per client 20 at once, then 5 per second; ≤ 200 runs and ≤ 4 sweeps queued",
        "429 with `Retry-After`; nothing stored",
        "test_limits.py, test_load.py",
    ),
    (
        "paths",
        "none taken: a vessel is a shipped RAO table by name (a path is for Python only); "
        "mechanisms and planners by registry name",
        "422 naming `vessel`",
        "test_limits.py",
    ),
    (
        "CLI",
        "`--host` an IP or host name, ports 1–65535, `--allow-host` names, `--allow-origin` "
        "scheme://host[:port], `--workers` 1–256, `--run-budget` 0–3600 s, scenario and sweep "
        "files ≤ 1 MiB and valid models, output suffixes, a token (≥ 16 characters) for a "
        "bind other than loopback, a data directory no other server holds",
        "exit 2 with the reason",
        "test_cli.py",
    ),
    (
        "GUI",
        "every widget is the browser's own and goes through `LiveSession.patch` (the model "
        "REST uses); slider ranges come from the fields; read-only until the token is entered",
        "a red notification; the widget returns to the value in force, for that browser only",
        "viewer/test_panel.py",
    ),
    (
        "mechanism, sea and planner math",
        "shapes, finite values and the range of every argument",
        "`ValueError` (a `TwinError`) naming the argument and its range",
        "tests/*/test_fuzz_*.py",
    ),
)


def boundary_table() -> str:
    rows = ["| boundary | what is checked | a bad value gets | tests |", "|---|---|---|---|"]
    rows += [f"| {' | '.join(row)} |" for row in BOUNDARIES]
    return "\n".join(rows)


def security(records: list[dict[str, Any]]) -> str:
    refused = next((r["unauthorized"]["requests"] for r in records if r["test"] == "rest_fuzz"), 0)
    return SECURITY.replace("UNAUTHORIZED", f"{refused:,}")


ISSUE30_INTRO = """\
Every request's work is bounded before it starts, and every job can be cancelled; limits are
fair per client; connections time out; exports stream; the store has a quota. Bounds:

- **a request**: priced (`twin.web.limits.price_run`, `price_sweep`) in steps, cells, heatmap
  panels and stored bytes; over a limit is a 422 naming it (`MAX_PANELS` = 36 heatmap panels
  beside `MAX_CELLS`, `MAX_RUNS`, `MAX_TOTAL_STEPS`), over the store's quota a 507;
- **a connection**: its request within 10 s (`REQUEST_TIMEOUT`), idle keep-alive 5 s, 128
  per client address, `connection_cap()` in all: min(1000, (fd limit − 256) / 2);
- **an export**: the run's stored (compressed) series, its time column and one row group of
  the columns asked for: ≤ blob + 8 B × samples + 16,384 × columns × 48 B
  (`export.memory_bound`); measured on a 200,000-step run (45.5 MB stored, 177 MB of JSON):
  RSS +7 MB for JSON, +45 MB for CSV (was: the 145 MB body, RSS +764 MB); 2 at once;
- **SIGTERM**: the sweep in hand, its heatmap task and waiting requests stop at once; the
  server exits within `docker stop`'s 10 s;
- **defaults**: `--private` off (reading stored data needs no token; with it, and a token,
  it does), `--forwarded-allow-ips` none, the Dask dashboard off (`--dashboard`: on
  127.0.0.1), no store quota."""

SECURITY = """\
- **Bind**: `twin serve` binds 127.0.0.1 unless `--host` says otherwise; the Docker image
  binds 0.0.0.0. One server per data directory (an OS file lock).
- **Host**: every request's Host, REST and the 3D viewer's port alike (its page, its assets
  and its websocket handshake), must be a loopback name, the bind address or an
  `--allow-host` name (400 otherwise): a page reached through a DNS name of its own (DNS
  rebinding) is refused before anything is read.
- **Origin**, as scheme + host + port: a browser POST or PATCH, and the viewer's websocket
  handshake, must come from one of the server's own origins (http on an allowed host at the
  REST or viewer port) or an `--allow-origin` one (403 otherwise). No CORS headers are sent.
- **Token**: any bind other than loopback needs `TWIN_TOKEN`, of at least 16 characters;
  without one `twin serve` refuses to start (exit 2). With a token, every POST, PATCH and
  DELETE needs `Authorization: Bearer <token>` (and with `--private` every GET of stored runs
  and sweeps), checked in constant time (`hmac.compare_digest`) by an ASGI middleware before
  the body is read, so an unknown client learns nothing from a malformed body (401 either
  way); past 10 wrong tokens with the same prefix a client gets 429 until it has waited,
  before such a guess is compared; the right token is never refused for others' failures.
  The client address is the socket's unless `--forwarded-allow-ips` names trusted proxies.
  Each browser unlocks the 3D viewer's controls by entering the token in its own panel
  (rate-limited alike); until then its controls are read-only, for it alone. Tested:
  test_cli.py (refusal; a 0.0.0.0 server that answers 401 without the token and
  200 with it), test_fuzz_api.py (UNAUTHORIZED requests without the token), test_api.py (the
  failure limit), viewer/test_panel.py (locked and unlocked browsers over raw websockets),
  viewer/test_browser.py (a real Chromium that unlocks with the token).
- **Viewer**: every browser has its own widgets (viser client handles): nothing it sends
  reaches another browser's widgets or shared widget state; viser's share-tunnel requests
  are not handled (any browser could otherwise ask the server for a public tunnel).
- **No paths from requests**; **rate and size limits** on submission (above).
- **Executor**: the Dask scheduler, workers and their HTTP endpoints listen on 127.0.0.1
  only, on free ports. Scheduler and workers take pickled functions from whoever connects, so
  they speak mutual TLS with a key made for the cluster and held only in the server's memory
  (`Security.temporary()`): another local user, in plain TCP or with a key of their own, is
  turned away (tests/runs/test_sweep.py). Their HTTP endpoints (health, metrics, task info)
  are read-only; the scheduler's dashboard is off unless `--dashboard` asks for it (then on
  127.0.0.1). `--scheduler` joins a cluster the operator secures.
- **Docker** runs as the non-root user `twin` (uid 10001) and stops on `docker stop` (SIGTERM,
  handled: PID 1 would ignore it otherwise); tests/web/test_cli.py checks the Dockerfile and
  tests/web/test_dockerfile.py replays its install.
"""


def run_tests(log: Path, tests: tuple[str, ...] | None = None, soak: bool = True) -> float:
    """Run every reliability test (or `tests`) with the figure log, then the short soak
    (`scripts/soak.py --short`, which records its figures as "soak"); [s] it took."""
    if tests is None:
        tests = (*FUZZ_TESTS, *FAULT_TESTS, *LOAD_TESTS, *BOUNDARY_TESTS, *ATTACK_TESTS,
                 *ISSUE30_TESTS)  # fmt: skip
    start = time.monotonic()
    env = {**os.environ, "TWIN_RELIABILITY_LOG": str(log)}
    subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *tests],
        cwd=ROOT, env=env, check=True,
    )  # fmt: skip
    if soak:
        subprocess.run(
            [sys.executable, str(ROOT / "scripts" / "soak.py"), "--short"], cwd=ROOT, env=env,
            check=True,
        )  # fmt: skip
    return time.monotonic() - start


def read(log: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in log.read_text().splitlines() if line.strip()]


def fuzz_table(records: list[dict[str, Any]]) -> str:
    rows = ["| suite | properties / operations | inputs | outcome |", "| --- | --- | --- | --- |"]
    outcome = {
        "tests/sea/test_fuzz_sea.py": "spectra, sea-state table, wave components and "
        "elevation finite and consistent (energy, bounds); bad input names the argument",
        "tests/vessel/test_fuzz_vessel.py": "vessel and base motion finite, bounded by the "
        "RAOs, rigid; bad input names the argument",
        "tests/mechanisms/test_fuzz_kinematics.py": "IK, FK, Jacobians finite; FK(IK(x)) = x; "
        "FK from any stroke lengths converges or raises a TwinError within its iterations",
        "tests/planners/test_fuzz_planners.py": "every planner's step finite and within its "
        "rate limits; damped pseudo-inverse bounded near singularities; bad knobs refused",
    }
    by_file: dict[str, list[int]] = defaultdict(list)
    for r in records:
        if r.get("kind") == "hypothesis":
            by_file[r["test"].split("::")[0]].append(int(r["examples"]))
    total = 0
    for path, examples in sorted(by_file.items()):
        total += sum(examples)
        rows.append(
            f"| hypothesis, `{path}` | {len(examples)} properties | {sum(examples):,} "
            f"| {outcome.get(path, 'no NaN or inf out')} |"
        )
    for r in records:
        if r["test"] != "rest_fuzz":
            continue
        statuses = ", ".join(f"{k}: {v}" for k, v in r["statuses"].items())
        rows.append(
            f"| schemathesis, OpenAPI of the app, with the token (seed {r['seed']}, "
            f"≤ {r['max_examples']} per operation) | {r['operations']} operations | "
            f"{r['requests']:,} requests | no 5xx; schema, status, header and content-type "
            f"conformance; strict JSON (no NaN); a refusal changes nothing ({statuses}; the "
            "401s are schemathesis's own probes without credentials) |"
        )
        u = r["unauthorized"]
        statuses = ", ".join(f"{k}: {v}" for k, v in u["statuses"].items())
        rows.append(
            f"| schemathesis, without the token | {u['operations']} mutating operations | "
            f"{u['requests']:,} requests | every one refused, nothing changed ({statuses}) |"
        )
        total += r["requests"] + u["requests"]
    rows.append(f"| **total** | | **{total:,}** | |")
    return "\n".join(rows)


def fault_table(records: list[dict[str, Any]]) -> str:
    rows = [
        "| fault injected | steps affected | what the twin did | measured |",
        "| --- | --- | --- | --- |",
    ]
    for r in records:
        name = r["test"]
        if not name.startswith("fault_"):
            continue
        figures = ", ".join(f"{k} = {v:.3g}" if isinstance(v, float) else f"{k} = {v}"
                            for k, v in r.items() if k != "test")  # fmt: skip
        action = {
            "fault_near_singular": "damped least squares (λ > 0), flagged `singular`",
            "fault_joint_limit": "each step shortened at the limit, flagged `joint_limit`",
        }.get(
            name,
            "last finite base pose held, flagged `base_motion`, counted in `faults`; no NaN in "
            "any record (nor, in test_api.py and viewer/test_readout.py, in a REST answer or scene "
            "node)",
        )
        rows.append(f"| {FAULTS.get(name, name)} | {r.get('steps', '')} | {action} | {figures} |")
    rows += [
        "| planner raises (ConvergenceError inside the hybrid planner) | 1 | state held for "
        "the step, flagged `kinematics`, message kept | next step moves on |",
        "| small-platform forward kinematics does not converge (3UPU_UP, 4-UPR) | 3 | platform "
        "held, flagged `kinematics` | state at steps 3–5 = step 2 |",
        "| the sea cannot be evaluated at all (raises) | > 100 | base held | finite series |",
        "| an unexpected exception inside the live loop | 1 | logged, `loop_errors` + 1 | "
        "simulated time goes on |",
    ]
    return "\n".join(rows)


def load_summary(records: list[dict[str, Any]]) -> str:
    """One sentence per test: what load was held, for how long, at what memory."""
    lines = []
    for r in records:
        if r["test"] == "load_soak":
            lines.append(
                f"**Held:** {r['clients']} viewer clients ({r['websocket_connections']} "
                f"websocket connections), {r['patches']:,} random PATCHes and "
                f"{r['runs_submitted']} concurrent runs ({r['runs_accepted']} accepted, "
                f"{r['runs_stored']} stored and done) and a {r['sweep_runs']:,}-run sweep (done "
                f"in {r['sweep_s']:.0f} s) on one executor, in {r['load_s']:.0f} s of load; health "
                f"answered within {r['health_max_latency_s']:.2f} s, a PATCH within "
                f"{r['patch_max_latency_s']:.2f} s; server memory (RSS) "
                f"{r['rss_before_mb']:.0f} MB before, {r['rss_after_mb']:.0f} MB after "
                f"(bound: +{r['rss_bound_mb']:.0f} MB)."
            )
        elif r["test"] == "crash_recovery":
            lines.append(
                f"**Killed:** {r['kills']} SIGKILLs mid-write ({', '.join(r['kill_moments'])}); "
                f"after each, `integrity_check` {r['integrity']}, journal {r['journal_mode']}, "
                f"all {r['runs_accepted']} accepted runs present; on restart "
                f"{r['runs_recovered']} of {r['runs_unfinished_at_last_kill']} unfinished runs "
                f"recovered to done; orphaned workers left alive: "
                f"{r['orphans_alive_before_cleanup']}."
            )
    return "\n\n".join(lines)


def load_table(records: list[dict[str, Any]]) -> str:
    rows = ["| test | figure | value |", "| --- | --- | --- |"]
    for r in records:
        if r["test"] not in ("load_soak", "crash_recovery"):
            continue
        for key, value in r.items():
            if key == "test":
                continue
            shown = f"{value:.3g}" if isinstance(value, float) else json.dumps(value)
            rows.append(f"| {r['test']} | {key} | {shown} |")
    return "\n".join(rows)


def _figures(record: dict[str, Any]) -> str:
    return ", ".join(
        f"{k} = {v:.3g}" if isinstance(v, float) else f"{k} = {v}"
        for k, v in record.items()
        if k != "test"
    )


def attack_table(records: list[dict[str, Any]]) -> str:
    """One row per attack of issue 13: what was tried, what happens now, what was measured."""
    rows = [
        "| attack | what happens now | measured | test |",
        "| --- | --- | --- | --- |",
    ]
    for name, (attack, now, test) in ATTACKS.items():
        found = [r for r in records if r["test"] == name or r["test"].startswith(f"{name}[")]
        if not found:
            measured = "not run"
        elif name == "load_soak":
            r = found[0]
            measured = (
                f"{r['sweep_runs']:,}-run sweep of 200 s runs in {r['sweep_s']:.0f} s beside "
                f"{r['runs_accepted']} concurrent runs, on the {r['executor']} of "
                f"{r['executor_workers']} workers started once ({r['executor_starts']} start, "
                f"{r['processes_started_during_load']} processes started during the load)"
            )
        elif len(found) > 1:
            statuses = sorted({str(r.get("status")) for r in found})
            measured = f"{len(found)} bodies, answered {', '.join(statuses)}, changed nothing"
        else:
            measured = _figures(found[0])
        rows.append(f"| {attack} | {now} | {measured} | {test} |")
    return "\n".join(rows)


#: issue 30's attacks, by the figure their test records: (attack, what happens now, test)
ISSUE30 = {
    "attack30_heatmap": (
        "`POST /api/sweeps` of one cell at 5,000 headings: 5,000 one-step runs, then 5,000 "
        "matplotlib panels built in the server process (77 min, 6.6 GB, health timed out; "
        "requeued at every restart)",
        "every request is priced before it starts (`limits.price_sweep`: steps, cells, panels, "
        "bytes); over `MAX_PANELS` (36) heatmap panels is a 422 naming the limit and the axis, "
        "nothing stored; `heatmap_png` draws at most `MAX_PANELS` in any case",
        "test_jobs.py",
    ),
    "attack30_heatmap_process": (
        "the heatmap drawn in the process that answers requests",
        "drawn by a task on the executor (`heatmap_bytes`, a worker process), waited for in "
        "0.2 s steps so a stop or a cancel does not wait for it",
        "test_jobs.py",
    ),
    "attack30_cancel": (
        "no REST call cancels a sweep (or a run)",
        "`POST /api/{runs,sweeps}/{id}/cancel` and `DELETE /api/{runs,sweeps}/{id}` (token "
        "needed): a queued or running job becomes failed, `cancelled by request`; the sweep "
        "in hand stops at its next chunk, the queue goes on",
        "test_jobs.py",
    ),
    "attack30_requeue": (
        "a job that ties the server up is requeued at every restart",
        "a job started `MAX_ATTEMPTS` (3) times without finishing is failed on the next start, "
        "saying so, instead of being queued again",
        "test_jobs.py",
    ),
    "attack30_pending_sweeps": (
        "8 sweeps pending against `MAX_PENDING_SWEEPS` = 4 over REST, 10 from the viewer's "
        "button",
        "the cap is checked in the same write transaction as the insert, on every surface "
        "(`actions.submit_sweep`, which REST and the viewer call): 429 beyond it",
        "test_jobs.py",
    ),
    "attack30_lockout": (
        "ten wrong PATCHes from an address make the token holder's right one a 429",
        "wrong tokens are limited per (client, token prefix); the right token is never "
        "refused for anyone else's failures, from the same address, a NAT or a proxy",
        "test_access.py, test_api.py",
    ),
    "attack30_xff": (
        "X-Forwarded-For picks the client address (uvicorn trusts it from loopback)",
        "the client is the socket's peer unless `--forwarded-allow-ips` names trusted proxies "
        "(off by default)",
        "test_access.py (a real uvicorn)",
    ),
    "attack30_nagle": (
        "every keep-alive answer waits ~45 ms (a protocol-0 socket: no TCP_NODELAY)",
        "the REST socket is IPPROTO_TCP with TCP_NODELAY, so is every connection it accepts "
        "and the viewer's; `make bench` measures GET /api/health and a 60 s run's POST p50 "
        "beside a minimal FastAPI peer (docs/performance.md)",
        "test_connections.py, benchmarks/server.py",
    ),
    "attack30_slowloris": (
        "20,000 idle or half-sent connections: the fd limit, /api/health timed out, 55,232 "
        "tracebacks",
        "a request (headers and body) must arrive within 10 s (408, closed); idle keep-alives "
        "close after 5 s; at most 128 connections per client address and `connection_cap()` "
        "in all (below the fd limit), more closed at once, before they are read",
        "test_connections.py",
    ),
    "attack30_accept_log": (
        "one traceback in the log per failed accept",
        "accept errors and refusals are counted and logged once per minute",
        "test_connections.py",
    ),
    "attack30_export": (
        "the JSON series of a 200,000-step run built whole in memory (145 MB, RSS +764 MB)",
        "CSV, Parquet and JSON stream a row group (16,384 samples) at a time, encoded 512 "
        "samples a call; `columns`, `every`, `t0`, `t1` select part of a run; at most 2 "
        "exports stream at once (429 beyond); `--private` puts stored data behind the token",
        "test_export.py",
    ),
    "attack30_disk": (
        "the store grows without bound (73.6 MB per 200,000-step run, no quota, no delete)",
        "series stored as zstd Parquet (368 → 266 bytes per step); `--max-store`, "
        "`--max-runs`: a submission that would pass them is a 507 saying what to do; "
        "`--retain` deletes the oldest finished unpinned results instead; DELETE frees room",
        "test_jobs.py, test_store.py",
    ),
    "attack30_corrupt_store": (
        "a corrupt store at start-up: a raw sqlite traceback after 23 s",
        "one line naming the file and what to do, before the executor starts",
        "test_store.py",
    ),
    "attack30_bad_row": (
        "one store row with invalid JSON makes `GET /api/runs` a 500",
        "that row is listed as failed, saying it is unreadable; the rest as stored",
        "test_store.py",
    ),
    "attack30_viewer_origin": (
        "the viewer moved off a squatted port but still trusted the squatter's origin",
        "the viewer trusts the REST port's origin and its own actual port's only",
        "test_connections.py",
    ),
    "attack30_malformed": (
        "a malformed viewer message logs a 730-byte traceback each time",
        "one line per client address per minute, with the count",
        "test_connections.py",
    ),
}


def issue30_table(records: list[dict[str, Any]]) -> str:
    """One row per attack of issue 30."""
    rows = ["| attack | what happens now | measured | test |", "| --- | --- | --- | --- |"]
    for name, (attack, now, test) in ISSUE30.items():
        found = [r for r in records if r["test"] == name]
        measured = _figures(found[0]) if found else "not run"
        rows.append(f"| {attack} | {now} | {measured} | {test} |")
    return "\n".join(rows)


def soak_table(records: list[dict[str, Any]]) -> str:
    """The soak's figures (`scripts/soak.py`), one row each."""
    found = [r for r in records if r["test"] == "soak"]
    if not found:
        return "not run"
    rows = ["| figure | value |", "| --- | --- |"]
    rows += [f"| {k} | {json.dumps(v)} |" for k, v in found[-1].items() if k != "test"]
    return "\n".join(rows)


def render(records: list[dict[str, Any]], elapsed: float) -> str:
    today = datetime.date.today().isoformat()
    return f"""# Reliability: bad input, numerical faults, load, access

What was tried to make the twin fall over, and what it did. Every figure below was measured
by the tests named, on {today}, in one run of `python scripts/reliability.py` ({elapsed:.0f} s
on this 2-core machine); the same tests run in `make test` (CI), where they record nothing.

## Bad input: validation at every boundary

{boundary_table()}

## Inputs fuzzed

{fuzz_table(records)}

## Numerical faults injected (tests/sim/test_faults.py, web/test_api.py, web/viewer/test_readout.py)

A step never raises for a numerical reason and never records NaN (docs/simulation.md): it
holds, damps or clamps, and flags the step. Flags are counted in a run's `fault_counts`, and
live in `GET /api/live`'s `faults` (counts, steps held, the newest events) and on the
viewer's readout, which keeps apart steps a fault held ("⚠ Faults: …"), steps shortened at a
limit or damped ("Limit handling") and samples beyond a limit ("Limit violations").

{fault_table(records)}

## Load, soak and crash (tests/web/test_load.py, tests/web/test_crash.py)

A real `twin serve` process on loopback; the tests stop by themselves.

{load_summary(records)}

The memory bound allows for what a first burst allocates and keeps (viser's message buffers,
the executor's client, numpy's caches): while writing the test, repeated rounds on one server
moved by +50 to +110 MB for patches with no trend, websocket rounds flattened below 1 MB a
round, run rounds added 9 MB in all. The live history is the `HISTORY` ring buffer (2,000
samples), checked through restarts and sea changes.

{load_table(records)}

## Attacks tried on loopback, and what happens now (issue 13)

{attack_table(records)}

## A server strangers cannot tie up (issue 30)

{ISSUE30_INTRO}

{issue30_table(records)}

### Soak (`scripts/soak.py --short`; `python scripts/soak.py` runs 30 minutes)

{soak_table(records)}

## Access

{security(records)}"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "reliability.md")
    parser.add_argument("--no-soak", action="store_true", help="leave out scripts/soak.py")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        log = Path(folder) / "figures.jsonl"
        elapsed = run_tests(log, soak=not args.no_soak)
        records = read(log)
    args.out.write_text(render(records, elapsed))
    print(f"wrote {args.out} from {len(records)} records")


if __name__ == "__main__":
    main()

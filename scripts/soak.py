"""Soak a real `twin serve` with the attacks of issue 30 beside ordinary use, and check it held.

    python scripts/soak.py                 # 30 minutes, 100 viewers, a 5,000-connection slowloris
    python scripts/soak.py --short         # the CI form: under 60 s, 10 viewers, 500 connections
    python scripts/soak.py --minutes 5 --json soak.json
    python scripts/soak.py --uploads       # issue 43: the five workability-upload attacks, each
                                           # alone, health and RSS measured during each

One server (`python -m twin.cli serve`, token mode, a local cluster of `--workers` workers, in
its own process group and data directory) is driven, all at once, by:

- **mixed load** from 127.0.0.1: runs of 5-60 s submitted, listed, read back, exported (CSV
  and JSON, part of them selected with `every`), some cancelled and deleted; small sweeps;
- **viewers**: `--viewers` websocket clients of the 3D viewer that announce themselves as a
  browser does (its camera: the render loop then draws for them) and read every frame, in a
  process of their own;
- **slowloris** from 127.0.0.2: `--slowloris` connections, each sending a header byte a
  second and never finishing its request, opened again as soon as the server closes them;
- **the heatmap attack**: a sweep of 5,000 headings (must be refused, 422) and one at the
  panel limit (must finish, its heatmap drawn on the executor);
- **a long run's exports**: a 200,000-step run (20,000 in the short form) exported as JSON
  three times at once.

`/api/health` is polled every 0.25 s from 127.0.0.1 throughout. At the end the slowloris
stops and the server must serve again within `RECOVERY` s; then a sweep is left running and
the server gets SIGTERM (as `docker stop` sends), which it must obey within 10 s; the store is
opened afterwards and every run the soak was told was accepted (and did not delete) must be in
it. Checks (exit 1 if one fails): health p99 < 1 s, the server's RSS under `--rss-bound` MB,
nothing accepted lost, the attack refused, SIGTERM within 10 s. The figures print as a table
(docs/reliability.md's issue-30 rows come from it) and, with `--json`, go to a file.

`--uploads` (issue 43) is a bounded soak of its own: the same server (token mode, 2 workers),
then each upload attack alone, /api/health polled every 0.05 s and the server's RSS every
0.2 s while it lasts: (1) wide scatter tables of 20,000, 50,000 and 400,000 Tp columns;
(2) 101 rows 1 ns apart and one 60 ms later (a 6e7-step grid); (3) a 150,000-row record at 24
headings (accepted: its evaluation runs on a worker) and a 200,000-row one at 36 (refused);
(4) 80 submit-and-cancel cycles of a 2 MB padded record under a 50 MB `--max-store`;
(5) 15 wrong tokens sharing the holder's first 8 characters, each sent 11 times, then the
holder's; a header-only, a 2-row and a NUL record. Each must be refused or bounded (a
request answered within `UPLOAD_ANSWER` s), health p99 ≤ `UPLOAD_HEALTH_P99` s and the RSS
growth ≤ `UPLOAD_RSS_GROWTH` MB during it; then SIGTERM with a 400,000-column upload in flight
must end the server within 10 s, its data directory locked until it is gone.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import multiprocessing
import os
import random
import resource
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import psutil

ROOT = Path(__file__).resolve().parents[1]
TOKEN = "soak-token-0123456789abcdef"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
#: [s] how soon the server must serve again once a flood stops
RECOVERY = 15.0
#: [s] what `docker stop` allows before SIGKILL
STOP_BUDGET = 10.0
#: [s] the p99 of /api/health the server must stay under
HEALTH_P99 = 1.0
#: issue 43's bounds during each upload attack: [s] health p99, [MB] RSS growth, [s] an
#: upload's answer
UPLOAD_HEALTH_P99 = 0.1
UPLOAD_RSS_GROWTH = 200.0
UPLOAD_ANSWER = 1.0
#: a tiny evaluation (1 planner, 1 seed, 2 s runs, 8 cells per heading)
UPLOAD_SPEC = {"planners": ["mtmp"], "seeds": 1, "duration": 2.0, "hs_grid": [1.0, 2.0, 3.0, 4.0],
               "tp_grid": [8.0, 12.0], "window_hours": [6.0]}  # fmt: skip


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Soak:
    """The server under test and what was measured."""

    def __init__(
        self, folder: Path, workers: int, worker_nice: int = 0, options: tuple[str, ...] = ()
    ) -> None:
        self.port, self.viser_port = free_port(), free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.data = folder / "data"
        self.log_path = folder / "server.log"
        args = [
            sys.executable, "-m", "twin.cli", "serve", "--host", "127.0.0.1",
            "--port", str(self.port), "--viser-port", str(self.viser_port),
            "--data-dir", str(self.data), "--workers", str(workers),
            "--worker-nice", str(worker_nice), *options,
        ]  # fmt: skip
        with self.log_path.open("wb") as log:
            self.process = subprocess.Popen(
                args, cwd=folder, stdout=log, stderr=subprocess.STDOUT,
                env={**os.environ, "TWIN_TOKEN": TOKEN}, start_new_session=True,
            )  # fmt: skip
        self.stop = threading.Event()
        self.lock = threading.Lock()
        self.health: list[float] = []
        self.health_errors = 0
        self.rss: list[float] = []
        self.load: list[float] = []  # the machine's 1-minute load average, as sampled
        self.accepted: set[str] = set()
        self.protected: set[str] = set()  # the long run: the mixed load leaves it alone
        self.deleted: set[str] = set()
        self.statuses: Counter[str] = Counter()
        self.failures: list[str] = []
        self.figures: dict[str, Any] = {}
        self.ws_messages = 0
        self.ws_connected = 0

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")[-3000:]

    def wait_ready(self, timeout: float = 300.0) -> float:
        """[s] until /api/health says `ok` (not `warming`): the soak measures a running
        server, not its start-up."""
        start = time.monotonic()
        while time.monotonic() - start < timeout:
            if self.process.poll() is not None:
                raise SystemExit(f"server exited early:\n{self.log()}")
            try:
                health = httpx.get(f"{self.url}/api/health", timeout=2)
                if health.status_code == 200 and health.json().get("status", "ok") == "ok":
                    self.viser_port = health.json().get("viewer_port") or self.viser_port
                    return time.monotonic() - start
            except httpx.TransportError:
                pass
            time.sleep(0.2)
        raise SystemExit(f"server not ready after {timeout} s:\n{self.log()}")

    def count(self, what: str) -> None:
        with self.lock:
            self.statuses[what] += 1


# -- the drivers ---------------------------------------------------------------------------------


def health_poller(soak: Soak) -> None:
    with httpx.Client(base_url=soak.url, timeout=30) as http:
        while not soak.stop.is_set():
            start = time.perf_counter()
            try:
                ok = http.get("/api/health").status_code == 200
            except httpx.HTTPError:
                ok = False
            elapsed = time.perf_counter() - start
            with soak.lock:
                soak.health.append(elapsed if ok else float("inf"))
                soak.health_errors += not ok
            soak.stop.wait(0.25)


def rss_sampler(soak: Soak) -> None:
    process = psutil.Process(soak.process.pid)
    while not soak.stop.is_set():
        try:
            soak.rss.append(process.memory_info().rss / 2**20)
        except psutil.Error:
            return
        # the machine is shared: latencies mean little without the load they were measured at
        soak.load.append(os.getloadavg()[0])
        soak.stop.wait(0.5)


def mixed_load(soak: Soak, seed: int) -> None:
    """Runs submitted, read, exported, cancelled and deleted; small sweeps now and then."""
    rng = random.Random(seed)
    with httpx.Client(base_url=soak.url, timeout=120, headers=AUTH) as http:
        while not soak.stop.is_set():
            try:
                action = rng.random()
                if action < 0.5:
                    body = {"sea_state": rng.randint(2, 6), "duration": rng.choice([5, 20, 60])}
                    response = http.post("/api/runs", json=body)
                    soak.count(f"POST /api/runs {response.status_code}")
                    if response.status_code in (201, 202):
                        with soak.lock:
                            soak.accepted.add(response.json()["id"])
                elif action < 0.7:
                    runs = http.get("/api/runs", params={"limit": 20}).json()
                    done = [r["id"] for r in runs if r["status"] == "done"]
                    if done:
                        fmt = rng.choice(["csv", "json"])
                        params = {"format": fmt, "every": rng.choice([1, 10])}
                        response = http.get(f"/api/runs/{rng.choice(done)}/series", params=params)
                        soak.count(f"GET series {response.status_code}")
                elif action < 0.8:
                    with soak.lock:
                        mine = sorted(soak.accepted - soak.deleted - soak.protected)
                    if mine:
                        victim = rng.choice(mine)
                        if rng.random() < 0.5:
                            code = http.post(f"/api/runs/{victim}/cancel").status_code
                            soak.count(f"cancel {code}")
                        else:
                            code = http.delete(f"/api/runs/{victim}").status_code
                            soak.count(f"DELETE {code}")
                            if code == 204:
                                with soak.lock:
                                    soak.deleted.add(victim)
                elif action < 0.81:
                    spec = {"hs": [1.0, 2.0], "tp": [8.0], "seeds": 1, "duration": 5.0}
                    code = http.post("/api/sweeps", json=spec).status_code
                    soak.count(f"POST /api/sweeps {code}")
                else:
                    soak.count(f"GET /api/live {http.get('/api/live').status_code}")
            except (httpx.HTTPError, ValueError) as exc:  # ValueError: an answer not JSON
                soak.count(f"error {type(exc).__name__}")
            soak.stop.wait(rng.uniform(0.05, 0.3))


def _camera_message() -> bytes:
    """What a browser sends once its page has drawn (`camera_hello`): a client that never sends
    it gets the scene once and then nothing (issue 30 item 7)."""
    from twin.web.viewer.viser_adapter import camera_hello

    return camera_hello()


async def _viewer(port: int, index: int, camera: bytes, stop: Any, counts: dict[str, int]) -> None:
    import viser
    import websockets

    protocol = websockets.Subprotocol(f"viser-v{viser.__version__}")
    url = f"ws://127.0.0.1:{port}"
    while not stop.is_set():
        try:
            async with websockets.connect(url, subprotocols=[protocol], max_size=None,
                                          open_timeout=60) as ws:  # fmt: skip
                counts["connected"] += 1
                await ws.send(camera)
                while not stop.is_set():
                    try:
                        await asyncio.wait_for(ws.recv(), 1.0)
                        counts["messages"] += 1
                    except TimeoutError:
                        continue
        except Exception:  # refused, closed: connect again, as a browser tab would
            await asyncio.sleep(1.0 + index % 5)


def viewers_process(
    port: int, viewers: int, camera: bytes, stop: Any, connected: Any, messages: Any
) -> None:
    """The viewers, in a process of their own (as the slowloris): reading every frame of the
    render loop, they must not slow the soak's own health polls (one GIL), only the server.
    `camera`: `_camera_message()`, built by the soak (this process need not import twin)."""
    counts = {"connected": 0, "messages": 0}

    async def report() -> None:
        while not stop.is_set():
            connected.value, messages.value = counts["connected"], counts["messages"]
            await asyncio.sleep(0.5)
        connected.value, messages.value = counts["connected"], counts["messages"]

    async def main() -> None:
        clients = (_viewer(port, i, camera, stop, counts) for i in range(viewers))
        await asyncio.gather(report(), *clients, return_exceptions=True)

    asyncio.run(main())


async def _slow_connection(port: int, stop: Any, counts: dict[str, int]) -> None:
    while not stop.is_set():
        try:
            reader, writer = await asyncio.open_connection(
                "127.0.0.1", port, local_addr=("127.0.0.2", 0)
            )
        except OSError:
            await asyncio.sleep(0.5)
            continue
        counts["opened"] += 1
        try:
            writer.write(b"GET /api/health HTTP/1.1\r\nHost: localhost\r\n")
            while not stop.is_set():
                writer.write(b"X-a: b\r\n")  # a header a second, never the blank line
                await writer.drain()
                try:
                    if await asyncio.wait_for(reader.read(1024), 1.0) == b"":
                        counts["closed"] += 1
                        break
                except TimeoutError:
                    continue
        except OSError:
            counts["closed"] += 1
        finally:
            writer.close()
        await asyncio.sleep(0.2)


def slowloris_process(port: int, connections: int, stop: Any, opened: Any, closed: Any) -> None:
    """The slowloris, in a process of its own: its thousands of sockets must not slow the
    soak's own health polls (one GIL), only the server."""
    _, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    counts = {"opened": 0, "closed": 0}

    async def main() -> None:
        await asyncio.gather(*(_slow_connection(port, stop, counts) for _ in range(connections)),
                             return_exceptions=True)  # fmt: skip

    asyncio.run(main())
    opened.value, closed.value = counts["opened"], counts["closed"]


def heatmap_attack(soak: Soak) -> None:
    """The sweep that held a server for over an hour, and one at the panel limit."""
    from twin.runs.sweep import MAX_PANELS

    attack = {"hs": [1.0], "tp": [8.0], "seeds": 1, "duration": 0.05,
              "heading": [float(h) for h in range(5000)]}  # fmt: skip
    with httpx.Client(base_url=soak.url, timeout=120, headers=AUTH) as http:
        start = time.perf_counter()
        refused = http.post("/api/sweeps", json=attack)
        soak.figures["heatmap_attack_status"] = refused.status_code
        soak.figures["heatmap_attack_answered_s"] = round(time.perf_counter() - start, 3)
        if refused.status_code != 422:
            soak.failures.append(f"the 5,000-heading sweep was answered {refused.status_code}")
        at_limit = {**attack, "heading": [float(h) for h in range(MAX_PANELS)]}
        start = time.perf_counter()
        sweep = http.post("/api/sweeps", json=at_limit)
        while sweep.status_code == 429 and not soak.stop.is_set():  # the queue is full: wait
            time.sleep(1.0)
            sweep = http.post("/api/sweeps", json=at_limit)
        if sweep.status_code != 202:
            soak.figures["panel_limit_sweep"] = f"answered {sweep.status_code}"
            return
        sweep_id = sweep.json()["id"]
        while not soak.stop.is_set():
            answer = http.get(f"/api/sweeps/{sweep_id}").json()
            status = answer["status"]
            if status in ("done", "failed"):
                soak.figures["panel_limit_sweep"] = status
                if status == "failed":
                    soak.failures.append(f"the sweep at the panel limit failed: {answer['error']}")
                soak.figures["panel_limit_sweep_s"] = round(time.perf_counter() - start, 1)
                soak.figures["panels"] = MAX_PANELS
                return
            time.sleep(0.5)


def long_exports(soak: Soak, steps: int) -> None:
    """A run of `steps` steps (200,000: the longest allowed), its JSON series fetched three
    times at once."""
    body = {"sea_state": 4, "duration": steps * 0.005, "dt": 0.005, "n_components": 50}
    with httpx.Client(base_url=soak.url, timeout=300, headers=AUTH) as http:
        response = http.post("/api/runs", json=body)
        if response.status_code not in (201, 202):
            soak.figures["long_run"] = f"answered {response.status_code}"
            return
        run_id = response.json()["id"]
        with soak.lock:
            soak.accepted.add(run_id)
            soak.protected.add(run_id)
        while not soak.stop.is_set():
            status = http.get(f"/api/runs/{run_id}").json()["status"]
            if status != "queued" and status != "running":
                break
            time.sleep(0.5)
        if status != "done":
            soak.figures["long_run"] = f"{status}: {http.get(f'/api/runs/{run_id}').json()}"
            return
        before = psutil.Process(soak.process.pid).memory_info().rss / 2**20
        sizes: list[int] = []

        refused = Counter()

        def fetch() -> None:
            while not soak.stop.is_set():
                with http.stream("GET", f"/api/runs/{run_id}/series") as stream:
                    if stream.status_code == 429:  # EXPORT_SLOTS streaming: wait a turn
                        refused["429"] += 1
                        time.sleep(1.0)
                        continue
                    sizes.append(sum(len(chunk) for chunk in stream.iter_bytes()))
                    return

        threads = [threading.Thread(target=fetch) for _ in range(3)]
        peak = before
        for thread in threads:
            thread.start()
        while any(t.is_alive() for t in threads):
            peak = max(peak, psutil.Process(soak.process.pid).memory_info().rss / 2**20)
            time.sleep(0.05)
        soak.figures["export_json_mb"] = round(max(sizes) / 2**20, 1) if sizes else 0
        soak.figures["exports_done"] = len(sizes)
        soak.figures["exports_told_to_wait"] = refused["429"]
        soak.figures["export_rss_before_mb"] = round(before)
        soak.figures["export_rss_peak_mb"] = round(peak)


# -- the soak ------------------------------------------------------------------------------------


def soak_once(args: argparse.Namespace) -> dict[str, Any]:
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))  # the slowloris needs its fds
    with tempfile.TemporaryDirectory(prefix="twin-soak-") as folder:
        soak = Soak(Path(folder), args.workers, args.worker_nice)
        try:
            soak.figures["startup_s"] = round(soak.wait_ready(), 1)
            attacks = [
                threading.Thread(target=heatmap_attack, args=(soak,), daemon=True),
                threading.Thread(target=long_exports, args=(soak, args.long_steps), daemon=True),
            ]
            threads = [
                threading.Thread(target=health_poller, args=(soak,), daemon=True),
                threading.Thread(target=rss_sampler, args=(soak,), daemon=True),
                *(threading.Thread(target=mixed_load, args=(soak, i), daemon=True)
                  for i in range(args.clients)),
            ]  # fmt: skip
            context = multiprocessing.get_context("spawn")
            viewer_stop = context.Event()
            connected, messages = context.Value("q", 0), context.Value("q", 0)
            viewers = context.Process(
                target=viewers_process, daemon=True,
                args=(soak.viser_port, args.viewers, _camera_message(), viewer_stop, connected,
                      messages),
            )  # fmt: skip
            slow_stop = context.Event()  # the slowloris stops before the rest
            opened, closed = context.Value("q", 0), context.Value("q", 0)
            slowloris = context.Process(
                target=slowloris_process, daemon=True,
                args=(soak.port, args.slowloris, slow_stop, opened, closed),
            )  # fmt: skip
            start = time.monotonic()
            for thread in (*threads, *attacks, viewers, slowloris):
                thread.start()
            soak.stop.wait(args.seconds)
            slow_stop.set()
            slowloris.join(60)
            soak.figures["slowloris_connections_opened"] = opened.value
            soak.figures["slowloris_closed_by_server"] = closed.value
            recovered = _recovery(soak, args.stretch)
            soak.figures["served_again_after_flood_s"] = recovered
            for thread in attacks:  # the attack sweep and the exports finish under the load
                thread.join(300)
            soak.figures["load_s"] = round(time.monotonic() - start, 1)
            soak.stop.set()  # the load, the viewers and the health polls stop: then SIGTERM
            viewer_stop.set()
            for thread in (*threads, viewers):
                thread.join(10)
            soak.ws_connected, soak.ws_messages = connected.value, messages.value
            stopped = _sigterm_with_a_sweep_open(soak, args.stretch)
        finally:
            soak.stop.set()
            if soak.process.poll() is None:
                os.killpg(soak.process.pid, signal.SIGKILL)
                soak.process.wait(10)
        _summarise(soak, stopped, args)
        lost = _lost(soak)
    resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    soak.figures["runs_lost"] = len(lost)
    if lost:
        soak.failures.append(f"{len(lost)} accepted runs missing from the store: {lost[:5]}")
    soak.figures["checks_failed"] = soak.failures
    return soak.figures


def _recovery(soak: Soak, stretch: float) -> float | None:
    start = time.monotonic()
    while time.monotonic() - start < RECOVERY * stretch:
        try:
            if httpx.get(f"{soak.url}/api/health", timeout=2).status_code == 200:
                return round(time.monotonic() - start, 2)
        except httpx.HTTPError:
            pass
        time.sleep(0.1)
    soak.failures.append(f"not serving {RECOVERY * stretch:g} s after the slowloris stopped")
    return None


def _sigterm_with_a_sweep_open(soak: Soak, stretch: float) -> float | None:
    spec = {"hs": [1.0, 2.0, 3.0], "tp": [6.0, 8.0], "seeds": 2, "duration": 200.0}
    try:
        httpx.post(f"{soak.url}/api/sweeps", json=spec, headers=AUTH, timeout=30)
    except httpx.HTTPError:
        pass
    time.sleep(1.0)
    start = time.monotonic()
    soak.process.send_signal(signal.SIGTERM)
    try:
        soak.process.wait(30)
    except subprocess.TimeoutExpired:
        soak.failures.append("SIGTERM not obeyed within 30 s")
        return None
    stopped = time.monotonic() - start
    if stopped > STOP_BUDGET * stretch:
        soak.failures.append(
            f"SIGTERM took {stopped:.1f} s (docker stop allows {STOP_BUDGET:g}, × {stretch:.2g})"
        )
    return round(stopped, 1)


def _lost(soak: Soak) -> list[str]:
    from twin.db import session

    database = soak.data / "runs.sqlite"
    with session(database, write=False) as conn:
        stored = {row[0] for row in conn.execute("SELECT id FROM runs")}
    return sorted(soak.accepted - soak.deleted - stored)


def _summarise(soak: Soak, stopped: float | None, args: argparse.Namespace) -> None:
    health = np.array(soak.health) if soak.health else np.array([float("inf")])
    finite = health[np.isfinite(health)]
    p50, p99 = np.percentile(health, [50, 99]) if len(finite) else (float("inf"),) * 2
    soak.figures.update({
        "minutes": round(args.seconds / 60, 2),
        "viewers": args.viewers,
        "viewers_connected": soak.ws_connected,
        "viewer_messages": soak.ws_messages,
        "slowloris": args.slowloris,
        "health_polls": len(health),
        "health_failed": soak.health_errors,
        "health_p50_s": round(float(p50), 4),
        "health_p99_s": round(float(p99), 4),
        "rss_max_mb": round(max(soak.rss)) if soak.rss else None,
        "rss_bound_mb": args.rss_bound,
        "load_average_min": round(min(soak.load), 1) if soak.load else None,
        "load_average_mean": round(float(np.mean(soak.load)), 1) if soak.load else None,
        "load_average_max": round(max(soak.load), 1) if soak.load else None,
        "requests": dict(sorted(soak.statuses.items())),
        "runs_accepted": len(soak.accepted),
        "runs_deleted": len(soak.deleted),
        "sigterm_exit_s": stopped,
    })  # fmt: skip
    if not p99 < HEALTH_P99 * args.stretch:
        soak.failures.append(
            f"/api/health p99 {p99:.2f} s (allowed < {HEALTH_P99 * args.stretch:g} s)"
        )
    if soak.rss and max(soak.rss) > args.rss_bound:
        soak.failures.append(f"server RSS {max(soak.rss):.0f} MB over {args.rss_bound} MB")


# -- issue 43: the workability-upload attacks -------------------------------------------------


class Watch:
    """/api/health every 0.05 s and the server's RSS every 0.2 s, kept with their times, so
    each attack's window can be cut out of them."""

    def __init__(self, soak: Soak) -> None:
        self.soak = soak
        self.health: list[tuple[float, float]] = []  # (time, latency; inf: failed)
        self.rss: list[tuple[float, float]] = []  # (time, MB)
        self.threads = [threading.Thread(target=f, daemon=True) for f in (self._poll, self._rss)]
        for thread in self.threads:
            thread.start()

    def _poll(self) -> None:
        with httpx.Client(base_url=self.soak.url, timeout=30) as http:
            while not self.soak.stop.is_set():
                start = time.perf_counter()
                try:
                    ok = http.get("/api/health").status_code == 200
                except httpx.HTTPError:
                    ok = False
                elapsed = time.perf_counter() - start
                self.health.append((time.monotonic(), elapsed if ok else float("inf")))
                self.soak.stop.wait(0.05)

    def _rss(self) -> None:
        process = psutil.Process(self.soak.process.pid)
        while not self.soak.stop.is_set():
            try:
                self.rss.append((time.monotonic(), process.memory_info().rss / 2**20))
            except psutil.Error:
                return
            self.soak.stop.wait(0.2)

    def window(self, start: float, end: float) -> dict[str, Any]:
        """Health p99 [s], polls, failures and the RSS growth [MB] between `start` and `end`."""
        latencies = [h for t, h in self.health if start <= t <= end]
        rss = [m for t, m in self.rss if start <= t <= end] or [0.0]
        before = [m for t, m in self.rss if t <= start] or rss[:1]
        finite = [h for h in latencies if np.isfinite(h)]
        return {
            "health_polls": len(latencies),
            "health_failed": len(latencies) - len(finite),
            "health_p99_s": round(float(np.percentile(latencies, 99)), 4) if latencies else None,
            "rss_growth_mb": round(max(rss) - before[-1], 1),
        }


def _post_upload(soak: Soak, text: str, **fields: Any) -> tuple[int, float, str, str]:
    """POST a workability upload (after the rate limit's waits): (status, [s] to the answer,
    its message, its Location)."""
    body = {**UPLOAD_SPEC, "record_csv": text, **fields}
    start = time.perf_counter()
    while True:
        answer = httpx.post(f"{soak.url}/api/workability", json=body, headers=AUTH, timeout=60)
        if answer.status_code != 429:
            break
        time.sleep(float(answer.headers.get("retry-after", "1")))  # the rate limit: wait
        start = time.perf_counter()
    detail = answer.json().get("message") or answer.json().get("detail") or ""
    location = answer.headers.get("location", "")
    return answer.status_code, time.perf_counter() - start, str(detail)[:160], location


def _job(soak: Soak, location: str, timeout: float = 600.0) -> dict[str, Any]:
    """A workability job once done or failed (its last state after `timeout` s)."""
    deadline, job = time.monotonic() + timeout, {"status": "queued"}
    while time.monotonic() < deadline and job["status"] in ("queued", "running"):
        time.sleep(0.5)
        job = httpx.get(soak.url + location, timeout=30).json()
    return job


def _refused(soak: Soak, answer: tuple[int, float, str, str]) -> tuple[bool, str]:
    """Whether an upload was refused: a 422 at once, or a 202 whose reading ended later (past
    `ANSWER_WAIT`) with its job failed; and the message."""
    status, _, message, location = answer
    if status == 202:
        job = _job(soak, location)
        return job["status"] == "failed", str(job.get("error"))[:160]
    return status == 422, message


def _wide(columns: int) -> str:
    tps = ",".join(f"{4 + 16 * i / columns:.6f}" for i in range(columns))
    return "hs," + tps + "\n1.0," + ",".join("1" for _ in range(columns)) + "\n"


def _hourly(rows: int, pad: int = 0) -> str:
    """`rows` hourly rows from 2000-01-01 in the shortest form (`time,hs,tp`); `pad`
    characters of an ignored column on each."""
    times = np.datetime64("2000-01-01T00", "h") + np.arange(rows)
    hs = (0.5 + 2.5 * (np.arange(rows) % 24) / 24).round(1)
    extra = "," + "x" * pad if pad else ""
    head = "time,hs,tp" + (",notes" if pad else "")
    lines = (f"{t},{h},9{extra}\n" for t, h in zip(times.astype(str), hs, strict=True))
    return head + "\n" + "".join(lines)


def _attack_wide(soak: Soak) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for columns in (20_000, 50_000, 400_000):
        status, took, _, _ = _post_upload(soak, _wide(columns))
        out[f"wide_{columns}"] = {"status": status, "answer_s": round(took, 3)}
        if status != 422 or took > UPLOAD_ANSWER:
            soak.failures.append(f"wide scatter of {columns} columns: {status} in {took:.2f} s")
    return out


def _attack_grid(soak: Soak) -> dict[str, Any]:
    times = [f"2020-01-01T00:00:00.{i:09d}" for i in range(101)] + ["2020-01-01T00:00:00.060"]
    answer = _post_upload(soak, "time,hs,tp\n" + "".join(f"{t},1.0,8.0\n" for t in times))
    refused, message = _refused(soak, answer)
    if not refused or answer[1] > UPLOAD_ANSWER:
        soak.failures.append(f"ns-apart rows: {answer[0]} in {answer[1]:.2f} s ({message})")
    return {"status": answer[0], "answer_s": round(answer[1], 3), "message": message}


def _attack_rows(soak: Soak) -> dict[str, Any]:
    best = {"kind": "best", "headings": [15.0 * i for i in range(24)]}
    status, took, _, location = _post_upload(soak, _hourly(150_000), heading=best)
    out: dict[str, Any] = {"accepted": {"status": status, "answer_s": round(took, 3)}}
    start = time.monotonic()
    job = _job(soak, location) if status == 202 else {"status": status}  # on a worker
    out["accepted"] |= {"job": job["status"], "job_s": round(time.monotonic() - start, 1)}
    if job["status"] != "done" or took > UPLOAD_ANSWER:
        soak.failures.append(f"150,000 rows at 24 headings: {status} in {took:.2f} s, job "
                             f"{job['status']} (to be done)")  # fmt: skip
    widest = {"kind": "best", "headings": [10.0 * i for i in range(36)]}
    answer = _post_upload(soak, _hourly(200_000), heading=widest)
    refused, message = _refused(soak, answer)
    out["refused"] = {"status": answer[0], "answer_s": round(answer[1], 3), "message": message}
    if not refused or "MAX_ROW_WORK" not in message or answer[1] > UPLOAD_ANSWER:
        soak.failures.append(f"200,000 rows at 36 headings: {answer[0]} ({message})")
    return out


def _attack_disk(soak: Soak) -> dict[str, Any]:
    from twin.db import session

    padded = _hourly(1_000, pad=2_000)  # 2 MB, 1,000 rows' columns
    codes: Counter[int] = Counter()
    for _ in range(80):
        status, _, _, location = _post_upload(soak, padded)
        codes[status] += 1
        if status == 202:
            httpx.post(f"{soak.url}{location}/cancel", headers=AUTH, timeout=30)
    with session(soak.data / "runs.sqlite", write=False) as db:
        stored = db.execute("SELECT COALESCE(SUM(size), 0), COALESCE(SUM(LENGTH(upload)), 0) "
                            "FROM workability").fetchone()  # fmt: skip
    size = sum(f.stat().st_size for f in soak.data.glob("runs.sqlite*"))
    out = {"statuses": dict(codes), "store_mb": round(size / 2**20, 1),
           "counted_mb": round(stored[0] / 2**20, 2), "uploads_left_bytes": stored[1]}  # fmt: skip
    if size > 50 * 2**20 or stored[1]:
        soak.failures.append(f"80 submit-and-cancel cycles: store {size / 2**20:.0f} MB, "
                             f"{stored[1]} bytes of uploads left")  # fmt: skip
    return out


def _attack_tokens(soak: Soak) -> dict[str, Any]:
    wrong = [TOKEN[:8] + f"{i:02d}" + "x" * (len(TOKEN) - 10) for i in range(15)]
    codes: Counter[int] = Counter()
    for guess in wrong:
        for _ in range(11):
            answer = httpx.post(f"{soak.url}/api/workability/x/cancel", timeout=30,
                                headers={"Authorization": f"Bearer {guess}"})  # fmt: skip
            codes[answer.status_code] += 1
    holder = httpx.post(f"{soak.url}/api/workability/x/cancel", headers=AUTH, timeout=30)
    bad = {name: _refused(soak, _post_upload(soak, text))[0] for name, text in (
        ("header_only", "time,hs,tp\n"), ("nul", "time,hs,tp\n2020-01-01T00,1\x00,8\n"))}
    two_rows = _post_upload(soak, "time,hs,tp\n2020-01-01T00,1,8\n2020-01-01T01,1,8\n")
    two = _job(soak, two_rows[3])["status"] if two_rows[0] == 202 else two_rows[0]
    if holder.status_code in (401, 429) or not all(bad.values()) or two != "done":
        soak.failures.append(f"holder {holder.status_code}; refused {bad}; 2 rows {two}")
    return {"wrong": dict(codes), "holder": holder.status_code, "refused": bad,
            "two_rows": two}  # fmt: skip


def _sigterm_with_an_upload_in_flight(soak: Soak) -> dict[str, Any]:
    sender = threading.Thread(target=_post_upload, args=(soak, _wide(400_000)), daemon=True)
    sender.start()
    time.sleep(0.3)
    start = time.monotonic()
    soak.process.send_signal(signal.SIGTERM)
    free_while_alive = False
    while soak.process.poll() is None and time.monotonic() - start < 30:
        from twin.web.lock import DataDirBusy, DataDirLock

        try:
            DataDirLock(soak.data).acquire().release()
            free_while_alive = soak.process.poll() is None
        except DataDirBusy:
            pass
        time.sleep(0.05)
    stopped = time.monotonic() - start
    if stopped > STOP_BUDGET or free_while_alive:
        soak.failures.append(f"SIGTERM: {stopped:.1f} s, lock free while alive {free_while_alive}")
    return {"exit_s": round(stopped, 1), "lock_free_while_alive": free_while_alive}


def upload_attacks(args: argparse.Namespace) -> dict[str, Any]:
    """Issue 43's five attacks, each alone, then SIGTERM with one in flight (module doc)."""
    with tempfile.TemporaryDirectory(prefix="twin-soak-uploads-") as folder:
        soak = Soak(Path(folder), args.workers, args.worker_nice,
                    ("--max-store", str(50 * 2**20)))  # fmt: skip
        try:
            soak.figures["startup_s"] = round(soak.wait_ready(), 1)
            _post_upload(soak, _hourly(48))  # the reading children are warm
            watch = Watch(soak)
            time.sleep(2.0)
            attacks = {"1_wide_scatter": _attack_wide, "2_ns_grid": _attack_grid,
                       "3_rows_by_headings": _attack_rows, "4_disk": _attack_disk,
                       "5_tokens_and_bad_records": _attack_tokens}  # fmt: skip
            for name, attack in attacks.items():
                start = time.monotonic()
                figures = attack(soak)
                window = watch.window(start, time.monotonic())
                soak.figures[name] = {**figures, **window, "s": round(time.monotonic() - start)}
                if window["health_p99_s"] is None or window["health_p99_s"] > UPLOAD_HEALTH_P99:
                    soak.failures.append(f"{name}: health p99 {window['health_p99_s']} s")
                if window["rss_growth_mb"] > UPLOAD_RSS_GROWTH:
                    soak.failures.append(f"{name}: RSS grew {window['rss_growth_mb']} MB")
            soak.stop.set()
            soak.figures["sigterm_upload_in_flight"] = _sigterm_with_an_upload_in_flight(soak)
        finally:
            soak.stop.set()
            if soak.process.poll() is None:
                os.killpg(soak.process.pid, signal.SIGKILL)
                soak.process.wait(10)
    soak.figures["load_average"] = round(os.getloadavg()[0], 1)
    soak.figures["checks_failed"] = soak.failures
    return soak.figures


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--short", action="store_true", help="the CI form: under 60 s")
    parser.add_argument("--uploads", action="store_true",
                        help="issue 43's workability-upload attacks instead")  # fmt: skip
    parser.add_argument("--minutes", type=float, default=30.0, help="load time (default 30)")
    parser.add_argument("--viewers", type=int, help="viewer websocket clients (100; short 10)")
    parser.add_argument("--slowloris", type=int, help="slow connections (5000; short 500)")
    parser.add_argument("--clients", type=int, default=4, help="mixed-load clients")
    parser.add_argument("--workers", type=int, default=2, help="the server's workers")
    parser.add_argument("--worker-nice", type=int, default=0,
                        help="the server's --worker-nice (10: a machine of its own)")  # fmt: skip
    parser.add_argument("--rss-bound", type=int, default=1500,
                        help="[MB] the server process's RSS must stay under it")  # fmt: skip
    parser.add_argument("--json", type=Path, help="write the figures here")
    parser.add_argument(
        "--stretch", type=float, default=1.0,
        help="multiply the time limits (health p99, recovery, SIGTERM) by this: the CI test "
        "passes the load it measured (tests/timing.py), as every time limit of the suite does",
    )  # fmt: skip
    args = parser.parse_args()
    args.seconds = 20.0 if args.short else 60.0 * args.minutes
    args.long_steps = 20_000 if args.short else 200_000
    args.viewers = args.viewers if args.viewers is not None else (10 if args.short else 100)
    args.slowloris = args.slowloris if args.slowloris is not None else (
        500 if args.short else 5000
    )
    figures = upload_attacks(args) if args.uploads else soak_once(args)
    log = os.environ.get("TWIN_RELIABILITY_LOG")  # scripts/reliability.py renders them
    if log:
        with open(log, "a", encoding="utf-8") as out:
            out.write(json.dumps({"test": "soak", **figures}) + "\n")
    width = max(map(len, figures))
    for name, value in figures.items():
        print(f"{name:<{width}}  {json.dumps(value)}")
    if args.json:
        args.json.write_text(json.dumps(figures, indent=2) + "\n")
    if figures["checks_failed"]:
        print("FAILED: " + "; ".join(figures["checks_failed"]), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Benchmarks of the served twin: the live 3D viewer's websocket updates and REST latency.

    python benchmarks/run.py --server-only   # just these rows, patched into docs/performance.md

- **live server**: a `LiveSession` shown by `start_viewer`; N websocket clients (the `websockets`
  package, speaking viser's subprotocol, each sending a browser's camera first, without
  which viser does not count it a browser and the viewer, resting, draws nothing) count the
  messages each receives over a window after the initial scene; CPU per update is the
  process's CPU time (simulation, render thread and websocket server together) over the
  render frames drawn in that window.
- **REST**: `POST /api/runs` of a 60 s scenario (1200 steps, under the synchronous cap, so the
  answer comes when the run is done: stored, simulated in the server process on the request's
  own worker thread (`twin.web.jobs.JobRunner.run_here`) — a run of at most
  `twin.web.jobs.INLINE_MAX_STEPS` steps when no other short run is in hand, else on one of
  two run workers, processes of the server's executor, as `twin serve` starts them — its
  result stored and read back)
  against uvicorn in a thread, from C concurrent httpx clients in threads; p50 and p99
  over every request. Every client connects from 127.0.0.1, so the app's per-address
  submission limit (`run_rate`, `run_burst`) is lifted: it would answer 429, which is what
  it is for, not latency.
- **NODELAY** (`nodelay_rows`, issue 30): GET /api/health p50 and a 60 s run's POST /api/runs
  p50 of twin's app served on `twin.web.server.listen`'s socket, as `twin serve` does, beside
  a minimal FastAPI peer (one GET, one POST echo) on an `IPPROTO_TCP` socket and on a
  protocol-0 one, measured in the same run over keep-alive connections: the protocol-0 peer
  shows what Nagle plus the delayed ACK cost every answer before the fix.
"""

from __future__ import annotations

import asyncio
import logging
import socket
import statistics
import tempfile
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import uvicorn
import viser
import websockets

from twin.sim.live import LiveSession
from twin.web import JobRunner, RunStore, create_app
from twin.web.access import Access
from twin.web.viewer import start_viewer
from twin.web.viewer.viser_adapter import camera_hello

#: [s] the window over which live updates are counted
LIVE_WINDOW = 5.0
#: [s] wait after connecting, so the initial scene (large messages) is not counted
LIVE_SETTLE = 1.0
#: the REST request: a 60 s run of the hybrid system (SYNC: answered when done)
REST_BODY = {"mechanism": "hybrid", "planner": "mtmp", "sea_state": 4, "duration": 60.0}

Row = Callable[..., None]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


async def _count(url: str, clients: int, settle: float, window: float) -> list[int]:
    """Messages each of `clients` websocket clients receives during `window` after `settle`."""
    counts = [0] * clients
    counting = asyncio.Event()
    protocol = websockets.Subprotocol(f"viser-v{viser.__version__}")  # viser refuses others

    async def client(i: int) -> None:
        async with websockets.connect(url, subprotocols=[protocol], max_size=None) as ws:
            await ws.send(camera_hello())  # a browser's first word: viser then draws for it
            while True:
                await ws.recv()
                if counting.is_set():
                    counts[i] += 1

    tasks = [asyncio.create_task(client(i)) for i in range(clients)]
    await asyncio.sleep(settle)
    counting.set()
    await asyncio.sleep(window)
    for task in tasks:
        task.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)
    return counts


def live_rows(row: Row, window: float = LIVE_WINDOW) -> None:
    """Scene updates per second to 1 and to 10 websocket clients, and CPU per update."""
    session = LiveSession({"sea_state": 4})
    session.start()
    viewer = start_viewer(session, access=Access(), port=free_port())
    try:
        time.sleep(1.0)  # numba, BLAS and the first frames warmed up
        for clients in (1, 10):
            frames, cpu = viewer.frames, time.process_time()
            counts = asyncio.run(_count(f"ws://127.0.0.1:{viewer.port}", clients, 1.0, window))
            # the settle second is in the CPU and frame deltas on both sides, so they cancel
            updates = viewer.frames - frames
            cpu_per_update = (time.process_time() - cpu) / max(updates, 1)
            rates = [c / window for c in counts]
            row(
                # viser coalesces queued updates into one websocket message, so messages/s can
                # be below frames drawn/s; no target: issue 6's 30 fps is about frames drawn
                f"live server: scene updates/s, {clients} websocket client"
                + ("s" if clients > 1 else "")
                + " (ws messages)",
                f"{statistics.mean(rates):.1f}/s per client (min {min(rates):.1f})",
            )
            row(
                f"live server: CPU per update, {clients} client" + ("s" if clients > 1 else ""),
                f"{1e3 * cpu_per_update:.1f} ms ({updates / (window + 1.0):.1f} frames/s drawn)",
            )
    finally:
        viewer.stop()
        session.stop()


def _serving(store: RunStore, workers: int) -> tuple[Any, Callable[[], None], int]:
    """The REST app as `twin serve` builds it, with `workers` run workers: (app, close, workers).

    With `twin.runs.executor` (runs on a Dask LocalCluster of single-threaded workers, kernels
    warmed on each, started once before the app) or, before it, the app's own `JobRunner`
    process pool. Every bench client is 127.0.0.1, so the per-address submission limit is
    lifted (see the module's doc).
    """
    limits: dict[str, Any] = {"run_rate": 1e9, "run_burst": 10**9}
    try:
        from twin.runs.executor import Executor
    except ImportError:
        jobs = JobRunner(store, workers=workers)
        app = create_app(LiveSession(), store, jobs=jobs, **limits)
        return app, lambda: None, jobs.workers
    executor = Executor.start(None, n_workers=workers)
    app = create_app(LiveSession(), store, executor=executor, jobs=JobRunner(store), **limits)
    return app, executor.close, executor.workers


def rest_rows(
    row: Row, requests_1: int = 20, requests_20: int = 2, targets: tuple[float, float] = (0.1, 1.0)
) -> None:
    """p50 of POST /api/runs (60 s scenario) with one client, p99 with 20 concurrent clients,
    against `targets` [s] (issue 12: p50 ≤ 100 ms, p99 ≤ 1 s), on two run workers."""
    for name in ("uvicorn.error", "httpx"):  # the root logger is at INFO (wavespectra)
        logging.getLogger(name).setLevel(logging.WARNING)
    with tempfile.TemporaryDirectory() as folder, RunStore(Path(folder) / "r.sqlite") as store:
        app, close, workers = _serving(store, 2)
        port = free_port()
        server = uvicorn.Server(
            uvicorn.Config(app, host="127.0.0.1", port=port, access_log=False, log_level="warning")
        )
        thread = threading.Thread(target=server.run, daemon=True)
        thread.start()
        try:
            url = f"http://127.0.0.1:{port}"
            while not server.started:
                time.sleep(0.05)

            def client(n: int) -> list[float]:
                latencies = []
                with httpx.Client(base_url=url, timeout=300) as http:
                    for _ in range(n):
                        start = time.perf_counter()
                        http.post("/api/runs", json=REST_BODY).raise_for_status()
                        latencies.append(time.perf_counter() - start)
                return latencies

            # every worker started, its imports done and its compiled kernels loaded: a few
            # rounds of concurrent requests, so each worker gets at least one
            with ThreadPoolExecutor(2 * workers) as pool:
                for _ in range(3):
                    list(pool.map(client, [2] * (2 * workers)))

            for clients, each in ((1, requests_1), (20, requests_20)):
                with ThreadPoolExecutor(clients) as pool:
                    latencies = np.concatenate(list(pool.map(client, [each] * clients)))
                p50, p99 = np.percentile(latencies, [50, 99])
                label = (
                    f"REST: POST /api/runs (60 s run), {clients} client"
                    + ("s" if clients > 1 else "")
                    + f", {len(latencies)} requests, {workers} workers"
                )
                if clients == 1:
                    met, target = p50 <= targets[0], f"p50 ≤ {1e3 * targets[0]:.0f} ms"
                else:
                    met, target = p99 <= targets[1], f"p99 ≤ {targets[1]:g} s"
                row(label, f"p50 {1e3 * p50:.0f} ms, p99 {1e3 * p99:.0f} ms", target, met)
        finally:
            server.should_exit = True
            thread.join(timeout=10)
            close()


#: keep-alive requests per NODELAY figure
NODELAY_REQUESTS = 200


def _serve_on(app: Any, sock: socket.socket) -> Callable[[], None]:
    """Serve `app` with uvicorn on `sock` from a thread; returns the function that stops it."""
    server = uvicorn.Server(uvicorn.Config(app, access_log=False, log_level="warning"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.05)

    def stop() -> None:
        server.should_exit = True
        thread.join(timeout=10)
        sock.close()

    return stop


def _peer_app() -> Any:
    """The minimal FastAPI peer: a GET and a POST that answer small JSON at once."""
    from fastapi import FastAPI

    peer = FastAPI()

    @peer.get("/api/health")
    def health() -> dict[str, str]:
        return {"status": "ok"}

    @peer.post("/api/runs")
    def post(body: dict[str, Any]) -> dict[str, Any]:
        return {"id": "0" * 32, "scenario": body}

    return peer


def _p50(port: int, method: str, body: Any, n: int) -> float:
    """[s] median latency of `n` keep-alive requests on one connection."""
    latencies = []
    with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=120) as http:
        for _ in range(n + 3):  # the first three warm the connection and the route
            start = time.perf_counter()
            http.request(method, "/api/health" if method == "GET" else "/api/runs",
                         json=body).raise_for_status()  # fmt: skip
            latencies.append(time.perf_counter() - start)
    return float(np.median(latencies[3:]))


def nodelay_rows(
    row: Row, requests: int = NODELAY_REQUESTS, targets: tuple[float, float] = (0.005, 0.020)
) -> None:
    """GET /api/health p50 and a 60 s run's POST p50, twin beside the peer (issue 30: ≤ 5 ms
    and ≤ 20 ms on an idle machine)."""
    from twin.web.server import listen

    for name in ("uvicorn.error", "httpx"):
        logging.getLogger(name).setLevel(logging.WARNING)
    peers = {}
    for label, proto in (("IPPROTO_TCP", socket.IPPROTO_TCP), ("protocol 0", 0)):
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM, proto)
        sock.bind(("127.0.0.1", 0))
        stop = _serve_on(_peer_app(), sock)
        port = sock.getsockname()[1]
        try:
            peers[label] = (_p50(port, "GET", None, requests),
                            _p50(port, "POST", REST_BODY, requests))  # fmt: skip
        finally:
            stop()
    with tempfile.TemporaryDirectory() as folder, RunStore(Path(folder) / "r.sqlite") as store:
        app, close, workers = _serving(store, 2)
        sock = listen("127.0.0.1", 0)
        port = sock.getsockname()[1]
        stop = _serve_on(app, sock)
        try:
            health = _p50(port, "GET", None, requests)
            _p50(port, "POST", REST_BODY, 2 * workers)  # every worker warm
            post = _p50(port, "POST", REST_BODY, max(requests // 10, 10))
        finally:
            stop()
            close()
    tcp, zero = peers["IPPROTO_TCP"], peers["protocol 0"]
    row(
        "REST: GET /api/health p50, keep-alive (twin.web.server.listen)",
        f"{1e3 * health:.1f} ms, {health / tcp[0]:.1f}× the peer (peer {1e3 * tcp[0]:.1f} ms; "
        f"protocol 0 {1e3 * zero[0]:.1f} ms)",
        f"≤ {1e3 * targets[0]:.0f} ms",
        health <= targets[0],
    )
    row(
        f"REST: POST /api/runs (60 s run) p50, keep-alive, {workers} workers",
        f"{1e3 * post:.1f} ms, {post / tcp[1]:.1f}× the peer's echo (peer {1e3 * tcp[1]:.1f} ms; "
        f"protocol 0 {1e3 * zero[1]:.1f} ms)",
        f"≤ {1e3 * targets[1]:.0f} ms",
        post <= targets[1],
    )

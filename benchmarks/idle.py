"""Benchmark of the served twin at rest: CPU of an idle `twin serve`, with and without its viewer.

    python benchmarks/run.py --idle-only   # just these rows, printed

- **idle server** (issue 29, item 8): `twin serve` in a subprocess (`--scheduler in-process`,
  so no worker processes; a scratch data folder; free ports), its live session paused over
  REST (`POST /api/live/pause`), no browser connected; after `IDLE_SETTLE` s, the server
  process's CPU time (user + system, every thread) over `IDLE_WINDOW` s of wall time, as a
  percentage of one core. Measured twice in the same run: with the 3D viewer, and with
  `--no-viewer`, the baseline. Issue 29's target: ≤ 2 % of a core with the viewer.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import httpx
import psutil

#: [s] wall time the idle server's CPU time is measured over, and the wait before it (the
#: pause lands, start-up work such as the first renders and the warm-up ends)
IDLE_WINDOW = 20.0
IDLE_SETTLE = 5.0
#: [s] longest wait for the server to answer and accept the pause: start-up warms every
#: kernel, which compiles them all (minutes on a loaded 2-core machine) after a kernel changed
START_TIMEOUT = 900.0
#: [% of a core] issue 29's target for the idle server with its viewer
IDLE_TARGET = 2.0

Row = Callable[..., None]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def idle_cpu(viewer: bool, window: float = IDLE_WINDOW, settle: float = IDLE_SETTLE) -> float:
    """[% of a core] CPU of a `twin serve` process over `window` s, its session paused, no
    browser connected; with its 3D viewer or `--no-viewer`.

    Raises:
        RuntimeError: the server exited or never accepted the pause (its output's last line).
    """
    port = free_port()
    with tempfile.TemporaryDirectory() as data:
        command = [
            str(Path(sys.executable).parent / "twin"), "serve", "--port", str(port),
            "--viser-port", str(free_port()), "--data-dir", data, "--scheduler", "in-process",
        ]  # fmt: skip
        if not viewer:
            command.append("--no-viewer")
        env = {k: v for k, v in os.environ.items() if k != "TWIN_TOKEN"}
        server = subprocess.Popen(
            command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
        )
        try:
            _pause(server, f"http://127.0.0.1:{port}")
            time.sleep(settle)
            process = psutil.Process(server.pid)
            before, start = process.cpu_times(), time.perf_counter()
            time.sleep(window)
            after, wall = process.cpu_times(), time.perf_counter() - start
        finally:
            server.terminate()
            try:
                server.wait(timeout=30)
            except subprocess.TimeoutExpired:
                server.kill()
    used = (after.user - before.user) + (after.system - before.system)
    return 100.0 * used / wall


def _pause(server: subprocess.Popen, url: str) -> None:
    """Wait until the server answers, then pause its live session (retried while it warms
    up: it may refuse until then)."""
    deadline = time.monotonic() + START_TIMEOUT
    with httpx.Client(base_url=url, timeout=10) as http:
        while time.monotonic() < deadline:
            if server.poll() is not None:
                tail = (server.stderr.read() if server.stderr else "").strip().splitlines()
                raise RuntimeError((tail or ["exited"])[-1])
            try:
                if http.post("/api/live/pause").status_code == 200:
                    if http.get("/api/live").json().get("playing") is False:
                        return
            except httpx.HTTPError:
                pass
            time.sleep(0.5)
    raise RuntimeError(f"the server did not accept a pause within {START_TIMEOUT:g} s")


def idle_rows(row: Row, window: float = IDLE_WINDOW) -> None:
    """The idle server's CPU with its viewer (no browser, session paused) and without."""
    try:
        baseline = idle_cpu(viewer=False, window=window)
        with_viewer = idle_cpu(viewer=True, window=window)
    except RuntimeError as exc:
        row("idle server: twin serve, session paused, no browser", f"failed: {exc}")
        return
    row(
        f"idle server: twin serve --no-viewer, session paused ({window:g} s)",
        f"{baseline:.2f} % of a core",
    )
    row(
        f"idle server: twin serve with viewer, no browser, session paused ({window:g} s)",
        f"{with_viewer:.2f} % of a core (baseline beside it {baseline:.2f} %)",
        f"≤ {IDLE_TARGET:g} % of a core",
        with_viewer <= IDLE_TARGET,
    )

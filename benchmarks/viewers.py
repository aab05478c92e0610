"""The server's cost per connected browser: CPU and /api/health latency against N viewers.

    python benchmarks/viewers.py [--n 0 10 50 100] [--seconds 60] [--workers 1] [--json F]

A real `twin serve` (token mode, as `scripts/soak.py` starts it); for each N, N viewer clients
in a process of their own that act as browsers (each sends the camera message, so viser counts
it and the render loop draws for it: `scripts/soak.py`'s `viewers_process`) read every frame
they are sent. Measured over `--seconds`: the server process's CPU (utime + stime from
/proc, cores), /api/health every 0.1 s (p50, p99, max), the windows and bytes the clients
received, the machine's load average. Reported, not asserted (docs/reliability.md).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import soak

TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """[s] CPU time of process pid so far (user + system)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def measure(url: str, pid: int, seconds: float) -> dict[str, Any]:
    """Server CPU [cores] and health latency [ms] over `seconds`."""
    latencies, loads = [], []
    cpu0, t0 = cpu_seconds(pid), time.monotonic()
    with httpx.Client(base_url=url, timeout=30) as http:
        while time.monotonic() - t0 < seconds:
            start = time.perf_counter()
            try:
                ok = http.get("/api/health").status_code == 200
            except httpx.HTTPError:
                ok = False
            latencies.append(time.perf_counter() - start if ok else float("inf"))
            loads.append(os.getloadavg()[0])
            time.sleep(0.1)
    cpu1, t1 = cpu_seconds(pid), time.monotonic()
    ms = 1e3 * np.array(latencies)
    return {
        "cpu_cores": round((cpu1 - cpu0) / (t1 - t0), 3),
        "health_p50_ms": round(float(np.percentile(ms, 50)), 1),
        "health_p99_ms": round(float(np.percentile(ms, 99)), 1),
        "health_max_ms": round(float(ms.max()), 1),
        "polls": len(ms),
        "load_avg": round(float(np.mean(loads)), 2),
    }


def run_viewers(server: soak.Soak, n: int, seconds: float, settle: float) -> dict[str, Any]:
    """One row: N browsers connected, settled, then measured."""
    context = multiprocessing.get_context("spawn")
    stop = context.Event()
    connected, messages = context.Value("q", 0), context.Value("q", 0)
    viewers = context.Process(
        target=soak.viewers_process, daemon=True,
        args=(server.viser_port, n, soak._camera_message(), stop, connected, messages),
    )  # fmt: skip
    viewers.start()
    try:
        time.sleep(settle)
        before = messages.value
        row = {"viewers": n, **measure(server.url, server.process.pid, seconds)}
        row["connected"] = connected.value
        row["windows_per_s"] = round((messages.value - before) / seconds, 1)
        return row
    finally:
        stop.set()
        viewers.join(15)
        if viewers.is_alive():
            viewers.kill()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[0, 10, 50, 100])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--settle", type=float, default=15.0)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="twin-viewers-") as folder:
        server = soak.Soak(Path(folder), args.workers)
        try:
            print(f"server ready in {server.wait_ready(timeout=1200):.1f} s", flush=True)
            for n in args.n:
                rows.append(run_viewers(server, n, args.seconds, args.settle))
                print(json.dumps(rows[-1]), flush=True)
                time.sleep(3)
        finally:
            if server.process.poll() is None:
                os.killpg(server.process.pid, signal.SIGTERM)
                try:
                    server.process.wait(20)
                except subprocess.TimeoutExpired:
                    os.killpg(server.process.pid, signal.SIGKILL)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()

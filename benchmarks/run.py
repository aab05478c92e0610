"""Benchmarks: the twin's engines against a Pinocchio peer, measured in one run.

    python benchmarks/run.py            # about 3 minutes on 2 cores; writes docs/performance.md
    python benchmarks/run.py --quick    # smaller sizes, a smoke test (does not write the doc)
    python benchmarks/run.py --server-only   # live-server and REST rows only, patched into the doc

**Features**
- the peer: a closed-loop weighted pseudo-inverse on the hybrid system's nine virtual joints as a
  Pinocchio chain, in a plain Python loop (`pinocchio_peer.py`), on the seed 000 sea;
- a single MTMP run of 200 s (4000 steps) with `simulate` and with `simulate_many`;
- the batched engine at N = 256, end to end and its stepping loop alone;
- a sweep of 1000 × 200 s runs in-process and on a two-worker Dask `LocalCluster`;
- scaling with duration and with N, with the fitted exponent;
- numba's compile time on first use (no cache) and its load time from the cache;
- the live server's websocket updates to 1 and 10 clients and REST latency (`server.py`).

Every ratio divides two figures measured in the same run (the machine is shared, so absolute
times are noisy); each time is the best of a few repeats. Targets are reported, not asserted.
"""

from __future__ import annotations

import argparse
import datetime
import logging
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from pinocchio_peer import PinocchioPeer, xi_to_q
from server import live_rows, rest_rows

import twin
from twin.mechanisms import HybridBoardingSystem
from twin.sim import PAPER_PRESETS, simulate
from twin.sim.batch import _HybridBatch, numba_available, simulate_many
from twin.sim.sweep import SweepSpec, run_sweep
from twin.spatial import invert_transform, pose_to_transform, so3_log

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "performance.md"
STEPS = 4000  # 200 s at dt = 0.05 s


def best(function: Callable[[], object], repeat: int) -> float:
    """[s] the shortest of `repeat` wall times of function()."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def peer_inputs(steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The seed 000 scenario's held-tip targets ᴮT_d (steps, 4, 4), twists and the start q."""
    scenario = PAPER_PRESETS["seed000"].model_copy(update={"duration": steps * 0.05})
    batch = _HybridBatch([scenario], scenario.dt, steps)
    T = invert_transform(pose_to_transform(batch.poses[0])) @ batch.held[0]
    twist = np.concatenate(
        [
            (T[1:, :3, 3] - T[:-1, :3, 3]) / scenario.dt,
            so3_log(T[1:, :3, :3] @ np.swapaxes(T[:-1, :3, :3], -1, -2)) / scenario.dt,
        ],
        -1,
    )
    return T[:-1], twist, xi_to_q(HybridBoardingSystem().working_state)


def fit_exponent(x: list[float], y: list[float]) -> str:
    """b of y = a x^b (least squares in log-log), and the straight line y = c + d x."""
    slope, intercept = np.polyfit(x, y, 1)
    b = np.polyfit(np.log(x), np.log(y), 1)[0]
    return f"exponent {b:.2f}; {intercept:.2f} s + {slope * 1e3:.1f} ms × x"


def compile_times() -> tuple[float, float]:
    """[s] numba's first compilation (empty cache) and a fresh process's load from the cache,
    each net of the same call once warm, measured in subprocesses."""
    code = (
        "import time; from twin.sim.batch import simulate_many;"
        "s = [dict(planner='mtmp', sea_state=4, duration=1.0, seed=i) for i in range(2)];"
        "t = time.perf_counter(); simulate_many(s[:1]); simulate_many(s);"
        "a = time.perf_counter() - t; t = time.perf_counter(); simulate_many(s[:1]);"
        "simulate_many(s); print(a - (time.perf_counter() - t))"
    )
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        run = lambda: float(  # noqa: E731
            subprocess.run(
                [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
            ).stdout
        )
        return run(), run()


def main(quick: bool = False) -> None:
    """Measure, print the table, and (unless `quick`) write docs/performance.md."""
    # wavespectra's funwave module calls logging.basicConfig(level="INFO") on import, which
    # would print every Dask scheduler event
    logging.getLogger().setLevel(logging.WARNING)
    steps = 400 if quick else STEPS
    n_batch = 32 if quick else 256
    sweep_runs = 40 if quick else 1000
    rows: list[tuple[str, str, str, str]] = []  # figure, value, target, met

    def row(figure: str, value: str, target: str = "", met: bool | None = None) -> None:
        rows.append((figure, value, target, "" if met is None else ("met" if met else "not met")))
        print(f"{figure:<58} {value:>28}  {target:<22} {rows[-1][3]}", flush=True)

    engines = ["numba", "numpy"] if numba_available() else ["numpy"]
    single = PAPER_PRESETS["seed000"].model_copy(update={"duration": steps * 0.05})
    for engine in engines:  # compile or load numba, warm caches
        simulate_many([single.model_copy(update={"duration": 1.0})] * 2, engine=engine)
        simulate_many([single.model_copy(update={"duration": 1.0})], engine=engine)

    # the peer
    targets, twists, q0 = peer_inputs(steps)
    peer = PinocchioPeer()
    t_peer = best(lambda: peer.run(q0, targets, twists, 0.05), 5)
    peer_rate = steps / t_peer
    row(
        f"peer: Pinocchio WPI loop, {steps} steps",
        f"{t_peer:.3f} s ({1e6 / peer_rate:.1f} µs/step)",
    )

    # a single 200 s MTMP run
    t_ref = best(lambda: simulate(single), 1)
    row(f"simulate(), MTMP {steps} steps", f"{t_ref:.2f} s = {t_ref / t_peer:.1f}× peer")
    for engine in engines:
        t = best(lambda e=engine: simulate_many([single], engine=e), 5)
        row(
            f"simulate_many([one]), {engine}, MTMP {steps} steps",
            f"{t:.3f} s = {t / t_peer:.2f}× peer",
            "≤ 1.0× peer",
            t <= t_peer,
        )

    # the batched engine at N = 256
    scenarios = [single.model_copy(update={"seed": i}) for i in range(n_batch)]
    for engine in engines:
        repeat = 2 if engine == "numba" else 1
        t = best(lambda e=engine: simulate_many(scenarios, engine=e), repeat)
        rate = n_batch * steps / t
        row(
            f"simulate_many N={n_batch}, {engine}, end to end",
            f"{rate:,.0f} steps/s = {rate / peer_rate:.1f}× peer",
            "≥ 4× peer",
            rate >= 4 * peer_rate,
        )
        batch = _HybridBatch(scenarios, single.dt, steps)
        t = best(lambda b=batch, e=engine: b.run_differential(_NoBar(), e == "numba"), repeat)
        rate = n_batch * steps / t
        row(
            f"  N={n_batch}, {engine}, stepping loop only",
            f"{rate:,.0f} steps/s = {rate / peer_rate:.1f}× peer",
            "≥ 4× peer",
            rate >= 4 * peer_rate,
        )

    # sweeps
    hs = list(np.round(np.linspace(0.5, 4.0, 10 if not quick else 2), 2))
    spec = SweepSpec(
        hs=hs,
        tp=[5.0, 7.0, 9.0, 11.0, 13.0],
        planner=["mtmp", "wpi"],
        seeds=sweep_runs // (len(hs) * 10),
        duration=steps * 0.05,
    )
    runs = len(spec.scenarios())
    result = run_sweep(spec, scheduler="in-process", progress=False)
    row(
        f"sweep {runs} × {spec.duration:g} s, in-process",
        f"{result.elapsed:.1f} s",
        "≤ 60 s",
        result.elapsed <= 60,
    )
    start = time.perf_counter()
    cluster = run_sweep(spec, n_workers=2, progress=False)
    total = time.perf_counter() - start
    row(
        f"sweep {runs} × {spec.duration:g} s, LocalCluster 2 workers",
        f"{cluster.elapsed:.1f} s (+{total - cluster.elapsed:.1f} s start/stop)",
        "≤ 60 s",
        cluster.elapsed <= 60,
    )
    same = result.table["operable_runs"].equals(cluster.table["operable_runs"])
    row("  cluster table equals in-process table", "yes" if same else "NO")

    # scaling
    durations = [25.0, 50.0, 100.0, 200.0] if not quick else [5.0, 10.0, 20.0]
    n_scale = 32 if not quick else 8
    times = [
        best(
            lambda d=d: simulate_many(
                [single.model_copy(update={"duration": d, "seed": i}) for i in range(n_scale)]
            ),
            2,
        )
        for d in durations
    ]
    row(
        f"scaling with duration x [s] (N={n_scale}, {durations[0]:g}-{durations[-1]:g} s)",
        fit_exponent(durations, times),
        "1",
    )
    sizes = [16, 32, 64, 128, 256] if not quick else [4, 8, 16]
    short = single.model_copy(update={"duration": 50.0 if not quick else 5.0})
    times = [
        best(lambda n=n: simulate_many([short.model_copy(update={"seed": i}) for i in range(n)]), 2)
        for n in sizes
    ]
    row(
        f"scaling with N = x ({sizes[0]}-{sizes[-1]}, {short.duration:g} s runs)",
        fit_exponent(sizes, times),
        "1",
    )
    if numba_available():
        first, cached = compile_times()
        row("numba: compile on first use (empty cache)", f"{first:.1f} s")
        row("numba: load from cache in a new process", f"{cached:.2f} s")
    live_rows(row, window=2.0 if quick else 5.0)
    rest_rows(row, requests_1=2 if quick else 5)
    if not quick:
        write_doc(rows)


def server_only() -> None:
    """Measure only the live-server and REST rows and put them in place of the doc's rows of
    the same kind (live server, CPU per update, REST), keeping the rest of the last run."""
    rows: list[tuple[str, str, str, str]] = []

    def row(figure: str, value: str, target: str = "", met: bool | None = None) -> None:
        rows.append((figure, value, target, "" if met is None else ("met" if met else "not met")))
        print(f"{figure:<58} {value:>28}  {target:<22} {rows[-1][3]}", flush=True)

    live_rows(row)
    rest_rows(row)
    lines = DOC.read_text().splitlines()
    ours = ("| live server", "| CPU per update", "| REST:")
    kept = [line for line in lines if not line.startswith(ours)]
    table_end = max(i for i, line in enumerate(kept) if line.startswith("|")) + 1
    new = [f"| {a.strip()} | {b} | {c} | {d} |" for a, b, c, d in rows]
    DOC.write_text("\n".join(kept[:table_end] + new + kept[table_end:]) + "\n")
    print(f"updated {DOC.relative_to(ROOT)}")


HEADER = """# Performance

Measured by `python benchmarks/run.py` (`make bench`), which rewrites this file. Every ratio
divides two figures taken in the same run, each the best of a few repeats; the machine is
shared, so compare ratios rather than absolute times between runs. Targets are issue 7's; the
benchmark reports them, no unit test asserts them.

What is measured:

- **peer**: a closed-loop weighted pseudo-inverse on the hybrid system's nine virtual joints as
  a Pinocchio serial chain (x, y, z, yaw, pitch, roll, slew, luff, telescope;
  `benchmarks/pinocchio_peer.py`), in a plain Python loop: forward kinematics and the tip's
  frame Jacobian, the pose error (log3), a damped 6×9 weighted solve, `pin.integrate`. It
  tracks the seed 000 scenario's held-tip target. Its Jacobian equals our J_task to 1e-9
  (`tests/sim/test_pinocchio_peer.py`, with its Euler-rate columns mapped to our body twist).
- **single run**: the seed 000 scenario (MTMP, WMO 4, 200 s at dt = 0.05 s, secondary task,
  Algorithm 1 and rate limits included), end to end: sea synthesis, stepping, the recorded
  series and the metrics. `simulate` is the reference engine (one step object per sample);
  `simulate_many` is the batch engine (`twin.sim.batch`), numba or numpy.
- **N = 256**: 256 such runs (sea seeds 0-255) in one `simulate_many`; "stepping loop only" is
  the time loop (targets, planner, integration) without sea synthesis, records and metrics —
  the part the peer's loop compares with ("planner steps/s" of the target).
- **sweep**: `run_sweep` over 10 Hs × 5 Tp × {MTMP, WPI} × 10 seeds = 1000 runs of 200 s,
  in-process and on a two-worker `LocalCluster` (start-up and shut-down shown apart).
- **scaling**: end-to-end time against duration (N = 32) and against N (50 s runs): the
  exponent of a log-log fit, and a straight-line fit whose intercept is the fixed cost (sea
  synthesis, set-up) that pulls the exponent below 1 for short runs.
"""


def write_doc(rows: list[tuple[str, str, str, str]]) -> None:
    """docs/performance.md: the method, the machine, the date and the table."""
    import pinocchio

    versions = (
        f"Python {platform.python_version()}, numpy {np.__version__}, pinocchio "
        f"{pinocchio.__version__}"
        + (f", numba {sys.modules['numba'].__version__}" if "numba" in sys.modules else "")
    )
    cpu = platform.processor() or platform.machine()
    try:
        cpu = next(
            line.split(":", 1)[1].strip()
            for line in Path("/proc/cpuinfo").read_text().splitlines()
            if line.startswith("model name")
        )
    except (OSError, StopIteration):
        pass
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    table = "\n".join(
        ["| figure | measured | target | |", "| --- | --- | --- | --- |"]
        + [f"| {a.strip()} | {b} | {c} | {d} |" for a, b, c, d in rows]
    )
    DOC.write_text(
        HEADER + f"\n## Latest run\n\n{datetime.date.today().isoformat()}, {cpu}, {os.cpu_count()} "
        f"cores, load average {load:.1f} at the end; {versions}; twin {twin.__version__}.\n\n"
        f"{table}\n"
    )
    print(f"wrote {DOC.relative_to(ROOT)}")


class _NoBar:
    """A stand-in for tqdm where no bar is wanted."""

    def update(self, n: int) -> None:
        del n  # Unused.


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes; no doc written")
    parser.add_argument(
        "--server-only", action="store_true", help="only the live-server and REST rows"
    )
    args = parser.parse_args()
    if args.server_only:
        server_only()
    else:
        main(quick=args.quick)

"""Site-workability rows of the benchmark (issue 28 item 7), called by `run.py`:

    python benchmarks/run.py --workability-only     # these rows alone, printed (no doc written)

- **10 years hourly**: a synthetic 87,600-row hourly record (the shipped NDBC 46097 August 2019
  record's 744 hourly sea states repeated end to end, given consecutive hourly timestamps from
  2010-01-01: real sea states, synthetic chronology; its months and windows mean nothing, its
  cost is that of a 10-year record) for 3 planners (MTMP, WPI, PI) with 5 seeds per cell, cells
  method, the default grid (17 Hs to 8 m × 15 Tp, fixed heading 150°), from an empty cell cache,
  on a two-worker `LocalCluster` (its start and stop shown apart). Target: ≤ 3 minutes on 2 cores.
- **again**: the same 10-year evaluation with every cell cached: what the record's rows cost
  (cell lookup, probabilities, summaries, windows) beside the runs.
- **5-day forecast**: 40 sea states at 3 h steps (every third row of the shipped record, as a
  forecast) for the same 3 planners once its cells are cached (a first evaluation fills what
  the 10-year record did not). Target: ≤ 2 s.

- **lanes keeping metrics alone** (issue 28 item 6): a batch of a cell's runs (64 MTMP runs of
  200 s over seeds, Hs 2.5 m) through `simulate_many`, keeping the series (keep="series") and
  the metrics alone (keep="metrics", what sweeps and workability use): best-of-3 times,
  interleaved, their ratio, and the peak memory numpy allocated (tracemalloc) for each.

Ratios divide by figures of the same run: the 10-year evaluation against its new runs' cost as
serial `simulate()` calls (one 200 s reference run measured beside it, × new runs), and each
time against its target.
"""

from __future__ import annotations

import tempfile
import time
import tracemalloc
from collections.abc import Callable

import numpy as np
import pandas as pd

from twin.assets import asset_path
from twin.runs.executor import Executor
from twin.runs.workability import WorkabilitySpec, run_workability
from twin.sim import PAPER_PRESETS, Scenario, simulate, simulate_many
from twin.site import SiteRecord, read_record

SHIPPED = "46097h2019_08.txt"
PLANNERS = ["mtmp", "wpi", "pi"]
YEARS_ROWS = 87_600  # 10 years × 8760 h
LONG_TARGET = 180.0  # [s] issue 28: 10 years hourly, 3 planners, 5 seeds, empty cache, 2 cores
FORECAST_TARGET = 2.0  # [s] issue 28: a 5-day forecast at 3 h steps with its cells cached

Row = Callable[..., None]


def ten_years(record: SiteRecord, rows: int = YEARS_ROWS) -> SiteRecord:
    """`rows` hourly sea states: `record`'s rows repeated end to end, hourly times from
    2010-01-01 (synthetic chronology, real sea states)."""
    index = np.arange(rows) % record.n
    times = pd.date_range("2010-01-01", periods=rows, freq="h").to_numpy()
    return SiteRecord(
        hs=record.hs[index],
        tp=record.tp[index],
        time=times,
        direction=record.direction[index] if record.direction is not None else None,
        source=f"{record.source} tiled to {rows} hourly rows (synthetic times)",
    )


def five_day_forecast(record: SiteRecord) -> SiteRecord:
    """40 sea states at 3 h steps (every third hourly row), as a forecast."""
    index = np.arange(40) * 3
    times = pd.date_range("2026-12-03", periods=40, freq="3h").to_numpy()
    return SiteRecord(
        hs=record.hs[index],
        tp=record.tp[index],
        time=times,
        kind="forecast",
        source=f"{record.source}: every third row as a 5-day forecast",
    )


def workability_rows(row: Row, quick: bool = False) -> None:
    """The rows above (`quick`: 1 year, 2 seeds, 20 s runs: a smoke test)."""
    shipped = read_record(asset_path("site", SHIPPED))
    years = ten_years(shipped, 8_760 if quick else YEARS_ROWS)
    forecast = five_day_forecast(shipped)
    spec = WorkabilitySpec(
        planners=PLANNERS, seeds=2 if quick else 5, duration=20.0 if quick else 200.0
    )
    reference = PAPER_PRESETS["seed000_ss4" if "seed000_ss4" in PAPER_PRESETS else "seed000"]
    single: Scenario = reference.model_copy(update={"duration": spec.duration})
    simulate(single.model_copy(update={"duration": 1.0}))  # warm
    serial = min(_timed(lambda: simulate(single)) for _ in range(3))
    with tempfile.TemporaryDirectory(prefix="twin-cells-") as data_dir:
        started = time.perf_counter()
        executor = Executor.start(None, n_workers=2)
        start_time = time.perf_counter() - started
        try:
            t0 = time.perf_counter()
            result = run_workability(spec, years, executor=executor, data_dir=data_dir)
            long_time = time.perf_counter() - t0
            t0 = time.perf_counter()  # again, every cell cached: the record's own bookkeeping
            again = run_workability(spec, years, executor=executor, data_dir=data_dir)
            again_time = time.perf_counter() - t0
            run_workability(spec, forecast, executor=executor, data_dir=data_dir)  # fill cells
            forecast_times = []
            for _ in range(3):
                t0 = time.perf_counter()
                cached = run_workability(spec, forecast, executor=executor, data_dir=data_dir)
                forecast_times.append(time.perf_counter() - t0)
            forecast_time = min(forecast_times)
        finally:
            started = time.perf_counter()
            executor.close()
            start_time += time.perf_counter() - started
    label = f"{years.n} hourly rows (synthetic: the shipped month tiled)"
    row(
        f"workability: {label}, 3 planners × {spec.seeds} seeds, empty cache, LocalCluster 2",
        f"{long_time:.1f} s (+{start_time:.1f} s start/stop)",
        f"≤ {LONG_TARGET:g} s (issue 28)",
        long_time <= LONG_TARGET,
    )
    row(
        "workability: its runs (new / evaluated) and runs per second",
        f"{result.new_runs} / {result.runs}, {result.new_runs / long_time:.0f} runs/s",
    )
    row(
        f"workability: × {result.new_runs} serial simulate() of {spec.duration:g} s "
        f"({serial * 1e3:.0f} ms each)",
        f"{long_time / (result.new_runs * serial):.2f}×",
    )
    row(
        f"workability: the same record again, cells cached ({again.new_runs} new runs)",
        f"{again_time:.1f} s ({again_time / long_time:.2f}× the first)",
    )
    row(
        f"workability: 5-day forecast (40 × 3 h), 3 planners, cells cached ({cached.new_runs} new)",
        f"{forecast_time:.2f} s ({forecast_time / FORECAST_TARGET:.2f}× the target)",
        f"≤ {FORECAST_TARGET:g} s (issue 28)",
        forecast_time <= FORECAST_TARGET,
    )
    for planner, value in result.summary["workability"].items():
        row(
            f"workability: {planner} on the tiled record (= the shipped month's)",
            f"{100 * value:.1f} %",
        )
    keep_rows(row, quick=quick)


def keep_rows(row: Row, quick: bool = False, lanes: int = 64, repeat: int = 3) -> None:
    """A cell's batch of runs keeping series vs metrics alone: times (best of `repeat`,
    interleaved), their ratio, and each one's peak traced memory (`quick`: 20 s runs)."""
    duration = 20.0 if quick else 200.0
    scenarios = [{"planner": "mtmp", "hs": 2.5, "tp": 9.0, "duration": duration, "seed": seed}
                 for seed in range(lanes)]  # fmt: skip
    for keep in ("series", "metrics"):  # warm both paths' runners
        simulate_many(scenarios[:2], keep=keep)
    times: dict[str, list[float]] = {"series": [], "metrics": []}
    for _ in range(repeat):
        for keep, spent in times.items():
            spent.append(_timed(lambda keep=keep: simulate_many(scenarios, keep=keep)))
    peak = {}
    for keep in times:
        tracemalloc.start()
        simulate_many(scenarios, keep=keep)
        peak[keep] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    best_series, best_metrics = min(times["series"]), min(times["metrics"])
    label = f"{lanes} × {duration:g} s MTMP runs"
    row(
        f"lanes keeping metrics alone: {label}, time keep=metrics / keep=series",
        f"{best_metrics:.2f} s / {best_series:.2f} s = {best_metrics / best_series:.2f}×",
    )
    row(
        f"lanes keeping metrics alone: {label}, peak memory metrics / series",
        f"{peak['metrics'] / 1e6:.0f} MB / {peak['series'] / 1e6:.0f} MB = "
        f"{peak['metrics'] / peak['series']:.2f}×",
    )


def _timed(function: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    function()
    return time.perf_counter() - t0


if __name__ == "__main__":
    import logging
    import sys

    logging.disable(logging.INFO)

    def row(figure: str, value: str, target: str = "", met: bool | None = None) -> None:
        verdict = "" if met is None else ("met" if met else "not met")
        print(f"{figure:<66} {value:>30}  {target:<22} {verdict}", flush=True)

    workability_rows(row, quick="--quick" in sys.argv)

"""Operability sweeps: a grid of sea states and planner settings, run on Dask.

The question a wave-compensation twin answers is "up to which sea state can we work, with which
planner and which β?". A sweep runs every cell of Hs × Tp × heading × planner × (β, k_e, k_c)
with several sea seeds and reports, per cell, the share of runs that are *operable*: no joint or
leg limit violated (`violations` = 0) and the gangway tip's largest position error under
`tip_error_threshold` (`tip_position_error_max`, docs/simulation.md).

    spec = SweepSpec(hs=[0.5, 1.5, 2.5], tp=[6, 8, 10], planner=["mtmp", "pi"], seeds=4)
    result = run_sweep(spec)                     # a LocalCluster for this sweep
    result = run_sweep(spec, scheduler="tcp://10.0.0.5:8786")   # an existing Dask cluster
    result = run_sweep(spec, executor=executor)  # an executor that outlives the sweep
    result.table                                 # pandas, one row per cell
    heatmap_png(result, "operability.png")

Runs are chunked (`chunk_size` scenarios of one planner each) and each chunk is one task on the
executor (`twin.runs.executor`, the one `twin serve` keeps for runs and sweeps alike) calling
`simulate_many`, below the priority of single runs; every seed of a cell uses the sea seeds
0 … seeds − 1, so cells (and planners) are compared on the same wave records.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator
from tqdm import tqdm

from twin.compiled import limit_threads
from twin.errors import TwinError
from twin.planners import get_planner
from twin.runs.executor import SWEEP_PRIORITY, Executor
from twin.sim.engine import simulate_many
from twin.sim.scenario import DEFAULT_PLANNER, TP_RANGE, Scenario

#: most grid cells (Hs × Tp × heading × planner × β × k_e × k_c) one sweep may ask for
MAX_CELLS = 5_000
#: most runs (cells × seeds)
MAX_RUNS = 20_000
#: most planner steps in all (runs × duration / dt): 20 000 runs of 200 s at 0.05 s
MAX_TOTAL_STEPS = 80_000_000
#: the grid axes, in table order
AXES = ("hs", "tp", "heading", "planner", "beta", "k_e", "k_c")
#: most values of each axis `spec_around` makes (Hs and Tp), and Tp's largest half-width [s]
AROUND_MAX_POINTS = 11
AROUND_MAX_TP_SPAN = 10.0
#: most heatmap panels (planner × heading × β × k_e × k_c) one figure draws: matplotlib's cost
#: per panel grows with their number (50 / 400 panels took 4.4 / 51.7 s, issue 30); the REST
#: API refuses a sweep over it (422), `heatmap_png` draws the first ones and says so
MAX_PANELS = 36
#: the panel axes of a heatmap
PANEL_AXES = ("planner", "heading", "beta", "k_e", "k_c")
#: what a run's row in `SweepResult.runs` keeps from its metrics
RUN_METRICS = (
    "violations",
    "joint_violations",
    "leg_violations",
    "tip_position_error_max",
    "tip_orientation_error_max",
    "leg_margin",
    "faults",
)


class SweepStopped(RuntimeError):
    """A sweep was stopped before its end (`run_sweep`'s `stop`)."""


class SweepSpec(BaseModel):
    """A sweep request. Every axis is a non-empty list of distinct values; units as `Scenario`.

    Runs use `mechanism` (the hybrid system by default); `scenario` sets any other `Scenario`
    field for every run (e.g. `{"spreading": 10, "n_components": 100}`).
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    mechanism: Literal["hybrid", "upu3up", "upr4"] = Field(
        "hybrid", description="the mechanism of every run; `planner` values must plan for it"
    )
    hs: list[float] = Field([0.5, 1.0, 1.5, 2.0, 2.5, 3.0], description="[m] significant heights")
    tp: list[float] = Field([6.0, 8.0, 10.0], description="[s] peak periods")
    heading: list[float] = Field(
        [150.0],
        description="[deg] direction the waves travel towards, counter-clockwise from the bow "
        "(180 head seas, 90 from starboard)",
    )
    planner: list[str] | None = Field(
        None,
        description="planners of the mechanism (PLANNERS); default (null): the mechanism's "
        "own, mtmp for the hybrid system, pid for the small platforms",
    )
    beta: list[float] = Field([0.7], description="[-] parallel/serial weight β")
    k_e: list[float] = Field([25.0], description="[1/s] closed-loop gain k_e")
    k_c: list[float] = Field([9.0], description="[-] telescope weight k_c")
    seeds: int = Field(3, ge=1, le=100, description="[-] runs per cell, sea seeds 0 … seeds − 1")
    duration: float = Field(200.0, gt=0.0, le=3600.0, description="[s] simulated time per run")
    dt: float = Field(0.05, ge=0.005, le=0.2, description="[s] control period")
    tip_error_threshold: float = Field(
        0.05,
        gt=0.0,
        le=10.0,
        description="[m] largest tip position error (after the first 10 samples) of an "
        "operable run",
    )
    scenario: dict[str, Any] = Field(
        default_factory=dict, description="other Scenario fields, the same for every run"
    )

    @field_validator(*AXES, mode="before")
    @classmethod
    def _axis(cls, values: Any, info: Any) -> Any:
        if isinstance(values, str | int | float):
            values = [values]
        if info.field_name == "planner" and values is None:
            return None  # the mechanism's default, filled in by `_caps`
        if not isinstance(values, list | tuple) or len(values) == 0:
            raise ValueError(f"{info.field_name}: empty axis; give at least one value")
        if not all(isinstance(v, str | int | float) for v in values):
            raise ValueError(f"{info.field_name}: each value must be a number or a name")
        if len(set(values)) != len(values):
            raise ValueError(f"{info.field_name}: repeated values {list(values)}")
        return list(values)

    @field_validator(*AXES)
    @classmethod
    def _values(cls, values: list | None, info: Any) -> list | None:
        """Each value within the `Scenario` field's range (the error names the field)."""
        name = info.field_name
        if values is None:
            return values
        for value in values:
            if name == "planner":
                if "mechanism" not in info.data:
                    break  # the mechanism itself is wrong: that is the one error to report
                get_planner(value, info.data["mechanism"])
            else:
                Scenario(**{name: value})
        return values

    @model_validator(mode="after")
    def _caps(self) -> SweepSpec:
        if self.planner is None:
            self.planner = [DEFAULT_PLANNER[self.mechanism]]
        clash = sorted(set(self.scenario) & {*AXES, "seed", "duration", "dt", "mechanism"})
        if clash:
            raise TwinError(f"scenario: {clash} are set by the sweep itself, not by `scenario`")
        Scenario(**self.scenario, duration=self.duration, dt=self.dt)  # names a bad field
        if round(self.duration / self.dt) < 1:
            raise TwinError(
                f"duration: {self.duration:g} s at dt = {self.dt:g} s is zero steps; allowed: "
                "duration ≥ dt"
            )
        sizes = {axis: len(getattr(self, axis)) for axis in AXES}
        cells, runs = math.prod(sizes.values()), math.prod(sizes.values()) * self.seeds
        shape = " × ".join(f"{axis} {n}" for axis, n in sizes.items())
        if cells > MAX_CELLS:
            raise TwinError(f"grid has {cells} cells ({shape}); allowed at most {MAX_CELLS}")
        if runs > MAX_RUNS:
            raise TwinError(
                f"grid has {runs} runs ({cells} cells × seeds {self.seeds}); allowed at most "
                f"{MAX_RUNS}"
            )
        steps = runs * round(self.duration / self.dt)
        if steps > MAX_TOTAL_STEPS:
            raise TwinError(
                f"grid has {steps} planner steps ({runs} runs × duration / dt); allowed at most "
                f"{MAX_TOTAL_STEPS}"
            )
        return self

    def cells(self) -> list[dict[str, Any]]:
        """Every grid cell as {axis: value}, in `AXES` order."""
        return [
            dict(zip(AXES, values, strict=True))
            for values in itertools.product(*(getattr(self, axis) for axis in AXES))
        ]

    def scenarios(self) -> list[dict[str, Any]]:
        """Every run's scenario fields: the cells × seeds, cell-major."""
        common = {**self.scenario, "mechanism": self.mechanism, "duration": self.duration,
                  "dt": self.dt}  # fmt: skip
        return [
            {**common, **cell, "seed": seed} for cell in self.cells() for seed in range(self.seeds)
        ]


@dataclass
class SweepResult:
    """A finished sweep.

    Attributes:
        spec: what was asked.
        runs: one row per run: the axes, `seed`, `RUN_METRICS` and `operable`.
        table: one row per cell: the axes, `runs`, `operable_runs`, `operability` [0-1] and
            the worst `tip_position_error_max` [m] and `violations_max` (samples) over its
            runs.
        elapsed: [s] wall time of the runs (a LocalCluster's start-up and shut-down excluded).
        scheduler: where it ran ("local cluster", an address, or "in-process").
    """

    spec: SweepSpec
    runs: pd.DataFrame
    table: pd.DataFrame
    elapsed: float
    scheduler: str

    @property
    def criterion(self) -> str:
        """The operability criterion in words, threshold stated."""
        return (
            "operable run: no joint or leg limit violation and tip position error ≤ "
            f"{self.spec.tip_error_threshold:g} m (largest over the run after the first 10 "
            "samples)"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the spec, the criterion and the table's rows."""
        return {
            "spec": self.spec.model_dump(),
            "criterion": self.criterion,
            "tip_error_threshold": self.spec.tip_error_threshold,
            "elapsed": self.elapsed,
            "scheduler": self.scheduler,
            "cells": _plain(self.table.to_dict(orient="records")),
        }


def run_sweep(
    spec: SweepSpec | dict,
    *,
    executor: Executor | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    n_workers: int | None = None,
    chunk_size: int = 64,
    on_progress: Callable[[int, int], None] | None = None,
    stop: Callable[[], bool] | None = None,
) -> SweepResult:
    """Run a sweep on the executor and tabulate operability.

    Args:
        spec: a `SweepSpec` or a dict of its fields (validated).
        executor: where the chunks run (`twin.runs.executor.Executor`, e.g. a server's, which
            lives longer than the sweep). None starts one for the sweep from `scheduler` and
            `n_workers` and closes it at the end.
        scheduler: without `executor`: None (a LocalCluster of one single-threaded worker
            process per core), "tcp://HOST:PORT" (an existing Dask scheduler; its workers need
            `twin` installed) or "in-process" (one worker thread in this process).
        progress: a tqdm bar over runs.
        n_workers: without `executor`: workers of the LocalCluster (default: the cores).
        chunk_size: runs per task, stepped together by `simulate_many`.
        on_progress: called with (runs done, runs in all) after each chunk (e.g. a REST job's
            status).
        stop: polled after each chunk; once it returns True the remaining chunks are cancelled
            and `SweepStopped` is raised (a server shutting down).

    Raises:
        ValueError: a bad spec (naming the field), a bad `chunk_size` or scheduler.
        SweepStopped: `stop` returned True.
    """
    spec = spec if isinstance(spec, SweepSpec) else SweepSpec(**spec)
    if not 1 <= chunk_size <= 4096:
        raise TwinError(f"chunk_size: got {chunk_size}, allowed 1 … 4096")
    if executor is None:
        with Executor.start(scheduler, n_workers=n_workers) as own:
            return run_sweep(
                spec, executor=own, progress=progress, chunk_size=chunk_size,
                on_progress=on_progress, stop=stop,
            )  # fmt: skip
    scenarios = spec.scenarios()
    order = sorted(range(len(scenarios)), key=lambda i: scenarios[i]["planner"])
    chunks = [order[s : s + chunk_size] for s in range(0, len(order), chunk_size)]
    threshold = spec.tip_error_threshold
    rows: list[dict[str, Any] | None] = [None] * len(scenarios)
    start = time.perf_counter()  # an executor's start-up is not the sweep's time
    futures = {
        executor.submit(
            run_chunk, [scenarios[i] for i in c], threshold, threads=executor.numba_threads,
            priority=SWEEP_PRIORITY,
        ): c
        for c in chunks
    }  # fmt: skip
    try:
        with tqdm(total=len(scenarios), disable=not progress, unit="run") as bar:
            for future in executor.as_completed(futures):
                if stop is not None and stop():
                    raise SweepStopped("sweep stopped before its end; its chunks were cancelled")
                _collect(rows, futures[future], future.result(), bar, on_progress)
    finally:
        executor.cancel(futures)
    elapsed = time.perf_counter() - start
    runs = pd.DataFrame(rows)
    table = (
        runs.groupby(list(AXES), sort=False)
        .agg(
            runs=("operable", "size"),
            operable_runs=("operable", "sum"),
            tip_position_error_max=("tip_position_error_max", "max"),
            violations_max=("violations", "max"),
        )
        .reset_index()
    )
    table.insert(len(AXES) + 2, "operability", table["operable_runs"] / table["runs"])
    return SweepResult(spec, runs, table, elapsed, executor.where)


def run_chunk(
    scenarios: list[dict[str, Any]], threshold: float, *, threads: int | None = 1
) -> list[dict[str, Any]]:
    """One task: run scenarios with `simulate_many`, keep `RUN_METRICS` and `operable`.

    Args:
        scenarios: scenario fields, one planner.
        threshold: [m] tip position error bound of an operable run.
        threads: numba threads for the chunk (1 on a cluster of one worker per core; None:
            numba's own count).
    """
    with limit_threads(threads):
        results = simulate_many(scenarios, keep="metrics")  # a cell reads metrics alone
    rows = []
    for fields, result in zip(scenarios, results, strict=True):
        m = result.metrics
        row = {axis: fields[axis] for axis in AXES} | {"seed": fields["seed"]}
        # a small platform's violations are all of one kind (`limit_violations` has them)
        row |= {name: m.get(name, m["violations"] if "violations" in name else 0)
                for name in RUN_METRICS}  # fmt: skip
        row["operable"] = m["violations"] == 0 and m["tip_position_error_max"] <= threshold
        rows.append(row)
    return rows


def spec_around(
    scenario: Scenario,
    *,
    seeds: int = 2,
    duration: float = 60.0,
    hs_points: int = 5,
    tp_points: int = 3,
    hs_span: float = 0.5,
    tp_span: float = 2.0,
    tip_error_threshold: float = 0.05,
) -> SweepSpec:
    """A sweep of Hs × Tp around a scenario's sea, everything else as the scenario has it.

    Hs takes `hs_points` values evenly over (1 − hs_span) … (1 + hs_span) times the
    scenario's (0 … 2·hs_span m on a calm sea, Hs = 0; at most 20 m), Tp `tp_points` values
    evenly over its ± `tp_span` seconds, clipped to the allowed periods (`TP_RANGE`, 1 … 30 s;
    values clipped onto the same limit count once, so that axis is shorter). Values are
    rounded to 3 significant digits and the one nearest the scenario's own value is that value
    exactly, so the scenario's sea is always a cell (the middle one with an odd count; with an
    even count the lower of the two middle ones, so that grid is not symmetric). The planner,
    its knobs (`beta`, `k_e`, `k_c` as one-value axes, the rest in `scenario`), heading,
    spectrum, vessel and limits mode are the scenario's.

    Args:
        scenario: the sea, mechanism, planner and knobs swept around.
        seeds: [-] sea seeds per cell, 0 … seeds − 1.
        duration: [s] simulated time per run.
        hs_points: [-] Hs values, a whole number 2 … `AROUND_MAX_POINTS` (11).
        tp_points: [-] Tp values, a whole number 2 … `AROUND_MAX_POINTS` (11).
        hs_span: [-] Hs's relative half-width, 0 < hs_span < 1 (0.5: 0.5 … 1.5 × Hs).
        tp_span: [s] Tp's half-width, 0 < tp_span ≤ `AROUND_MAX_TP_SPAN` (10 s).
        tip_error_threshold: [m] largest tip position error of an operable run.

    Raises:
        ValueError: a bad count or span (a `TwinError`), naming the argument and its
            allowed range; or a bad `SweepSpec` field (`seeds`, `duration`, …), naming it.
    """
    _check_around(hs_points=hs_points, tp_points=tp_points, hs_span=hs_span, tp_span=tp_span)
    hs_points, tp_points, hs_span, tp_span = (
        int(hs_points), int(tp_points), float(hs_span), float(tp_span)
    )  # fmt: skip
    hs, tp = scenario.sea()
    if hs > 0:
        hs_axis = hs * np.linspace(1.0 - hs_span, 1.0 + hs_span, hs_points)
    else:  # a calm sea: the width of the grid around a 1 m sea, from 0 up
        hs_axis = np.linspace(0.0, 2.0 * hs_span, hs_points)
    tp_axis = np.clip(tp + np.linspace(-tp_span, tp_span, tp_points), *TP_RANGE)
    hs_values = _readable(np.clip(hs_axis, 0.0, 20.0), hs)
    tp_values = _readable(tp_axis, tp)
    own = {"heading", "planner", "beta", "k_e", "k_c"}
    skip = {*AXES, "mechanism", "duration", "dt", "seed", "sea_state", "regular_waves",
            "initial_state"}  # fmt: skip
    fields = scenario.model_dump()
    return SweepSpec(
        mechanism=scenario.mechanism,
        hs=hs_values,
        tp=tp_values,
        **{axis: [fields[axis]] for axis in sorted(own)},
        seeds=seeds,
        duration=duration,
        dt=scenario.dt,
        tip_error_threshold=tip_error_threshold,
        scenario={k: v for k, v in fields.items() if k not in skip and v is not None},
    )


def _check_around(*, hs_points: Any, tp_points: Any, hs_span: Any, tp_span: Any) -> None:
    """`spec_around`'s grid arguments within their ranges; the error names the argument."""
    for name, points in (("hs_points", hs_points), ("tp_points", tp_points)):
        whole = isinstance(points, int | np.integer) and not isinstance(points, bool)
        if not whole or not 2 <= points <= AROUND_MAX_POINTS:
            raise TwinError(
                f"{name}: got {points!r}, allowed a whole number 2 … {AROUND_MAX_POINTS}"
            )
    if not _finite(hs_span) or not 0.0 < hs_span < 1.0:
        raise TwinError(
            f"hs_span: got {hs_span!r}, allowed 0 < hs_span < 1 (Hs spans (1 − hs_span) … "
            "(1 + hs_span) times the current Hs)"
        )
    if not _finite(tp_span) or not 0.0 < tp_span <= AROUND_MAX_TP_SPAN:
        raise TwinError(
            f"tp_span: got {tp_span!r}, allowed 0 < tp_span ≤ {AROUND_MAX_TP_SPAN:g} s (Tp "
            "spans the current Tp ± tp_span)"
        )


def _finite(value: Any) -> bool:
    """A real number (not a bool), finite."""
    real = isinstance(value, int | float | np.integer | np.floating)
    return real and not isinstance(value, bool) and math.isfinite(value)


def _readable(values: np.ndarray, centre: float) -> list[float]:
    """Grid values to 3 significant digits, the one nearest `centre` exactly `centre` (of two
    as near, the lower one; float noise does not decide); repeats dropped."""
    out = [float(f"{v:.3g}") for v in values]
    out[int(np.argmin(np.round(np.abs(values - centre), 9)))] = float(centre)
    return list(dict.fromkeys(out))


def panel_count(spec: SweepSpec) -> int:
    """Heatmap panels a sweep's figure has: one per planner, heading and (β, k_e, k_c)."""
    return math.prod(len(getattr(spec, axis)) for axis in PANEL_AXES)


def heatmap_png(
    result: SweepResult,
    path: Any,
    mark: tuple[float, float] | None = None,
    *,
    max_panels: int = MAX_PANELS,
) -> Any:
    """Operability heatmaps, Hs (rows) × Tp (columns), one panel per planner, heading and
    (β, k_e, k_c); cells annotated in percent; the criterion in the title.

    At most `max_panels` panels are drawn (the first ones, in the table's order); the title
    then says how many the table has, so a figure's cost stays bounded whatever the sweep.

    Args:
        result: the sweep.
        path: the PNG written (or a binary file object).
        mark: (Hs [m], Tp [s]) to ring on every panel, e.g. the live sea (left out when it
            lies outside the grid).
        max_panels: most panels drawn.

    Returns:
        The path written.
    """
    from matplotlib.figure import Figure

    table = result.table
    hs, tp = sorted(table["hs"].unique()), sorted(table["tp"].unique())
    panels = list(table.groupby(list(PANEL_AXES), sort=False))
    shown = "" if len(panels) <= max_panels else (
        f"; the first {max_panels} of {len(panels)} panels (the table has all)"
    )
    panels = panels[:max_panels]
    columns = min(len(panels), 3)
    rows = -(-len(panels) // columns)
    figure = Figure(
        figsize=(2.0 + (1.2 + 0.7 * len(tp)) * columns, 1.2 + (1.4 + 0.5 * len(hs)) * rows),
        layout="constrained",
    )
    axes = figure.subplots(rows, columns, squeeze=False)
    image = None
    for ax, ((planner, heading, beta, k_e, k_c), cell) in zip(axes.flat, panels, strict=False):
        grid = (
            cell.pivot_table(index="hs", columns="tp", values="operability")
            .reindex(index=hs, columns=tp)
            .to_numpy()
        )
        image = ax.imshow(100 * grid, cmap="RdYlGn", vmin=0, vmax=100, origin="lower")
        for (i, j), value in np.ndenumerate(grid):
            if np.isfinite(value):
                ax.text(j, i, f"{100 * value:.0f}", ha="center", va="center", fontsize=8)
        # rounded as users read a sea: Hs to 0.1 m, Tp to 0.1 s
        ax.set_xticks(range(len(tp)), [f"{v:.1f}" for v in tp])
        ax.set_yticks(range(len(hs)), [f"{v:.1f}" for v in hs])
        ax.set_xlabel("Tp [s]")
        ax.set_ylabel("Hs [m]")
        knobs = f"β {beta:g}, k_e {k_e:g}, k_c {k_c:g}"  # the hybrid system's knobs
        if result.spec.mechanism != "hybrid":
            knobs = result.spec.mechanism
        ax.set_title(f"{str(planner).upper()}, heading {heading:g}°\n{knobs}", fontsize=9)
        if mark is not None and hs[0] <= mark[0] <= hs[-1] and tp[0] <= mark[1] <= tp[-1]:
            x = np.interp(mark[1], tp, np.arange(len(tp)))
            y = np.interp(mark[0], hs, np.arange(len(hs)))
            ax.plot(x, y, "o", ms=22, mfc="none", mec="black", mew=2.0, label="current sea")
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.18), fontsize=8,
                      frameon=False, markerscale=0.5)  # fmt: skip
    for ax in axes.flat[len(panels) :]:
        ax.set_visible(False)
    figure.suptitle(
        f"Operability [%], {result.spec.seeds} seed{'s' if result.spec.seeds != 1 else ''} "
        f"per cell, {result.spec.duration:g} s runs\n"
        f"operable: no limit violation, tip error ≤ {result.spec.tip_error_threshold:g} m"
        f"{shown}",
        fontsize=9,
    )
    if image is not None:
        figure.colorbar(image, ax=axes, label="operable runs [%]", shrink=0.8)
    path = Path(path) if isinstance(path, str | Path) else path
    figure.savefig(path, dpi=120, bbox_inches="tight", format="png")
    return path


def heatmap_bytes(result: SweepResult, max_panels: int = MAX_PANELS) -> bytes:
    """`heatmap_png` as PNG bytes: the task a server submits to its executor, so the figure
    is drawn in a worker process, never in the process that answers requests."""
    import io

    buffer = io.BytesIO()
    heatmap_png(result, buffer, max_panels=max_panels)
    return buffer.getvalue()


def _collect(
    rows: list[dict[str, Any] | None],
    chunk: list[int],
    done: list[dict[str, Any]],
    bar: tqdm,
    on_progress: Callable[[int, int], None] | None,
) -> None:
    for i, row in zip(chunk, done, strict=True):
        rows[i] = row
    bar.update(len(chunk))
    if on_progress is not None:
        on_progress(sum(row is not None for row in rows), len(rows))  # a bar may be disabled


def _plain(value: Any) -> Any:
    """numpy scalars → Python scalars, recursively (json.dumps cannot take numpy types)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value.item() if isinstance(value, np.generic) else value

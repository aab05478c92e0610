"""The onboard report: from a measured motion log to the sea, operability now and heading advice.

For each window of the log (`twin.motion.estimate.window_starts`, 20 min by default):

1. the sea estimated from the vessel's own motion (`twin.motion.estimate.estimate_sea`, the
   wave buoy analogy): Hs, Tp, the relative direction β the waves travel towards
   (`Scenario.heading`) and their uncertainty; a refused window keeps its reason;
2. each planner's probability of being operable at the current relative heading β — from the
   workability cells, the one code path (`twin.runs.workability.run_workability` with the record
   strategy: a cell heading is the nearest of the strategy grid, a missing cell is run and
   cached);
3. the heading advice: every relative heading of the strategy grid (`WorkabilitySpec.
   heading_grid`) ranked by that probability (ties: the smaller turn first), with the turn of
   the bow that reaches it. The waves keep their direction, so reaching β' from β turns the bow by
   Δψ = β − β' (wrapped to ±180°): positive is a turn to port (counter-clockwise seen from above,
   z up), negative to starboard;
4. an alert when a planner's probability at the current heading drops below `threshold`.

This module lives in `twin.sim` because it needs the cells; `twin.motion.estimate` below it
knows nothing of the simulation. All headings are evaluated in one `run_workability` call first
(the best-of-grid strategy: every cell any window needs, run on one executor), so the per-heading
and current-heading calls that follow find their cells cached.

    report = onboard_report(t, motion, OnboardSpec(), start=np.datetime64("2026-08-01T14:00"))
    report.write("out/")    # onboard.csv, advice.csv, onboard.json, timeline.png
"""

from __future__ import annotations

import io
import json
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, model_validator

from twin.errors import TwinError
from twin.motion.estimate import (
    DEFAULT_WINDOW,
    MIN_WINDOW,
    EstimateRefused,
    SeaEstimate,
    estimate_sea,
    window_starts,
)
from twin.motion.mount import vessel_motion_from
from twin.runs.executor import Executor
from twin.runs.workability import (
    OPERABLE_LEVEL,
    HeadingStrategy,
    WorkabilitySpec,
    run_workability,
)
from twin.sim.base_motion import mount_for, raos_named
from twin.site.heading import wave_from
from twin.site.records import SiteRecord

#: [s] the longest window (an hour: beyond it the sea is seldom stationary)
MAX_WINDOW = 3600.0
#: most headings the strategy grid may have (`HeadingStrategy`'s best-of set)
MAX_HEADINGS = 36
#: the strategy grid's default: every 30° (12 relative headings)
DEFAULT_HEADINGS = [float(h) for h in range(0, 360, 30)]


class OnboardSpec(BaseModel):
    """An onboard report's request: window, alert threshold, the JONSWAP γ the estimate assumes,
    and the workability spec whose cells judge operability (its `heading_grid` is the strategy
    grid the advice ranks; its `heading` is set here)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    window: float = Field(DEFAULT_WINDOW, ge=MIN_WINDOW, le=MAX_WINDOW,
                          description="[s] window length of one estimate (10-60 min)")  # fmt: skip
    threshold: float = Field(
        OPERABLE_LEVEL, ge=0.0, le=1.0,
        description="[-] alert when a planner's probability is under it",
    )  # fmt: skip
    gamma: float = Field(3.3, ge=1.0, le=10.0, description="[-] JONSWAP γ the estimate assumes")
    workability: WorkabilitySpec = Field(
        default_factory=lambda: WorkabilitySpec(heading_grid=DEFAULT_HEADINGS),
        description="mechanism, planners, seeds, cell grids (heading_grid: the strategy grid)",
    )

    @model_validator(mode="after")
    def _grid(self) -> OnboardSpec:
        grid = self.workability.heading_grid
        if len(grid) > MAX_HEADINGS:
            raise TwinError(f"workability.heading_grid: {len(grid)} headings; the advice ranks "
                            f"at most {MAX_HEADINGS}")  # fmt: skip
        return self

    def vessel(self) -> str:
        """The RAO table the motion is read through: the scenario's vessel, else the mount's."""
        spec = self.workability
        return str(spec.scenario.get("vessel") or mount_for(spec.mechanism).vessel)


@dataclass
class OnboardReport:
    """A finished report.

    Attributes:
        spec: what was asked.
        windows: one row per window and planner: `start`, `end` [s of the log], `time` (the
            window's start, UTC, if the log has a start time), `hs`, `hs_sd`, `tp`, `tp_sd`,
            `direction`, `direction_sd` [deg, `Scenario.heading`], `ambiguous`, `refused` (the
            reason, "" if estimated), `planner`, `cell_heading` [deg], `probability` [0-1] at
            the current heading, `alert`, `best_heading`, `best_probability`, `turn` [deg, +
            to port] to the best heading.
        advice: one row per estimated window, planner and grid heading: `start`, `planner`,
            `heading`, `probability`, `turn` [deg], `rank` (1 best).
        estimates: the `SeaEstimate` per window (None where refused).
        notes: what a reader should know (assumptions, refusals, cells' notes).
    """

    spec: OnboardSpec
    windows: pd.DataFrame
    advice: pd.DataFrame
    estimates: list[SeaEstimate | None]
    notes: list[str] = field(default_factory=list)
    runs: int = 0
    new_runs: int = 0

    def alerts(self) -> list[dict[str, Any]]:
        """Each window and planner under the threshold: start, planner, probability, the best
        heading and the turn to it."""
        rows = self.windows[self.windows["alert"]]
        return [{"start": float(start), "planner": str(planner), "probability": float(p),
                 "best_heading": float(best), "turn": float(turn)}
                for start, planner, p, best, turn in zip(
                    rows["start"], rows["planner"], rows["probability"], rows["best_heading"],
                    rows["turn"], strict=True)]  # fmt: skip

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: spec, the windows (records), alerts, notes, runs (advice: `advice.csv`)."""
        table = self.windows.copy()
        if "time" in table:
            table["time"] = [pd.Timestamp(v).isoformat() + "Z" for v in table["time"]]
        records = [{k: (None if isinstance(v, float) and np.isnan(v) else v)
                    for k, v in row.items()}
                   for row in table.to_dict(orient="records")]  # fmt: skip
        return {
            "spec": self.spec.model_dump(mode="json"), "vessel": self.spec.vessel(),
            "windows": records, "alerts": self.alerts(),
            "notes": self.notes, "runs": self.runs, "new_runs": self.new_runs,
        }  # fmt: skip

    def timeline_png(self) -> bytes:
        """The timeline plot (`onboard_timeline`) as PNG bytes."""
        buffer = io.BytesIO()
        onboard_timeline(self).savefig(buffer, format="png", dpi=110, bbox_inches="tight")
        return buffer.getvalue()

    def write(self, out: str | Path) -> list[Path]:
        """`onboard.csv` (windows), `advice.csv`, `onboard.json` and `timeline.png` into `out`."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        paths = [out / "onboard.csv", out / "advice.csv", out / "onboard.json",
                 out / "timeline.png"]  # fmt: skip
        self.windows.to_csv(paths[0], index=False, float_format="%.6g")
        self.advice.to_csv(paths[1], index=False, float_format="%.6g")
        paths[2].write_text(json.dumps(self.to_dict(), indent=2) + "\n")
        paths[3].write_bytes(self.timeline_png())
        return paths


def estimate_windows(
    t: np.ndarray, motion: np.ndarray, spec: OnboardSpec, executor: Executor | None = None
) -> tuple[np.ndarray, list[SeaEstimate | str]]:
    """[s] window starts and, per window, its `SeaEstimate` or the reason it was refused; on
    `executor`'s workers in parts (one per worker, in order) when given, else here."""
    if t.ndim != 1 or t.size < 2:
        raise TwinError(f"time: a 1-D series of at least two samples, got shape {t.shape}")
    end = float(t[-1] + np.median(np.diff(t)))  # N samples cover N steps
    starts = window_starts(float(t[0]), end, spec.window)
    if starts.size == 0:
        raise TwinError(f"log: {end - float(t[0]):.0f} s of motion; at least one window of "
                        f"{MIN_WINDOW:.0f} s is needed")  # fmt: skip
    windows = [(t[inside], motion[inside])
               for inside in ((t >= s) & (t < s + spec.window) for s in starts)]  # fmt: skip
    split = np.array_split(np.arange(starts.size), _workers(executor, starts.size))
    parts = [[windows[i] for i in indices] for indices in split]
    if executor is None or len(parts) == 1:
        return starts, [e for part in parts for e in estimate_part(part, spec)]
    futures = [executor.submit(estimate_part, part, spec) for part in parts]
    try:
        return starts, [e for future in futures for e in future.result()]
    finally:
        executor.cancel(futures)


def _workers(executor: Executor | None, windows: int) -> int:
    """How many parts the windows go in: one per worker thread of `executor` (1 without)."""
    return 1 if executor is None else max(1, min(executor.workers, windows))


def estimate_part(
    part: list[tuple[np.ndarray, np.ndarray]], spec: OnboardSpec
) -> list[SeaEstimate | str]:
    """`estimate_sea` of each (t, motion) window of `part`, or the reason it was refused."""
    raos = raos_named(spec.vessel())
    out: list[SeaEstimate | str] = []
    for t, motion in part:
        try:
            out.append(estimate_sea(t, motion, raos, gamma=spec.gamma))
        except EstimateRefused as exc:
            out.append(str(exc))
    return out


def centre_motion(sensor_motion: np.ndarray, sensor_position: Any) -> np.ndarray:
    """(N, 6) [m, rad] the centre of motion's motion from a sensor's at `sensor_position` (3,)
    [m] (`twin.motion.mount.vessel_motion_from`), a channel the sensor does not give kept
    absent (NaN), not read as zero: the estimate must not fit a sway it never measured."""
    absent = np.all(np.isnan(sensor_motion), axis=0)
    out = vessel_motion_from(sensor_motion, sensor_position)
    out[:, absent] = np.nan
    return out


def turn_to(current: np.ndarray | float, target: np.ndarray | float) -> np.ndarray:
    """[deg] the bow's turn Δψ = β − β' (wrapped to (−180°, 180°], + to port) that takes the
    relative heading from `current` β to `target` β' with the waves' direction unchanged."""
    d = np.mod(np.asarray(current, dtype=float) - np.asarray(target, dtype=float), 360.0)
    return np.where(d > 180.0, d - 360.0, d)


def onboard_report(
    t: np.ndarray,
    motion: np.ndarray,
    spec: OnboardSpec | dict,
    *,
    start: np.datetime64 | None = None,
    data_dir: str | Path | None = None,
    executor: Executor | None = None,
    scheduler: str | None = None,
    n_workers: int | None = None,
    stop: Callable[[], bool] | None = None,
) -> OnboardReport:
    """The onboard report of a motion log (module docstring).

    Args:
        t: (N,) [s] uniform times; motion: (N, 6) [m, rad] centre-of-motion motion, vessel
            frame (`twin.motion.estimate.estimate_sea`), NaN columns absent.
        spec: an `OnboardSpec` or its fields.
        start: the UTC time of t = 0, if known (the tables then carry times).
        data_dir: folder of the cell cache; None: a temporary one for this report.
        executor, scheduler, n_workers, stop: as `run_workability`.

    Raises:
        TwinError: malformed input, or no window to estimate (a log under `MIN_WINDOW`).
    """
    spec = spec if isinstance(spec, OnboardSpec) else OnboardSpec(**spec)
    starts, estimates = estimate_windows(np.asarray(t, float), np.asarray(motion, float), spec,
                                         executor)  # fmt: skip
    kept = [i for i, e in enumerate(estimates) if isinstance(e, SeaEstimate)]
    notes = [f"window at {starts[i]:.0f} s refused: {e}" for i, e in enumerate(estimates)
             if isinstance(e, str)]  # fmt: skip
    if kept:
        notes += list(dict.fromkeys(n for i in kept for n in estimates[i].notes))  # type: ignore[union-attr]
    origin: Any = np.datetime64(0, "ns")
    if start is not None:
        origin = np.asarray(start, "datetime64[ns]")[()]
    found = [e for e in estimates if isinstance(e, SeaEstimate)]
    current = np.empty((2, len(spec.workability.planners or []), 0))
    by_heading: dict[float, np.ndarray] = {}
    runs = new_runs = 0
    if found:
        times = origin + (starts[kept] * 1e9).astype("timedelta64[ns]")
        with tempfile.TemporaryDirectory(prefix="twin-onboard-") as scratch:
            cells = _Cells(spec, times, found, data_dir or scratch, executor, scheduler,
                           n_workers, stop)  # fmt: skip
            current, by_heading, notes_cells = cells.evaluate()
            runs, new_runs = cells.runs, cells.new_runs
        notes += notes_cells
    windows, advice = _tables(spec, starts, estimates, kept, current, by_heading,
                              None if start is None else origin)  # fmt: skip
    seas = [e if isinstance(e, SeaEstimate) else None for e in estimates]
    return OnboardReport(spec, windows, advice, seas, notes, runs, new_runs)


class _Cells:
    """The workability calls of one report: all headings first (so one executor runs every
    missing cell), then each grid heading and the current heading from the cache."""

    def __init__(
        self, spec: OnboardSpec, times: np.ndarray, found: list[SeaEstimate],
        data_dir: str | Path, executor: Executor | None, scheduler: str | None,
        n_workers: int | None, stop: Callable[[], bool] | None,
    ) -> None:  # fmt: skip
        self.spec, self.data_dir, self.stop = spec, data_dir, stop
        self.executor, self.scheduler, self.n_workers = executor, scheduler, n_workers
        beta = np.array([e.direction for e in found])
        self.record = SiteRecord(
            hs=np.array([e.hs for e in found]), tp=np.array([e.tp for e in found]), time=times,
            direction=np.asarray(wave_from(beta, 0.0)), kind="timeseries",
            source="wave buoy analogy estimates",
        )  # fmt: skip
        self.runs = self.new_runs = 0
        self.notes: list[str] = []

    def _call(self, heading: HeadingStrategy) -> pd.DataFrame:
        spec = self.spec.workability.model_copy(update={"heading": heading})
        result = run_workability(spec, self.record, executor=self.executor,
                                 scheduler=self.scheduler, n_workers=self.n_workers,
                                 data_dir=self.data_dir, stop=self.stop)  # fmt: skip
        self.runs = max(self.runs, result.runs)
        self.new_runs += result.new_runs
        self.notes = result.notes
        return result.rows

    def evaluate(self) -> tuple[np.ndarray, dict[float, np.ndarray], list[str]]:
        """(planners, windows) probability at the current heading with the cell heading in a
        last row block, per grid heading the same, and the cells' notes."""
        grid = list(self.spec.workability.heading_grid)
        self._call(HeadingStrategy(kind="best", headings=grid))  # runs what is missing
        by_heading = {h: _per_planner(self._call(HeadingStrategy(kind="fixed", headings=[h])),
                                      "probability") for h in grid}  # fmt: skip
        # the record strategy: compass vessel heading 0 and waves from wave_from(β, 0) give β
        rows = self._call(HeadingStrategy(kind="record", vessel_heading=0.0))
        current = np.stack([_per_planner(rows, "probability"),
                            _per_planner(rows, "cell_heading")])  # fmt: skip
        return current, by_heading, self.notes


def _per_planner(rows: pd.DataFrame, column: str) -> np.ndarray:
    """(planners, windows) of a workability result's column, planners in their order."""
    return np.stack([g[column].to_numpy(float) for _, g in rows.groupby("planner", sort=False)])


def _tables(
    spec: OnboardSpec, starts: np.ndarray, estimates: list[SeaEstimate | str], kept: list[int],
    current: np.ndarray, by_heading: dict[float, np.ndarray], origin: np.datetime64 | None,
) -> tuple[pd.DataFrame, pd.DataFrame]:  # fmt: skip
    """The windows table and the advice table (`OnboardReport`)."""
    planners = list(spec.workability.planners or [])
    grid = np.array(list(by_heading), dtype=float)
    rows, advice = [], []
    for i, estimate in enumerate(estimates):
        base: dict[str, Any] = {"start": float(starts[i]), "end": float(starts[i] + spec.window)}
        if origin is not None:
            base["time"] = origin + np.timedelta64(int(starts[i] * 1e9), "ns")
        sea = estimate if isinstance(estimate, SeaEstimate) else None
        for name in ("hs", "hs_sd", "tp", "tp_sd", "direction", "direction_sd"):
            base[name] = getattr(sea, name) if sea is not None else np.nan
        base["ambiguous"] = bool(sea.ambiguous) if sea is not None else False
        base["refused"] = "" if sea is not None else str(estimate)
        for p, planner in enumerate(planners):
            row = {**base, "planner": planner, "cell_heading": np.nan, "probability": np.nan,
                   "alert": False, "best_heading": np.nan, "best_probability": np.nan,
                   "turn": np.nan}  # fmt: skip
            if sea is not None:
                k = kept.index(i)
                probs = np.array([by_heading[h][p, k] for h in grid])
                turns = turn_to(sea.direction, grid)
                order = np.lexsort((np.abs(turns), -probs))
                row |= {"cell_heading": current[1, p, k], "probability": current[0, p, k],
                        "alert": bool(current[0, p, k] < spec.threshold),
                        "best_heading": grid[order[0]], "best_probability": probs[order[0]],
                        "turn": float(turns[order[0]])}  # fmt: skip
                advice += [{"start": float(starts[i]), "planner": planner, "heading": grid[j],
                            "probability": probs[j], "turn": float(turns[j]), "rank": r + 1}
                           for r, j in enumerate(order)]  # fmt: skip
            rows.append(row)
    columns = ["start", "planner", "heading", "probability", "turn", "rank"]
    return pd.DataFrame(rows), pd.DataFrame(advice, columns=columns)


def onboard_timeline(report: OnboardReport) -> Any:
    """A matplotlib figure: Hs and Tp (±1σ), the direction, and each planner's probability at
    the current heading with the threshold, against the window start [min]; refused windows
    blank, alerts marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    table = report.windows
    first = table.drop_duplicates("start")
    minutes = first["start"].to_numpy() / 60.0
    fig, axes = plt.subplots(4, 1, figsize=(8, 8), sharex=True)
    labels = {"hs": "Hs [m]", "tp": "Tp [s]", "direction": "β, waves to [deg from bow]"}
    for ax, (name, label) in zip(axes[:3], labels.items(), strict=True):
        ax.errorbar(minutes, first[name], yerr=first[f"{name}_sd"], fmt="o-", ms=3, capsize=2)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[2].set_ylim(0, 360)
    ax = axes[3]
    for planner, group in table.groupby("planner", sort=False):
        line = ax.plot(group["start"] / 60.0, group["probability"], "o-", ms=3, label=planner)
        alert = group[group["alert"]]
        ax.plot(alert["start"] / 60.0, alert["probability"], "x", ms=8, color=line[0].get_color())
    ax.axhline(report.spec.threshold, color="red", lw=1, ls="--", label="alert threshold")
    ax.set_ylim(-0.05, 1.05)
    ax.set_ylabel("P(operable)")
    ax.set_xlabel("window start [min]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    axes[0].set_title(f"onboard report: sea from the {report.spec.vessel()}'s motion, "
                      "operability at the current heading")  # fmt: skip
    return fig


def onboard_task(
    t: np.ndarray, motion: np.ndarray, fields: dict[str, Any], *, start: str | None,
    data_dir: str, where: str,
) -> dict[str, Any]:  # fmt: skip
    """One REST job, a task on a worker of the server's executor: the report's JSON with its
    advice records, and the timeline PNG. Missing cells go to the same cluster as chunks
    (`distributed.worker_client`, as `twin.web.workability_jobs.evaluate_job`).

    Args:
        t, motion: the log as `onboard_report` takes it; fields: `OnboardSpec` fields.
        start: the UTC time of t = 0 (ISO 8601), or None.
        data_dir: folder of the cell cache; where: the executor's `where`.
    """
    from distributed import worker_client

    with worker_client() as client:  # this task leaves its slot to the chunks it waits for
        report = onboard_report(
            t, motion, OnboardSpec(**fields), executor=Executor(client, where=where),
            start=None if start is None else np.datetime64(start.rstrip("Z"), "ns"),
            data_dir=data_dir,
        )  # fmt: skip
    advice = report.advice.to_dict(orient="records")
    return {"result": {**report.to_dict(), "advice": advice}, "png": report.timeline_png()}

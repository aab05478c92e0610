"""Site workability: from a site's wave record to the share of time a planner can work.

For every record row (a sea state: Hs, Tp, direction, time or occurrence) and every planner, the
probability that a run is *operable* — the criterion of operability sweeps (`twin.runs.sweep`):
no joint or leg limit violated and the tip position error under `tip_error_threshold` — over
`seeds` sea seeds (0 … seeds − 1, the same for every row and planner, so planners are compared
on the same wave records). Runs are ordinary `Scenario`s stepped by `simulate_many` on the one
executor (`twin.runs.executor`) in chunks, below the priority of single runs, like sweeps.

    spec = WorkabilitySpec(planners=["mtmp", "qp"], seeds=5)
    record = read_record(asset_path("site", "46097h2019_08.txt"))
    result = run_workability(spec, record, data_dir="data")   # cells cached in data/cells.sqlite
    result.summary["workability"]          # {"mtmp": 0.71, "qp": 0.93}
    result.write("out/")                   # workability.csv, workability.json, *.png
    result.pngs()                          # {"monthly.png": b"...", ...}

Two methods:

- `cells` (default): each row is evaluated on a stated grid of operability cells (Hs × Tp ×
  relative heading). The row's cell is the grid rectangle around its Hs and Tp; its
  probability is **interpolated bilinearly in Hs and Tp between the cell's four corners**
  (`cell_lookup="linear"`, the default), or taken as **the worse of the two corners at the
  cell's upper Hs** (`cell_lookup="conservative"`: operability falls with Hs, and is not
  monotonic in Tp, so neither Tp side is safe alone: a lower bound). A cell whose corners'
  probabilities differ by more than `refine_spread` is **split** at its midpoints in Hs and
  Tp (up to `refine_levels` times, per planner: the runs go where operability changes
  fastest), and the row takes the sub-cell around it. In heading the row takes the **nearest
  relative heading** on the circle (exact for the fixed and best-of strategies, whose headings
  are the grid). A row above the highest Hs of the grid is not operable. Cells are run once
  per (scenario, seed) and cached on disk, keyed by every scenario field and
  `ENGINE_VERSION`, so another record, a longer one, or more seeds reuse them.
- `direct`: each row is run at its own Hs, Tp and heading (also cached, by the same keys).

Heading strategies (`HeadingStrategy`, `twin.site.heading` for the conventions): a fixed
relative heading; the best of a set (the captain picks the heading that keeps every limit: a
row's probability is the largest over the set, and the heading that gave it is reported); or the
vessel heading from the record (β from the record's wave direction and vessel heading).

The limiting constraint of a non-operable run is the limit that bound first, read from its
metrics (`twin.sim.metrics`, "first_bound"): the limit its first violating sample violates. For
the hybrid system, a virtual joint and side ("joint d3 (upper)") or one of the six legs ("leg 4
(lower)"); of several violated at that sample, the one passed furthest as a share of its range.
For a small platform, the first limit kind that sample violates (leg stroke, U-joint angle,
collision, state range; the clamped demand, in `record` mode, last). A run that violates no
limit but misses the tip-error threshold is limited by the tip error.
"""

from __future__ import annotations

import calendar
import contextlib
import hashlib
import io
import itertools
import json
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator
from tqdm import tqdm

import twin
from twin.db import session
from twin.errors import TwinError
from twin.planners import get_planner
from twin.runs.executor import SWEEP_PRIORITY, Executor
from twin.sim.scenario import DEFAULT_PLANNER, TP_RANGE, Scenario
from twin.site.heading import angular_distance, relative_heading
from twin.site.records import Duplicates, SiteRecord, read_record, utc_column
from twin.site.windows import record_step, window_stats

#: what a cached cell depends on besides its scenario: the package version and this module's
#: reduction of a run (bump CELL_FORMAT when `run_summary` or the engine's results change;
#: 3: the hybrid planners' exact-sampled tip gain, issue 39, made earlier cells stale; 4: the
#: SE(3) exp/log coefficients free of cancellation, run results moved by up to 3e-9)
CELL_FORMAT = 4
ENGINE_VERSION = f"twin {twin.__version__} / cells {CELL_FORMAT}"
#: the cache file in a data dir
CELL_DATABASE = "cells.sqlite"
#: most runs one evaluation may need (new or cached)
MAX_RUNS = 2_000_000
#: most rows a record may have (10 years hourly is 87 600)
MAX_ROWS = 200_000
#: a row counts as operable (windows, strips) when its probability reaches this
OPERABLE_LEVEL = 0.5
#: a month the record covers for less than this share of its hours is marked partial
PARTIAL_MONTH = 0.5
MONTHS = ("Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec")
#: Scenario fields `WorkabilitySpec` sets itself (not through `scenario`)
OWN_FIELDS = {"mechanism", "planner", "hs", "tp", "heading", "seed", "duration", "dt",
              "sea_state", "regular_waves"}  # fmt: skip


class WorkabilityStopped(RuntimeError):
    """An evaluation was stopped before its end (`run_workability`'s `stop`)."""


class HeadingStrategy(BaseModel):
    """How the vessel meets the waves.

    kind:
        fixed: every row at `headings[0]`, a relative heading (`Scenario.heading`, deg: 180 head
            seas, 90 waves travelling to port); the vessel turns with the waves.
        best: each row at every heading of `headings`; the captain takes the one that keeps
            every limit (the row's probability is the largest over them).
        record: the row's own relative heading, from the record's wave direction (from, deg true)
            and the vessel heading (deg true, where the bow points): `vessel_heading` for every
            row if given, else the record's `heading` column
            (`twin.site.heading.relative_heading`).
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    kind: Literal["fixed", "best", "record"] = "fixed"
    headings: list[float] = Field(
        [150.0], min_length=1, max_length=36,
        description="[deg] relative headings (Scenario.heading): one for fixed, a set for best",
    )  # fmt: skip
    vessel_heading: float | None = Field(
        None, ge=0.0, le=360.0,
        description="[deg true] record strategy: the compass heading the bow points to on every "
        "row (a vessel held on station at a fixed heading); None: the record's heading column",
    )  # fmt: skip

    @field_validator("headings")
    @classmethod
    def _distinct(cls, values: list[float]) -> list[float]:
        for v in values:
            if not -360.0 <= v <= 360.0:
                raise ValueError(f"headings: {v:g} outside -360 … 360 deg")
        values = [float(np.mod(v, 360.0)) for v in values]
        if len(set(values)) != len(values):
            raise ValueError(f"headings: repeated values {values}")
        return values

    @model_validator(mode="after")
    def _one_if_fixed(self) -> HeadingStrategy:
        if self.kind == "fixed" and len(self.headings) != 1:
            raise TwinError(f"headings: a fixed strategy has one heading, got {self.headings}")
        if self.vessel_heading is not None and self.kind != "record":
            raise TwinError("vessel_heading: only with the record strategy (the bow's compass "
                            f"heading met by the record's waves), got {self.kind}")  # fmt: skip
        return self

    def needs(self) -> tuple[str, ...]:
        """The record columns every row must have besides time, Hs and Tp: the wave direction
        and vessel heading for `record` (the heading not when `vessel_heading` is given)."""
        if self.kind != "record":
            return ()
        return ("direction",) if self.vessel_heading is not None else ("direction", "heading")

    @classmethod
    def parse(cls, text: str) -> HeadingStrategy:
        """`"fixed:150"`, `"best:150,180,210"` or `"record"` (the CLI's form)."""
        kind, _, rest = text.strip().partition(":")
        if kind not in ("fixed", "best", "record"):
            raise TwinError(f"heading strategy {text!r}: allowed fixed:DEG, best:DEG,DEG,… or "
                            "record")  # fmt: skip
        if kind == "record":
            if rest.strip():
                raise TwinError(f"heading strategy {text!r}: record takes no headings; a fixed "
                                "compass heading is --vessel-heading DEG")  # fmt: skip
            return cls(kind="record")
        try:
            headings = [float(v) for v in rest.split(",") if v.strip()]
        except ValueError:
            raise TwinError(f"heading strategy {text!r}: headings must be numbers [deg]") from None
        if not headings:
            raise TwinError(f"heading strategy {text!r}: give the heading(s), e.g. {kind}:150")
        return cls(kind=kind, headings=headings)

    def label(self) -> str:
        if self.kind == "record":
            if self.vessel_heading is not None:
                return f"vessel heading {self.vessel_heading:g}° true"
            return "vessel heading from the record"
        heads = ", ".join(f"{h:g}°" for h in self.headings)
        return f"fixed relative heading {heads}" if self.kind == "fixed" else f"best of {heads}"


class WorkabilitySpec(BaseModel):
    """A workability request: mechanism, planners and knobs, seeds, runs, headings, cell grid.

    Units as `Scenario`. `scenario` sets any other `Scenario` field for every run (e.g.
    `{"beta": 0.7, "spreading": 10, "vessel": "sov"}`).
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    mechanism: Literal["hybrid", "upu3up", "upr4"] = "hybrid"
    planners: list[str] | None = Field(
        None, description="planners of the mechanism; default its Scenario default (mtmp, pid)"
    )
    scenario: dict[str, Any] = Field(
        default_factory=dict, description="other Scenario fields (knobs), the same for every run"
    )
    seeds: int = Field(3, ge=1, le=50, description="[-] runs per cell or row, sea seeds 0 … N−1")
    duration: float = Field(200.0, gt=0.0, le=3600.0, description="[s] simulated time per run")
    dt: float = Field(0.05, ge=0.005, le=0.2, description="[s] control period")
    heading: HeadingStrategy = Field(default_factory=HeadingStrategy)
    hs_grid: list[float] = Field(
        [0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0, 8.0],
        min_length=1, max_length=60, description="[m] Hs of the cells, increasing (to 8 m: "
        "qp keeps operating past 5 m, docs/workability.md 'Rated sea')",
    )  # fmt: skip
    tp_grid: list[float] = Field(
        [3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0, 16.0, 18.0, 20.0],
        min_length=1, max_length=60, description="[s] Tp of the cells, increasing",
    )  # fmt: skip
    heading_grid: list[float] = Field(
        [float(v) for v in range(0, 360, 15)], min_length=1, max_length=72,
        description="[deg] relative headings of the cells for the record strategy",
    )  # fmt: skip
    hs_limits: list[float] = Field(
        [1.5, 2.0, 2.5], max_length=12,
        description="[m] Hs limits of the threshold baseline (reported in ascending order)",
    )  # fmt: skip
    duplicates: Duplicates = Field(
        "error", description="rows sharing a time: error (naming their lines), mean or first"
    )
    tip_error_threshold: float = Field(
        0.05, gt=0.0, le=10.0, description="[m] largest tip position error of an operable run"
    )
    method: Literal["cells", "direct"] = "cells"
    cell_lookup: Literal["linear", "conservative"] = Field(
        "linear",
        description="cells: linear interpolates a row's probability bilinearly in Hs and Tp "
        "between its cell's corners (measured within 1 point of direct runs, "
        "docs/workability.md); conservative takes the worse of the two corners at the cell's "
        "upper Hs (a lower bound)",
    )
    refine_levels: int = Field(
        3, ge=0, le=4, description="cells: times a cell whose corners differ by more than "
        "refine_spread is split at its Hs and Tp midpoints (0: the grid alone)",
    )  # fmt: skip
    refine_spread: float = Field(
        0.25, ge=0.0, le=1.0, description="[0-1] cells: the corner probabilities' spread "
        "(largest − smallest) over which a cell is split (0.25: any disagreement of 3 seeds)",
    )  # fmt: skip
    max_runs: int = Field(
        MAX_RUNS, ge=1, le=MAX_RUNS, description="most runs in all: more for the grid (or the "
        "rows, direct) is an error; a refinement that would pass it is not made (noted)",
    )  # fmt: skip
    window_hours: list[float] = Field(
        [6.0, 12.0], max_length=8, description="[h] window lengths W of the weather windows"
    )
    shift: tuple[int, int] | None = Field(
        None, description="daily work shift (start, end) hours, e.g. (7, 19); None: all day"
    )
    chunk_size: int = Field(64, ge=1, le=4096, description="runs per executor task")

    @field_validator("hs_grid", "tp_grid")
    @classmethod
    def _increasing(cls, values: list[float], info: Any) -> list[float]:
        if any(b <= a for a, b in itertools.pairwise(values)):
            raise ValueError(f"{info.field_name}: must increase strictly, got {values}")
        low, high = (0.0, 20.0) if info.field_name == "hs_grid" else TP_RANGE
        if values[0] < low or values[-1] > high:
            raise ValueError(f"{info.field_name}: values within {low:g} … {high:g}")
        return values

    @field_validator("heading_grid")
    @classmethod
    def _circle(cls, values: list[float]) -> list[float]:
        values = [float(np.mod(v, 360.0)) for v in values]
        if len(set(values)) != len(values):
            raise ValueError(f"heading_grid: repeated directions {values}")
        return values

    @field_validator("window_hours")
    @classmethod
    def _positive(cls, values: list[float]) -> list[float]:
        if any(v <= 0 for v in values):
            raise ValueError(f"window_hours: each > 0 h, got {values}")
        return values

    @field_validator("hs_limits")
    @classmethod
    def _ascending(cls, values: list[float]) -> list[float]:
        if any(v <= 0 for v in values) or len(set(values)) != len(values):
            raise ValueError(f"hs_limits: distinct values > 0 m, got {values}")
        return sorted(values)

    @model_validator(mode="after")
    def _consistent(self) -> WorkabilitySpec:
        if self.planners is None:
            self.planners = [DEFAULT_PLANNER[self.mechanism]]
        if not self.planners or len(set(self.planners)) != len(self.planners):
            raise TwinError(f"planners: a non-empty list of distinct names, got {self.planners}")
        for planner in self.planners:
            get_planner(planner, self.mechanism)  # names the allowed ones
        clash = sorted(set(self.scenario) & OWN_FIELDS)
        if clash:
            raise TwinError(f"scenario: {clash} are set by the workability spec itself")
        Scenario(**self.scenario, mechanism=self.mechanism, duration=self.duration, dt=self.dt)
        if round(self.duration / self.dt) < 1:
            raise TwinError(f"duration: {self.duration:g} s at dt = {self.dt:g} s is zero steps")
        if self.shift is not None and not 0 <= self.shift[0] < self.shift[1] <= 24:
            raise TwinError(f"shift: got {self.shift}; allowed (start, end), 0 ≤ start < end ≤ 24")
        return self

    @property
    def criterion(self) -> str:
        return (
            "operable run: no joint or leg limit violation and tip position error ≤ "
            f"{self.tip_error_threshold:g} m (largest over the run after the first 10 samples)"
        )


# -- what a worker runs ---------------------------------------------------------------------------


#: a small platform's limit kinds (`twin.sim.metrics.PlatformReduction.kinds`) as a row names them
PLATFORM_LIMITS = {"stroke_min": "leg stroke (lower)", "stroke_max": "leg stroke (upper)",
                   "u_joint": "U-joint angle", "collision": "collision",
                   "clamped": "demand clamped (rate or range)", "state": "state range"}  # fmt: skip


def run_summary(metrics: dict[str, Any], mechanism: str) -> dict[str, Any]:
    """What a cell keeps of a run's metrics: violations, the tip's largest position error [m]
    and, if a limit was violated, the limit that bound first and when (module docstring)."""
    bound = metrics.get("first_bound")
    out: dict[str, Any] = {
        "violations": int(metrics["violations"]),
        "tip_error": float(metrics["tip_position_error_max"]),
        "limit": None,
        "limit_t": None,
    }
    if out["violations"] == 0 or bound is None:
        return out
    name = bound["limit"]
    out["limit"] = name if mechanism == "hybrid" else PLATFORM_LIMITS.get(name, name)
    out["limit_t"] = float(bound["t"])
    return out


def run_cells_chunk(
    scenarios: list[dict[str, Any]], *, threads: int | None = 1
) -> list[dict[str, Any]]:
    """One executor task: run scenarios with `simulate_many`, keep each one's `run_summary`."""
    from twin.compiled import limit_threads
    from twin.sim.engine import simulate_many

    with limit_threads(threads):
        results = simulate_many(scenarios, keep="metrics")  # a cell reads metrics alone
    return [run_summary(r.metrics, r.scenario.mechanism) for r in results]


# -- the cell cache -------------------------------------------------------------------------------


def cell_key(fields: dict[str, Any]) -> str:
    """The cache key of a run: every `Scenario` field (defaults filled in) and `ENGINE_VERSION`,
    hashed."""
    full = Scenario(**fields).model_dump(mode="json")
    text = json.dumps({"engine": ENGINE_VERSION, "scenario": full}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


class CellCache:
    """Run summaries by `cell_key`, in SQLite (`<data_dir>/cells.sqlite`, a table of its own)
    or, without a data dir, in memory for one evaluation."""

    def __init__(self, data_dir: str | Path | None) -> None:
        self.path = None if data_dir is None else Path(data_dir) / CELL_DATABASE
        self._memory: dict[str, dict[str, Any]] = {}
        if self.path is not None:
            with session(self.path) as db:
                db.execute("CREATE TABLE IF NOT EXISTS cells (key TEXT PRIMARY KEY, engine TEXT, "
                           "summary TEXT NOT NULL, created REAL)")  # fmt: skip

    def get(self, keys: Sequence[str]) -> dict[str, dict[str, Any]]:
        """The summaries of those keys that are cached."""
        if self.path is None:
            return {k: self._memory[k] for k in keys if k in self._memory}
        found: dict[str, dict[str, Any]] = {}
        with session(self.path, write=False) as db:
            unique = list(dict.fromkeys(keys))
            for start in range(0, len(unique), 500):  # SQLite's bound on parameters
                part = unique[start : start + 500]
                marks = ",".join("?" * len(part))
                for key, summary in db.execute(
                    f"SELECT key, summary FROM cells WHERE key IN ({marks})", part
                ):
                    found[key] = json.loads(summary)
        return found

    def put(self, items: dict[str, dict[str, Any]]) -> None:
        if self.path is None:
            self._memory.update(items)
            return
        now = time.time()
        with session(self.path) as db:
            db.executemany(
                "INSERT OR REPLACE INTO cells VALUES (?, ?, ?, ?)",
                [(k, ENGINE_VERSION, json.dumps(v), now) for k, v in items.items()],
            )

    def __len__(self) -> int:
        if self.path is None:
            return len(self._memory)
        with session(self.path, write=False) as db:
            return int(db.execute("SELECT COUNT(*) FROM cells").fetchone()[0])


# -- evaluation -----------------------------------------------------------------------------------


@dataclass
class WorkabilityResult:
    """A finished evaluation.

    Attributes:
        spec: what was asked.
        record: the record evaluated.
        rows: one row per record row and planner: `time` (time series), `hs`, `tp`,
            `direction`, `planner`, `heading` (the relative heading used, deg), `cell_hs`,
            `cell_tp`, `cell_heading` (cells method; the run's own values in direct mode),
            `probability` [0-1], `operable` (probability ≥ OPERABLE_LEVEL), `limiting` (the
            most frequent limiting constraint of its non-operable runs; "" if none) and
            `weight`.
        summary: workability per planner (overall, per month), the Hs-threshold baseline,
            limiting constraints, weather windows (`to_dict` has them all).
        runs: runs evaluated (cached or new); new_runs: runs simulated now.
        elapsed: [s] wall time; scheduler: where new runs ran ("" if none).
    """

    spec: WorkabilitySpec
    record: SiteRecord
    rows: pd.DataFrame
    summary: dict[str, Any]
    runs: int
    new_runs: int
    elapsed: float
    scheduler: str
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: spec, record, criterion, summary, notes (rows: `to_csv`)."""
        return _plain({
            "spec": self.spec.model_dump(mode="json"),
            "record": self.record.summary(),
            "criterion": self.spec.criterion,
            "engine": ENGINE_VERSION,
            "runs": self.runs, "new_runs": self.new_runs, "elapsed": self.elapsed,
            "scheduler": self.scheduler, "notes": self.notes,
            **self.summary,
        })  # fmt: skip

    def to_csv(self, path: str | Path) -> Path:
        """The per-row table (`rows_csv`) to `path`."""
        path = Path(path)
        rows_csv(self.rows, path)
        return path

    def to_json(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(json.dumps(self.to_dict(), indent=2) + "\n")
        return path

    def pngs(self, title: str | None = None) -> dict[str, bytes]:
        """The plots as PNG bytes by file name: `monthly.png` (time series with months),
        `windows.png`, `strip.png` (time series, forecasts) and `forecast.png` (forecasts).
        `title`: what the plots call the record (e.g. an uploaded file's name); default its
        source."""
        from twin.runs import workability_plots as plots

        out: dict[str, bytes] = {}
        figures = plots.figures(self, title=title)
        for name, figure in figures.items():
            buffer = io.BytesIO()
            figure.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
            out[name] = buffer.getvalue()
        return out

    def write(self, out: str | Path, title: str | None = None) -> list[Path]:
        """`workability.csv` (per row), `months.csv` (time series: per month, `months_table`),
        `workability.json` and every PNG (`pngs(title)`) into folder `out`."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        written = [self.to_csv(out / "workability.csv"), self.to_json(out / "workability.json")]
        if "months" in self.summary:
            months_table(self.summary).to_csv(out / "months.csv", index=False,
                                              float_format="%.6g")  # fmt: skip
            written.append(out / "months.csv")
        for name, data in self.pngs(title).items():
            (out / name).write_bytes(data)
            written.append(out / name)
        return written


def run_workability(
    spec: WorkabilitySpec | dict,
    record: SiteRecord,
    *,
    executor: Executor | None = None,
    on_progress: Callable[[int, int], None] | None = None,
    scheduler: str | None = None,
    n_workers: int | None = None,
    data_dir: str | Path | None = None,
    progress: bool = False,
    stop: Callable[[], bool] | None = None,
) -> WorkabilityResult:
    """Workability of every planner on a site record (module docstring).

    Args:
        spec: a `WorkabilitySpec` or a dict of its fields (validated).
        record: the site's record (`twin.site.read_record`).
        executor: where new runs go (e.g. a server's); None starts one from `scheduler` and
            `n_workers` only if some run is not cached, and closes it at the end.
        on_progress: called with (runs done, runs in all) after the cache lookup and after each
            chunk (cached runs count as done).
        scheduler: without `executor`: None (a LocalCluster), "tcp://HOST:PORT" or "in-process".
        n_workers: workers of that LocalCluster.
        data_dir: folder of the cell cache (`cells.sqlite`); None: no cache beyond this call.
        progress: a tqdm bar over runs.
        stop: polled after each chunk; True cancels the rest and raises `WorkabilityStopped`.

    Raises:
        ValueError: a bad spec or a record the strategy cannot use (TwinError, naming it).
        WorkabilityStopped: `stop` returned True.
    """
    spec = spec if isinstance(spec, WorkabilitySpec) else WorkabilitySpec(**spec)
    start = time.perf_counter()
    check_record(spec, record)
    notes = _notes(spec, record)
    betas = _row_headings(spec, record)  # (n, options)
    base = _cells(spec, record, betas, notes)
    lookups = {planner: base for planner in spec.planners or []}
    levels = spec.refine_levels if spec.method == "cells" else 0
    previous = lookups
    found: dict[str, dict[str, Any]] = {}
    keys: dict[tuple, str] = {}
    cache = CellCache(data_dir)
    new, where = 0, ""
    with contextlib.ExitStack() as stack:
        for level in range(levels + 1):
            # a refining pass needs every corner; the last only those its lookup weighs
            corners = (0, 1, 2, 3) if level < levels or spec.cell_lookup == "linear" else (2, 3)
            places = {planner: _places(lookup, corners) for planner, lookup in lookups.items()}
            step = _new_runs(spec, places, keys, cache, found, refining=level > 0)
            if step is None:  # over max_runs: the cells of the level before stand
                lookups = previous
                notes.append(f"cells refined {level - 1} of {levels} times: a further "
                             f"refinement would pass max_runs ({spec.max_runs} runs)")  # fmt: skip
                break
            todo, fields_of = step
            if on_progress is not None:
                on_progress(len(keys) - len(todo), len(keys))
            if todo:
                if executor is None:  # started once, for the first runs not cached
                    executor = stack.enter_context(Executor.start(scheduler, n_workers=n_workers))
                where = _run(spec, todo, fields_of, keys, cache, found, executor, progress,
                             on_progress, stop, len(keys))  # fmt: skip
                new += len(todo)
            if level == levels:
                break
            refined, summaries = {}, _summaries_of(keys, found)
            for planner, lookup in lookups.items():
                prob, _ = _corner_values(lookup, _judge(spec, planner, summaries))
                if (split := _refine(lookup, prob, spec.refine_spread)) is not None:
                    refined[planner] = split
            if not refined:
                break
            previous, lookups = lookups, lookups | refined
    rows = _evaluate(spec, record, betas, lookups, _summaries_of(keys, found))
    summary = _summarise(spec, record, rows)
    return WorkabilityResult(spec, record, rows, summary, len(keys), new,
                             time.perf_counter() - start, where, notes)  # fmt: skip


def _summaries_of(keys: dict[tuple, str], found: dict[str, dict[str, Any]]) -> dict[tuple, dict]:
    """Run summaries by (planner, Hs, Tp, heading, seed), from those found by cache key."""
    return {combo: found[key] for combo, key in keys.items() if key in found}


def _new_runs(
    spec: WorkabilitySpec, places: dict[str, np.ndarray], keys: dict[tuple, str],
    cache: CellCache, found: dict[str, dict[str, Any]], refining: bool = False,
) -> tuple[list[tuple], dict[tuple, dict[str, Any]]] | None:  # fmt: skip
    """Add the runs of each planner's `places` (Hs, Tp, heading) × seeds to `keys`, read the
    cached ones into `found`, and return those still to run with their scenario fields; None
    (nothing added) for a `refining` pass that would pass `spec.max_runs` in all.

    Raises:
        TwinError: more than `spec.max_runs` runs in all, not refining.
    """
    fields_of: dict[tuple, dict[str, Any]] = {}
    for planner, where in places.items():
        for h, p, b in where.tolist():
            for seed in range(spec.seeds):
                if (planner, h, p, b, seed) not in keys:
                    fields_of[(planner, h, p, b, seed)] = {
                        **spec.scenario, "mechanism": spec.mechanism, "planner": planner,
                        "hs": h, "tp": p, "heading": b, "seed": seed,
                        "duration": spec.duration, "dt": spec.dt,
                    }  # fmt: skip
    if len(keys) + len(fields_of) > spec.max_runs:
        if refining:
            return None
        raise TwinError(f"{len(keys) + len(fields_of)} runs needed; allowed at most "
                        f"{spec.max_runs} (max_runs: coarsen the grid, fewer seeds or the cells "
                        "method)")  # fmt: skip
    added = {combo: cell_key(fields) for combo, fields in fields_of.items()}
    keys |= added
    found |= cache.get(list(added.values()))
    return [c for c, key in added.items() if key not in found], fields_of


def read_site_record(
    path: str | Path, spec: WorkabilitySpec | dict, kind: str | None = None
) -> SiteRecord:
    """Read a record for `spec` and check it can be evaluated: every row needs only the columns
    the heading strategy uses (`HeadingStrategy.needs`), rows sharing a time follow
    `spec.duplicates`, and the rows skipped are counted by reason (`SiteRecord.skipped`;
    `SiteRecord.warnings` when over 5 %).

    Raises:
        TwinError: a malformed file (naming the line), or a record `check_record` refuses.
    """
    spec = spec if isinstance(spec, WorkabilitySpec) else WorkabilitySpec(**spec)
    record = read_record(path, kind, require=spec.heading.needs(), duplicates=spec.duplicates)
    check_record(spec, record)
    return record


def check_record(spec: WorkabilitySpec, record: SiteRecord) -> None:
    """TwinError unless `spec` can evaluate `record`: at least one row (else the reasons rows
    were skipped, with their counts), at most MAX_ROWS, and the columns its heading strategy
    needs."""
    if record.n == 0:
        reasons = ", ".join(f"{reason}: {count}" for reason, count in record.skipped.items())
        raise TwinError(
            f"record: no rows left to evaluate ({reasons or 'the file has no rows'}); every row "
            "needs Hs and Tp, and the record strategy a direction"
        )
    if record.n > MAX_ROWS:
        raise TwinError(f"record: {record.n} rows; allowed at most {MAX_ROWS}")
    needs = spec.heading.needs()
    lacking = [c for c in needs if getattr(record, c) is None]
    if lacking:
        raise TwinError(
            f"heading strategy {spec.heading.label()!r} needs the record's {' and '.join(needs)} "
            f"({record.source or 'the record'} lacks {', '.join(lacking)}); allowed: fixed:DEG, "
            "best:DEG,DEG,… "
            "or, with wave directions, a vessel heading (--vessel-heading DEG)"
        )


def _row_headings(spec: WorkabilitySpec, record: SiteRecord) -> np.ndarray:
    """(n, options) relative headings [deg] each row is evaluated at."""
    strategy = spec.heading
    if strategy.kind == "record":
        check_record(spec, record)  # names what a direct caller's record lacks
        heading = record.heading if strategy.vessel_heading is None else strategy.vessel_heading
        beta = relative_heading(record.direction, heading)  # type: ignore[arg-type]
        return np.asarray(beta, dtype=float).reshape(-1, 1)
    return np.tile(np.asarray(strategy.headings, dtype=float), (record.n, 1))


def _notes(spec: WorkabilitySpec, record: SiteRecord) -> list[str]:
    """What a reader of the result should know about the record: rows skipped over 5 %
    (`SiteRecord.warnings`), the reader's notes, months pooled over years, and rows whose Tp
    lies outside the cell grid (they take its nearest edge cell; rows above the Hs grid are
    noted by `_cells`)."""
    notes = [*record.warnings(), *record.notes]
    if record.time is not None:
        years = sorted(set(pd.DatetimeIndex(record.time).year.tolist()))
        if len(years) > 1:
            notes.append(f"months pool {len(years)} years ({years[0]}-{years[-1]}): each month's "
                         "figure is over that month of every year")  # fmt: skip
    if spec.method == "cells":
        low, high = spec.tp_grid[0], spec.tp_grid[-1]
        below, over = int(np.sum(record.tp < low)), int(np.sum(record.tp > high))
        for count, side, edge in ((below, "below", low), (over, "above", high)):
            if count:
                notes.append(f"{count} rows have Tp {side} the cell grid's {edge:g} s and take "
                             f"its {edge:g} s cells (the grid's edge in Tp)")  # fmt: skip
    return notes


@dataclass
class _Lookup:
    """Each row's cell per heading option (n rows, k options): the Hs bracket [h0, h1] [m] and
    Tp bracket [t0, t1] [s] around the row (equal ends: the row on a grid value or past the
    grid's end; direct: the row's own sea), the cell's relative heading [deg], and the rows above
    the Hs grid (not operable, nothing run)."""

    hs: np.ndarray  # (n,) the rows' Hs and Tp (clipped to TP_RANGE)
    tp: np.ndarray
    h0: np.ndarray  # (n, k) each
    h1: np.ndarray
    t0: np.ndarray
    t1: np.ndarray
    beta: np.ndarray
    above: np.ndarray  # (n,)

    def weights(self) -> tuple[np.ndarray, np.ndarray]:
        """Bilinear weights of the upper Hs and the upper Tp end, (n, k) each (1: that end
        alone)."""
        out = []
        for x, lo, hi in ((self.hs, self.h0, self.h1), (self.tp, self.t0, self.t1)):
            span = np.where(hi > lo, hi - lo, 1.0)
            out.append(np.where(hi > lo, np.clip((x[:, None] - lo) / span, 0.0, 1.0), 1.0))
        return out[0], out[1]

    def corners(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """(Hs, Tp) of the four corners: (h0, t0), (h0, t1), (h1, t0), (h1, t1)."""
        return [(h, t) for h in (self.h0, self.h1) for t in (self.t0, self.t1)]

    def split(self, mask: np.ndarray) -> _Lookup:
        """The cells of `mask` (n, k) halved in Hs and Tp, each row keeping the half it lies in
        (a row on a midpoint: that value alone, so it runs at its own sea)."""
        ends = {}
        for x, lo, hi, name in ((self.hs, self.h0, self.h1, "h"), (self.tp, self.t0, self.t1, "t")):
            x = np.broadcast_to(x[:, None], lo.shape)
            mid = np.round(0.5 * (lo + hi), 4)
            cut = mask & (hi > lo)
            on = np.abs(x - mid) < 1e-9
            ends[name + "0"] = np.where(cut, np.where(on | (x > mid), mid, lo), lo)
            ends[name + "1"] = np.where(cut, np.where(on | (x < mid), mid, hi), hi)
        return replace(self, **ends)


def _bracket(grid: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The grid values at or below and at or above each x (to float noise: one value on a grid
    point; the edge value past either end), and the index of the upper one in the grid."""
    index = np.searchsorted(grid, x - 1e-9, side="left")
    hi = grid[np.minimum(index, grid.size - 1)]
    on = np.abs(hi - x) < 1e-9
    lo = np.where(on | (index == 0) | (index >= grid.size), hi, grid[np.maximum(index - 1, 0)])
    return lo, hi, index


def _cells(
    spec: WorkabilitySpec, record: SiteRecord, betas: np.ndarray, notes: list[str]
) -> _Lookup:
    """Each row's cell (`_Lookup`; direct: its own Hs, Tp clipped to TP_RANGE, and heading)."""
    hs = record.hs.copy()
    tp = np.clip(record.tp, *TP_RANGE)
    clipped = int(np.sum(tp != record.tp))
    if clipped:
        notes.append(f"{clipped} rows had Tp outside {TP_RANGE[0]:g}-{TP_RANGE[1]:g} s (the "
                     "periods a scenario allows) and were clipped to it")  # fmt: skip
    if record.spreading is not None:
        notes.append("the record's spreading column is not used: every run takes the spec's "
                     "scenario spreading (long-crested unless set)")  # fmt: skip
    k = betas.shape[1]

    def wide(values: np.ndarray) -> np.ndarray:
        return np.repeat(values[:, None], k, axis=1)

    if spec.method == "direct":
        own_hs, own_tp = wide(np.round(hs, 4)), wide(np.round(tp, 4))
        return _Lookup(hs, tp, own_hs, own_hs, own_tp, own_tp,
                       np.round(np.mod(betas, 360.0), 3), hs > 20.0)  # fmt: skip
    grid_hs = np.asarray(spec.hs_grid)
    h0, h1, index = _bracket(grid_hs, hs)
    above = index >= grid_hs.size
    if above.any():
        notes.append(f"{int(above.sum())} rows have Hs above the cell grid's {grid_hs[-1]:g} m "
                     "and count as not operable")  # fmt: skip
    t0, t1, _ = _bracket(np.asarray(spec.tp_grid), tp)
    if spec.heading.kind == "record":
        grid_b = np.asarray(spec.heading_grid)
        nearest = np.argmin(angular_distance(betas[:, :, None], grid_b[None, None, :]), axis=2)
        cell_beta = grid_b[nearest]
    else:
        cell_beta = betas
    return _Lookup(hs, tp, wide(h0), wide(h1), wide(t0), wide(t1), cell_beta, above)


def _places(lookup: _Lookup, corners: Sequence[int]) -> np.ndarray:
    """The distinct (Hs, Tp, heading) of the given corners (indices into `_Lookup.corners`) of
    every row not above the grid, (m, 3)."""
    keep = ~lookup.above
    pairs = lookup.corners()
    stacked = [np.stack([pairs[c][0][keep], pairs[c][1][keep], lookup.beta[keep]], axis=-1)
               for c in corners]  # fmt: skip
    return np.unique(np.concatenate([p.reshape(-1, 3) for p in stacked]), axis=0)


def _corner_values(
    lookup: _Lookup, judge: Callable[[float, float, float], tuple[float, str]],
    corners: Sequence[int] = (0, 1, 2, 3),
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Probability and limiting constraint of each row's four corners, (4, n, k) each (rows
    above the grid, and corners not in `corners`: 0 and "")."""
    n, k = lookup.h0.shape
    keep = np.repeat(~lookup.above[:, None], k, axis=1)
    prob, limit = np.zeros((4, n, k)), np.full((4, n, k), "", dtype=object)
    pairs = lookup.corners()
    for c in corners:
        h, t = pairs[c]
        places = np.stack([h[keep], t[keep], lookup.beta[keep]], axis=-1)
        if places.size == 0:
            continue
        unique, inverse = np.unique(places, axis=0, return_inverse=True)
        judged = [judge(*place) for place in unique.tolist()]
        prob[c][keep] = np.array([j[0] for j in judged])[inverse.ravel()]
        limit[c][keep] = np.array([j[1] for j in judged], dtype=object)[inverse.ravel()]
    return prob, limit


def _refine(lookup: _Lookup, prob: np.ndarray, spread: float) -> _Lookup | None:
    """`lookup` with every cell whose corner probabilities `prob` (4, n, k) spread over
    `spread` split once (`_Lookup.split`); None when none is."""
    wider = (lookup.h1 > lookup.h0) | (lookup.t1 > lookup.t0)
    mask = (prob.max(axis=0) - prob.min(axis=0) > spread) & wider & ~lookup.above[:, None]
    return lookup.split(mask) if mask.any() else None


def _run(
    spec: WorkabilitySpec, todo: list[tuple], fields_of: dict[tuple, dict[str, Any]],
    keys: dict[tuple, str], cache: CellCache, found: dict[str, dict[str, Any]],
    executor: Executor, progress: bool, on_progress: Callable[[int, int], None] | None,
    stop: Callable[[], bool] | None, total: int,
) -> str:  # fmt: skip
    """Run the runs `todo` on the executor in chunks (one planner each), caching each chunk."""
    todo = sorted(todo, key=lambda c: (c[0], c[1], c[2], c[3], c[4]))
    size = spec.chunk_size
    chunks = [todo[s : s + size] for s in range(0, len(todo), size)]
    futures = {
        executor.submit(run_cells_chunk, [fields_of[c] for c in chunk],
                        threads=executor.numba_threads, priority=SWEEP_PRIORITY): chunk
        for chunk in chunks
    }  # fmt: skip
    done = total - len(todo)
    try:
        with tqdm(total=total, initial=done, disable=not progress, unit="run") as bar:
            for future in executor.as_completed(futures):
                if stop is not None and stop():
                    raise WorkabilityStopped("workability stopped before its end; its chunks "
                                             "were cancelled")  # fmt: skip
                chunk = futures[future]
                new = {keys[c]: s for c, s in zip(chunk, future.result(), strict=True)}
                cache.put(new)  # a stopped evaluation keeps what it ran
                found.update(new)
                done += len(chunk)
                bar.update(len(chunk))
                if on_progress is not None:
                    on_progress(done, total)
    finally:
        executor.cancel(futures)
    return executor.where


def _judge(
    spec: WorkabilitySpec, planner: str, summaries: dict[tuple, dict[str, Any]]
) -> Callable[[float, float, float], tuple[float, str]]:
    """(probability, most frequent limiting constraint) of `planner`'s runs at a (Hs, Tp,
    heading), over the spec's seeds, remembered per place."""
    memo: dict[tuple, tuple[float, str]] = {}

    def judge(h: float, p: float, b: float) -> tuple[float, str]:
        if (h, p, b) not in memo:
            ok, limits = 0, Counter[str]()
            for seed in range(spec.seeds):
                s = summaries[(planner, h, p, b, seed)]
                if s["violations"] == 0 and s["tip_error"] <= spec.tip_error_threshold:
                    ok += 1
                else:
                    limits[s["limit"] or "tip error"] += 1
            common = limits.most_common(1)[0][0] if limits else ""
            memo[(h, p, b)] = (ok / spec.seeds, common)
        return memo[(h, p, b)]

    return judge


def _row_values(
    spec: WorkabilitySpec, lookup: _Lookup, prob: np.ndarray, limit: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each row and option's probability, limiting constraint and cell Tp from its corners'
    (4, n, k): linear, bilinear in Hs and Tp; conservative, the worse of the upper-Hs corners.
    The constraint (and Tp) is that of the worst corner weighing in; "" when it is operable."""
    wh, wt = lookup.weights()
    if spec.cell_lookup == "linear":
        weight = np.stack([(1 - wh) * (1 - wt), (1 - wh) * wt, wh * (1 - wt), wh * wt])
        value = np.sum(weight * prob, axis=0)
    else:
        weight = np.stack([np.zeros_like(wh)] * 2 + [np.ones_like(wh)] * 2)
        value = np.minimum(prob[2], prob[3])
    worst = np.argmin(np.where(weight > 0, prob, np.inf), axis=0)[None]
    named = np.take_along_axis(limit, worst, axis=0)[0]
    worst_p = np.take_along_axis(prob, worst, axis=0)[0]
    named = np.where(worst_p < 1.0, named, "")
    if spec.cell_lookup == "linear":  # the nearer Tp end (ties: the longer period)
        cell_tp = np.where(wt >= 0.5, lookup.t1, lookup.t0)
    else:
        cell_tp = np.where(worst[0] == 2, lookup.t0, lookup.t1)
    return value, named, cell_tp


def _evaluate(
    spec: WorkabilitySpec, record: SiteRecord, betas: np.ndarray, lookups: dict[str, _Lookup],
    summaries: dict[tuple, dict[str, Any]],
) -> pd.DataFrame:  # fmt: skip
    """One row per record row and planner: probability, heading chosen, limiting constraint."""
    frames = []
    rows = np.arange(record.n)
    for planner in spec.planners or []:
        lookup = lookups[planner]
        corners = (0, 1, 2, 3) if spec.cell_lookup == "linear" else (2, 3)
        prob, limit = _corner_values(lookup, _judge(spec, planner, summaries), corners)
        value, named, cell_tp = _row_values(spec, lookup, prob, limit)
        chosen = np.argmax(value, axis=1)  # best of the options, the first on ties
        probability = np.where(lookup.above, 0.0, value[rows, chosen])
        limiting = np.where(lookup.above, "Hs above the cell grid", named[rows, chosen])
        columns: dict[str, Any] = {}
        if record.time is not None:
            columns["time"] = record.time
        columns |= {"hs": record.hs, "tp": record.tp}
        if record.direction is not None:
            columns["direction"] = record.direction
        columns |= {
            "planner": planner, "heading": betas[rows, chosen],
            "cell_hs": lookup.h1[rows, chosen], "cell_tp": cell_tp[rows, chosen],
            "cell_heading": lookup.beta[rows, chosen],
            "probability": probability, "operable": probability >= OPERABLE_LEVEL,
            "limiting": limiting, "weight": record.weights,
        }  # fmt: skip
        frames.append(pd.DataFrame(columns))
    return pd.concat(frames, ignore_index=True)


def _summarise(spec: WorkabilitySpec, record: SiteRecord, rows: pd.DataFrame) -> dict[str, Any]:
    """Workability overall and per month per planner, the Hs-threshold baseline beside it,
    limiting constraints, heading choices and weather windows."""
    weight = record.weights
    month = None
    if record.time is not None:
        month = pd.DatetimeIndex(record.time).month.to_numpy()
    out: dict[str, Any] = {"mechanism": spec.mechanism, "heading_strategy": spec.heading.label(),
                           "planners": {}, "threshold": {}}  # fmt: skip
    if record.time is not None:
        out["months"] = _months(record)
        out["partial_month"] = PARTIAL_MONTH  # the coverage below which a month is partial
        out["years"] = sorted({int(y) for y in pd.DatetimeIndex(record.time).year})
    for limit in spec.hs_limits:
        operable = record.hs < limit  # the estimate users make today
        entry: dict[str, Any] = {"workability": float(np.sum(weight * operable))}
        if month is not None:
            entry["monthly"] = _monthly(operable.astype(float), weight, month)
            entry["windows"] = _windows(spec, record, operable)
        out["threshold"][f"{limit:g}"] = entry
    for planner, group in rows.groupby("planner", sort=False):
        p = group["probability"].to_numpy()
        limiting = group.loc[~group["operable"], "limiting"]
        w = group.loc[~group["operable"], "weight"]
        shares = w.groupby(limiting.to_numpy()).sum() / max(float(w.sum()), 1e-300)
        entry = {
            "workability": float(np.sum(weight * p)),
            "operable_share": float(np.sum(weight * group["operable"].to_numpy())),
            "limiting": {str(k): float(v) for k, v in shares.sort_values(ascending=False).items()},
        }
        if spec.heading.kind == "best":
            chosen = group.loc[group["operable"], "heading"].round(3)
            entry["headings_chosen"] = {f"{k:g}": int(v) for k, v in
                                        chosen.value_counts().sort_index().items()}  # fmt: skip
        if month is not None:
            entry["monthly"] = _monthly(p, weight, month)
            entry["windows"] = _windows(spec, record, group["operable"].to_numpy())
        out["planners"][str(planner)] = entry
    out["workability"] = {k: v["workability"] for k, v in out["planners"].items()}
    return out


def _monthly(values: np.ndarray, weight: np.ndarray, month: np.ndarray) -> dict[str, float]:
    """Weighted mean of `values` per calendar month present in the record (all years)."""
    out = {}
    for m in range(1, 13):
        mask = month == m
        if mask.any():
            out[MONTHS[m - 1]] = float(np.sum(values[mask] * weight[mask]) / np.sum(weight[mask]))
    return out


def _months(record: SiteRecord) -> dict[str, dict[str, Any]]:
    """Per calendar month present: the hours the record covers (rows × its time step, at most
    the month's), the years it pools, the hours those years' months have, the share covered,
    and whether that share is under PARTIAL_MONTH (a figure resting on under half its time)."""
    times = np.asarray(record.time, dtype="datetime64[ns]")
    index = pd.DatetimeIndex(times)
    step = record_step(times)
    month_of, year_of = index.month.to_numpy(), index.year.to_numpy()
    out: dict[str, dict[str, Any]] = {}
    for month in np.unique(month_of).tolist():
        mask = month_of == month
        years = sorted(set(year_of[mask].tolist()))
        calendar_hours = 24.0 * sum(calendar.monthrange(y, month)[1] for y in years)
        # a sparse record's step can exceed a month (two rows years apart): never more hours
        # than the month has
        hours = min(float(mask.sum()) * step, calendar_hours)
        coverage = hours / calendar_hours
        out[MONTHS[month - 1]] = {"hours": hours, "years": years,
                                  "calendar_hours": calendar_hours, "coverage": coverage,
                                  "partial": coverage < PARTIAL_MONTH}  # fmt: skip
    return out


def _windows(spec: WorkabilitySpec, record: SiteRecord, operable: np.ndarray) -> dict[str, Any]:
    """Weather windows of each length W on the record's own rows (`twin.site.windows`)."""
    order = np.argsort(record.time, kind="stable")  # type: ignore[arg-type]
    times = record.time[order]  # type: ignore[index]
    step = record_step(times)
    return {
        f"{w:g}": window_stats(operable[order], step, w, times=times, shift=spec.shift).to_dict()
        for w in spec.window_hours
    }


def rows_csv(rows: pd.DataFrame, target: str | Path | io.TextIOBase | None = None) -> str | None:
    """A result's per-row table as CSV (`WorkabilityResult.rows`): times in UTC with their zone
    (`2019-08-01T00:10Z`), floats to 6 significant digits. Written to `target` (a path or an
    open text file), or returned as text when `target` is None."""
    table = rows.copy()
    if "time" in table:
        table["time"] = utc_column(table["time"].to_numpy()).to_numpy()
    return table.to_csv(target, index=False, float_format="%.6g")  # type: ignore[arg-type]


def months_table(summary: dict[str, Any]) -> pd.DataFrame:
    """One row per calendar month of a time-series result: hours covered, years pooled,
    coverage, partial, then the workability [0-1] of each planner and of each Hs limit
    (`hs<LIMIT>`). Empty for a scatter diagram."""
    months = summary.get("months", {})
    table = pd.DataFrame({
        "month": list(months), "hours": [m["hours"] for m in months.values()],
        "years": [" ".join(map(str, m["years"])) for m in months.values()],
        "coverage": [m["coverage"] for m in months.values()],
        "partial": [m["partial"] for m in months.values()],
    })  # fmt: skip
    for planner, entry in summary["planners"].items():
        table[planner] = [entry.get("monthly", {}).get(m, np.nan) for m in months]
    for limit, entry in summary["threshold"].items():
        table[f"hs<{limit}"] = [entry.get("monthly", {}).get(m, np.nan) for m in months]
    return table


def _plain(value: Any) -> Any:
    """numpy scalars → Python scalars, recursively (json.dumps cannot take numpy types)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value.item() if isinstance(value, np.generic) else value

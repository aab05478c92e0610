"""The plots of a `WorkabilityResult` (matplotlib figures, no pyplot: safe off the main thread).

- `monthly.png`: workability [%] per calendar month, one bar per planner, the Hs-threshold
  baseline (operable iff Hs < limit) as a line across each month; a scatter diagram gets one
  group.
- `windows.png`: length histogram of the weather windows of at least W hours (the spec's first
  W), per planner and for the threshold baseline.
- `strip.png`: a time strip per planner, each row coloured by its probability of being operable
  (green operable, red not, grey no data).
- `forecast.png` (forecast records): an operability bar per time step per planner, the
  probability in each cell and the limiting constraint where it is not operable.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

from twin.site.windows import regular_series

if TYPE_CHECKING:
    from matplotlib.typing import LineStyleType

    from twin.sim.workability import WorkabilityResult

#: planner bar colours (colour-blind safe), threshold line styles
COLOURS = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442")
DASHES: tuple[LineStyleType, ...] = (":", "--", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 3)), "-")
#: strip colours by probability: not operable … operable, no data grey
STRIP = ListedColormap(["#d7301f", "#fc8d59", "#fee08b", "#91cf60", "#1a9850"])


def figures(result: WorkabilityResult) -> dict[str, Figure]:
    """Every plot of `result` by file name (which ones depends on the record's kind)."""
    out = {"monthly.png": monthly(result)}
    if result.record.time is not None:
        out["windows.png"] = windows(result)
        out["strip.png"] = strip(result)
    if result.record.kind == "forecast":
        out["forecast.png"] = forecast(result)
    return out


def _title(result: WorkabilityResult) -> str:
    spec = result.spec
    method = f"cells ({spec.cell_lookup} in Hs)" if spec.method == "cells" else "direct runs"
    return (f"{result.record.source}: {spec.mechanism}, {spec.heading.label()}, {spec.seeds} "
            f"seeds, {spec.duration:g} s runs, {method}\noperable: no limit violation, tip "
            f"error ≤ {spec.tip_error_threshold:g} m")  # fmt: skip


def monthly(result: WorkabilityResult) -> Figure:
    summary = result.summary
    planners = list(summary["planners"])
    has_months = "monthly" in next(iter(summary["planners"].values()))
    groups = list(next(iter(summary["planners"].values()))["monthly"]) if has_months else ["all"]

    def values(entry: dict) -> list[float]:
        if has_months:
            return [100 * entry["monthly"].get(g, np.nan) for g in groups]
        return [100 * entry["workability"]]

    figure = Figure(figsize=(max(5.0, 1.0 + 0.9 * len(groups) * max(1, len(planners)) / 2), 3.8),
                    layout="constrained")  # fmt: skip
    ax = figure.subplots()
    x = np.arange(len(groups))
    width = 0.8 / len(planners)
    for k, planner in enumerate(planners):
        entry = summary["planners"][planner]
        bars = ax.bar(x - 0.4 + width * (k + 0.5), values(entry), width,
                      color=COLOURS[k % len(COLOURS)],
                      label=f"{planner.upper()} ({100 * entry['workability']:.0f} %)")  # fmt: skip
        if len(groups) * len(planners) <= 24:
            ax.bar_label(bars, fmt="%.0f", fontsize=7, padding=1)
    for k, (limit, entry) in enumerate(summary["threshold"].items()):
        # a line across each month's bars: the estimate the bars are read against
        ax.hlines(values(entry), x - 0.45, x + 0.45, colors="black", linewidth=1.4,
                  linestyles=DASHES[k % len(DASHES)],
                  label=f"Hs < {limit} m ({100 * entry['workability']:.0f} %)")  # fmt: skip
    ax.set_xticks(x, groups)
    ax.set_ylim(0, 109)
    ax.set_ylabel("workability [%]")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    ax.set_title(_title(result), fontsize=8)
    return figure


def windows(result: WorkabilityResult) -> Figure:
    summary = result.summary
    w = f"{result.spec.window_hours[0]:g}" if result.spec.window_hours else None
    figure = Figure(figsize=(6.0, 3.6), layout="constrained")
    ax = figure.subplots()
    series: list[tuple[str, list[float], str, LineStyleType]] = []  # label, lengths, colour, style
    for k, (planner, entry) in enumerate(summary["planners"].items()):
        stats = entry["windows"].get(w) if w else None
        if stats:
            series.append((f"{planner.upper()}: {stats['count']} windows",
                           stats["lengths"], COLOURS[k % len(COLOURS)], "-"))  # fmt: skip
    for k, (limit, entry) in enumerate(summary["threshold"].items()):
        stats = entry.get("windows", {}).get(w) if w else None
        if stats:
            series.append((f"Hs < {limit} m: {stats['count']}", stats["lengths"], "black",
                           DASHES[k % len(DASHES)]))  # fmt: skip
    longest = max([max(s[1], default=0.0) for s in series] + [1.0])
    bins = np.linspace(float(w or 0), longest + 1e-9, 16).tolist() if w else 10
    for label, lengths, colour, style in series:
        ax.hist(lengths, bins=bins, histtype="step", color=colour, linestyle=style, linewidth=1.6,
                label=label)  # fmt: skip
    shift = result.spec.shift
    within = f", within {shift[0]:02d}-{shift[1]:02d} h" if shift else ""
    ax.set_xlabel(f"window length [h] (windows ≥ {w} h{within})")
    ax.set_ylabel("windows")
    ax.legend(fontsize=7, frameon=False)
    ax.set_title(_title(result), fontsize=8)
    return figure


def strip(result: WorkabilityResult) -> Figure:
    rows = result.rows
    planners = list(result.summary["planners"])
    figure = Figure(figsize=(9.0, 0.9 + 0.45 * len(planners)), layout="constrained")
    ax = figure.subplots()
    for k, planner in enumerate(planners):
        group = rows[rows["planner"] == planner]
        series = regular_series(group["time"].to_numpy(), np.ones(len(group), dtype=bool))
        p = np.full(series.times.size, np.nan)
        index = np.searchsorted(series.times, group["time"].to_numpy())
        index = np.clip(index, 0, p.size - 1)
        p[index] = group["probability"].to_numpy()
        image = np.ma.masked_invalid(p[None, :])
        t0, t1 = series.times[0], series.times[-1] + np.timedelta64(
            int(series.step_hours * 3.6e12), "ns")  # fmt: skip
        extent = (pd.Timestamp(t0), pd.Timestamp(t1), k - 0.4, k + 0.4)
        import matplotlib.dates as mdates

        cmap = STRIP.with_extremes(bad="#bbbbbb")
        ax.imshow(image, aspect="auto", cmap=cmap, vmin=0.0, vmax=1.0, interpolation="nearest",
                  extent=(mdates.date2num(extent[0]), mdates.date2num(extent[1]), extent[2],
                          extent[3]), origin="lower")  # fmt: skip
    ax.set_ylim(-0.6, len(planners) - 0.4)
    ax.set_yticks(range(len(planners)), [p.upper() for p in planners])
    ax.xaxis_date()
    figure.autofmt_xdate()
    ax.set_title(_title(result) + "\ncolour: probability of operable (green 1, red 0, grey no "
                 "data)", fontsize=8)  # fmt: skip
    return figure


def forecast(result: WorkabilityResult) -> Figure:
    rows = result.rows
    planners = list(result.summary["planners"])
    times = np.sort(rows["time"].unique())
    figure = Figure(figsize=(max(6.0, 0.55 * len(times) + 1.5), 1.2 + 0.6 * len(planners)),
                    layout="constrained")  # fmt: skip
    ax = figure.subplots()
    for k, planner in enumerate(planners):
        group = rows[rows["planner"] == planner].set_index("time").reindex(times)
        p = group["probability"].to_numpy(dtype=float)
        ax.imshow(np.ma.masked_invalid(p[None, :]), aspect="auto", cmap=STRIP, vmin=0, vmax=1,
                  extent=(-0.5, len(times) - 0.5, k - 0.4, k + 0.4), origin="lower")  # fmt: skip
        for j, (value, limit) in enumerate(zip(p, group["limiting"].fillna(""), strict=True)):
            if np.isfinite(value):
                text = f"{100 * value:.0f}"
                if value < 1.0 and limit:
                    text += "\n" + _short(limit)
                ax.text(j, k, text, ha="center", va="center", fontsize=6)
    ax.set_xlim(-0.5, len(times) - 0.5)
    ax.set_ylim(-0.6, len(planners) - 0.4)
    ax.set_yticks(range(len(planners)), [p.upper() for p in planners])
    labels = [pd.Timestamp(t).strftime("%d %Hh") for t in times]
    step = max(1, len(times) // 20)
    ax.set_xticks(range(0, len(times), step), labels[::step], rotation=60, fontsize=7)
    ax.set_title(_title(result) + "\noperable runs [%] per step; limiting constraint below",
                 fontsize=8)  # fmt: skip
    return figure


def _short(limit: str) -> str:
    """A constraint's name, short enough for a forecast cell."""
    return (limit.replace("joint ", "").replace("leg stroke", "legs").replace("(upper)", "↑")
            .replace("(lower)", "↓").replace("tip error", "tip"))  # fmt: skip

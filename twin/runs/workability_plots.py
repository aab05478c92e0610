"""The plots of a `WorkabilityResult` (matplotlib figures, no pyplot: safe off the main thread).

- `monthly.png`: workability [%] per calendar month, one bar per planner, the Hs-threshold
  baseline (operable iff Hs < limit) as a line across each month; under each month the hours
  it covers and the years it pools, a month under half covered hatched and marked partial; a
  scatter diagram gets one group.
- `windows.png`: length histogram of the weather windows of at least W hours (the spec's first
  W), per planner and for the threshold baseline, side by side in each bin; "no window" said
  when there is none.
- `strip.png`: a time strip per planner, each row coloured by its probability of being operable
  over the time it stands for (grey where the record has no row), a colour bar, times in UTC.
- `forecast.png` (forecast records): an operability bar per time step per planner, the
  probability in each cell and the limiting constraint where it is not operable.

Every plot takes a `title`: what it calls the record (an uploaded file's name); default the
record's source.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from matplotlib.artist import Artist
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from twin.site.windows import record_step

if TYPE_CHECKING:
    from matplotlib.typing import LineStyleType

    from twin.runs.workability import WorkabilityResult

#: planner bar colours (colour-blind safe), threshold line styles
COLOURS = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442")
DASHES: tuple[LineStyleType, ...] = (":", "--", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 3)), "-")
#: strip colours by probability: not operable … operable, no data grey
STRIP = ListedColormap(["#d7301f", "#fc8d59", "#fee08b", "#91cf60", "#1a9850"])


def figures(result: WorkabilityResult, title: str | None = None) -> dict[str, Figure]:
    """Every plot of `result` by file name (which ones depends on the record's kind), each
    titled by `title` (default the record's source)."""
    out = {"monthly.png": monthly(result, title)}
    if result.record.time is not None:
        out["windows.png"] = windows(result, title)
        out["strip.png"] = strip(result, title)
    if result.record.kind == "forecast":
        out["forecast.png"] = forecast(result, title)
    return out


def _title(result: WorkabilityResult, title: str | None = None) -> str:
    spec = result.spec
    lookup = "bilinear" if spec.cell_lookup == "linear" else "conservative"
    refined = f", refined ×{spec.refine_levels}" if spec.refine_levels else ""
    method = f"cells ({lookup} in Hs, Tp{refined})" if spec.method == "cells" else "direct runs"
    name = title or result.record.source
    return (f"{name}: {spec.mechanism}, {spec.heading.label()}, {spec.seeds} "
            f"seeds, {spec.duration:g} s runs, {method}\noperable: no limit violation, tip "
            f"error ≤ {spec.tip_error_threshold:g} m")  # fmt: skip


def monthly(result: WorkabilityResult, title: str | None = None) -> Figure:
    """Workability per calendar month per planner, the threshold lines, hours and years under
    each month, partial months hatched."""
    summary = result.summary
    planners = list(summary["planners"])
    months = summary.get("months", {})
    groups = list(months) or ["all"]

    def values(entry: dict) -> list[float]:
        if months:
            return [100 * entry["monthly"].get(g, np.nan) for g in groups]
        return [100 * entry["workability"]]

    figure = Figure(figsize=(max(6.5, 1.6 + 0.75 * len(groups) * max(1, len(planners)) / 2),
                             4.2), layout="constrained")  # fmt: skip
    ax = figure.subplots()
    x = np.arange(len(groups))
    width = 0.8 / len(planners)
    partial = [bool(months.get(g, {}).get("partial")) for g in groups]
    handles: list[Artist] = []
    for k, planner in enumerate(planners):
        entry = summary["planners"][planner]
        colour = COLOURS[k % len(COLOURS)]
        bars = ax.bar(x - 0.4 + width * (k + 0.5), values(entry), width, color=colour)
        share = 100 * entry["workability"]
        handles.append(Patch(color=colour, label=f"{planner.upper()} ({share:.0f} %)"))
        for bar, thin in zip(bars, partial, strict=True):
            if thin:  # a month under half covered: its bar is a sample, not a month
                bar.set_hatch("//")
                bar.set_alpha(0.55)
        if len(groups) * len(planners) <= 24:
            ax.bar_label(bars, fmt="%.0f", fontsize=8, padding=1)
    for k, (limit, entry) in enumerate(summary["threshold"].items()):
        # a line across each month's bars: the estimate the bars are read against
        share = 100 * entry["workability"]
        handles.append(ax.hlines(values(entry), x - 0.45, x + 0.45, colors="black",
                                 linewidth=1.4, linestyles=DASHES[k % len(DASHES)],
                                 label=f"Hs < {limit} m ({share:.0f} %)"))  # fmt: skip
    if any(partial):
        below = f"partial month (< {100 * summary['partial_month']:.0f} % covered)"
        handles.append(Patch(facecolor="white", edgecolor="black", hatch="//", label=below))
    ax.set_xticks(x, [_month_label(g, months.get(g)) for g in groups], fontsize=8)
    ax.set_ylim(0, 109)
    ax.set_ylabel("workability [%]")
    ax.legend(handles=handles, fontsize=9, loc="upper left", bbox_to_anchor=(1.0, 1.0),
              frameon=False)  # fmt: skip
    years = summary.get("years", [])
    pooled = f"\nmonths pooled over {len(years)} years ({years[0]}-{years[-1]})" \
        if len(years) > 1 else ""  # fmt: skip
    ax.set_title(_title(result, title) + pooled, fontsize=8)
    return figure


def _month_label(group: str, month: dict | None) -> str:
    """`Aug` over its hours and, pooled, its years; `partial` under half covered."""
    if month is None:
        return group
    years = month["years"]
    span = f"\n{years[0]}" if len(years) == 1 else f"\n{len(years)} yrs"
    return f"{group}{span}\n{month['hours']:.0f} h" + ("\npartial" if month["partial"] else "")


def windows(result: WorkabilityResult, title: str | None = None) -> Figure:
    """Histogram of window lengths ≥ W (the first W), the series side by side in each bin."""
    summary = result.summary
    w = f"{result.spec.window_hours[0]:g}" if result.spec.window_hours else None
    figure = Figure(figsize=(7.0, 3.8), layout="constrained")
    ax = figure.subplots()
    series: list[tuple[str, list[float], str]] = []  # label, lengths, colour
    for k, (planner, entry) in enumerate(summary["planners"].items()):
        stats = entry["windows"].get(w) if w else None
        if stats is not None:
            series.append((f"{planner.upper()}: {stats['count']} windows", stats["lengths"],
                           COLOURS[k % len(COLOURS)]))  # fmt: skip
    greys = ("#222222", "#666666", "#999999", "#bbbbbb")
    for k, (limit, entry) in enumerate(summary["threshold"].items()):
        stats = entry.get("windows", {}).get(w) if w else None
        if stats is not None:
            series.append((f"Hs < {limit} m: {stats['count']}", stats["lengths"],
                           greys[k % len(greys)]))  # fmt: skip
    if series and any(s[1] for s in series):
        low = float(w or 0)
        high = max(max(s[1], default=low) for s in series)
        bins = np.linspace(low, max(high, low + 1.0) + 1e-9, 13).tolist()
        ax.hist([s[1] for s in series], bins=bins, histtype="bar", rwidth=0.9,
                color=[s[2] for s in series], label=[s[0] for s in series])  # fmt: skip
        ax.legend(fontsize=8, frameon=False)
    else:
        ax.text(0.5, 0.5, f"no weather window of ≥ {w} h in this record", ha="center",
                va="center", transform=ax.transAxes)  # fmt: skip
    shift = result.spec.shift
    within = f", within {shift[0]:02d}-{shift[1]:02d} h UTC" if shift else ""
    ax.set_xlabel(f"window length [h] (windows ≥ {w} h{within})")
    ax.set_ylabel("windows")
    ax.set_title(_title(result, title), fontsize=8)
    return figure


def strip(result: WorkabilityResult, title: str | None = None) -> Figure:
    """One strip per planner: each row's probability over [its time, + one step), grey where
    the record has no row; a colour bar; UTC times."""
    import matplotlib.dates as mdates

    rows = result.rows
    planners = list(result.summary["planners"])
    figure = Figure(figsize=(9.0, 1.4 + 0.45 * len(planners)), layout="constrained")
    ax = figure.subplots()
    cmap = STRIP.with_extremes(bad="#bbbbbb")
    mesh = None
    for k, planner in enumerate(planners):
        group = rows[rows["planner"] == planner].sort_values("time", kind="stable")
        times = group["time"].to_numpy(dtype="datetime64[ns]")
        step = np.timedelta64(round(record_step(times) * 3.6e12), "ns")
        # cells [t_i, end_i) with the row's probability, the gaps to t_i+1 empty (grey)
        ends = np.minimum(times + step, np.append(times[1:], times[-1] + step))
        edges = np.empty(2 * times.size, dtype="datetime64[ns]")
        edges[0::2], edges[1::2] = times, ends
        values = np.full(2 * times.size - 1, np.nan)
        values[0::2] = group["probability"].to_numpy(dtype=float)
        x = mdates.date2num(edges.astype("datetime64[us]").astype(object))
        mesh = ax.pcolormesh(x, [k - 0.4, k + 0.4], np.ma.masked_invalid(values[None, :]),
                             cmap=cmap, vmin=0.0, vmax=1.0)  # fmt: skip
    if mesh is not None:
        figure.colorbar(mesh, ax=ax, label="P(operable)", fraction=0.04, pad=0.01)
    ax.set_ylim(-0.6, len(planners) - 0.4)
    ax.set_yticks(range(len(planners)), [p.upper() for p in planners])
    ax.xaxis_date()
    ax.set_xlabel("time (UTC)")
    figure.autofmt_xdate()
    ax.set_title(_title(result, title) + "\ncolour: probability of operable (green 1, red 0, "
                 "grey no data)", fontsize=8)  # fmt: skip
    return figure


def forecast(result: WorkabilityResult, title: str | None = None) -> Figure:
    """Operable runs [%] per forecast step per planner, at a width a page shows whole: the
    limiting constraint written in the cell while cells are wide enough for it."""
    rows = result.rows
    planners = list(result.summary["planners"])
    times = np.sort(rows["time"].unique())
    figure = Figure(figsize=(10.0, 1.6 + 0.6 * len(planners)), layout="constrained")
    ax = figure.subplots()
    roomy = len(times) <= 24  # cells wide enough for the constraint under the figure
    size = 8 if len(times) <= 24 else 7 if len(times) <= 48 else 0
    for k, planner in enumerate(planners):
        group = rows[rows["planner"] == planner].set_index("time").reindex(times)
        p = group["probability"].to_numpy(dtype=float)
        ax.imshow(np.ma.masked_invalid(p[None, :]), aspect="auto", cmap=STRIP, vmin=0, vmax=1,
                  extent=(-0.5, len(times) - 0.5, k - 0.4, k + 0.4), origin="lower")  # fmt: skip
        for j, (value, limit) in enumerate(zip(p, group["limiting"].fillna(""), strict=True)):
            if size and np.isfinite(value):
                text = f"{100 * value:.0f}"
                if roomy and value < 1.0 and limit:
                    text += "\n" + _short(limit)
                ax.text(j, k, text, ha="center", va="center", fontsize=size)
    ax.set_xlim(-0.5, len(times) - 0.5)
    ax.set_ylim(-0.6, len(planners) - 0.4)
    ax.set_yticks(range(len(planners)), [p.upper() for p in planners])
    labels = [pd.Timestamp(t).strftime("%d %Hh") for t in times]
    step = max(1, len(times) // 16)
    ax.set_xticks(range(0, len(times), step), labels[::step], rotation=45, fontsize=8)
    ax.set_xlabel("time (UTC, day hour)")
    ax.set_title(_title(result, title) + "\noperable runs [%] per step"
                 + ("; limiting constraint below" if roomy else ""), fontsize=8)  # fmt: skip
    return figure


def _short(limit: str) -> str:
    """A constraint's name, short enough for a forecast cell."""
    return (limit.replace("joint ", "").replace("leg stroke", "legs").replace("(upper)", "↑")
            .replace("(lower)", "↓").replace("tip error", "tip"))  # fmt: skip

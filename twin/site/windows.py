"""Weather windows of an operable / not series on a regular time step.

A *window* is a run of consecutive operable steps, optionally only within a daily work shift
(e.g. 07-19 h: a step counts only if it starts within the shift, so a window never spans the
night). Its length is its steps × the time step. The *waiting time* for a window of W hours,
from a start time t, is the time until the earliest step s ≥ t from which W hours are operable
(0 if the window is open at t); start times with no such s before the record ends are left out
and counted (`censored`).

    series = regular_series(times, operable)          # gaps become not operable
    stats = window_stats(series.operable, 1.0, 12.0, times=series.times, shift=(7, 19))
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from twin.errors import TwinError

#: percentiles of the waiting time reported
PERCENTILES = (10, 50, 90)


@dataclass(frozen=True)
class RegularSeries:
    """Attributes:
    times: (m,) datetime64[ns], regular at `step_hours` from the first time to the last.
    operable: (m,) bool; False where the record had no row (a gap) or was not operable.
    observed: (m,) bool; True where the record had a row.
    step_hours: [h] the step.
    """

    times: np.ndarray
    operable: np.ndarray
    observed: np.ndarray
    step_hours: float


def regular_series(
    times: np.ndarray, operable: np.ndarray, step_hours: float | None = None
) -> RegularSeries:
    """Put a record's operable flags on a regular grid: the step is `step_hours` or the record's
    median spacing; each row goes to its nearest grid time; grid times without a row are not
    operable (unknown weather is no window). Rows that share a grid time: operable only if all
    are."""
    times = np.asarray(times, dtype="datetime64[ns]")
    operable = np.asarray(operable, dtype=bool)
    if times.shape != operable.shape or times.ndim != 1 or times.size == 0:
        raise TwinError("times and operable: one non-empty row each, the same length")
    order = np.argsort(times, kind="stable")
    times, operable = times[order], operable[order]
    ns = times.astype(np.int64)
    if step_hours is None:
        gaps = np.diff(ns)
        gaps = gaps[gaps > 0]
        step_ns = int(np.median(gaps)) if gaps.size else 3_600_000_000_000
    else:
        if not math.isfinite(step_hours) or step_hours <= 0:
            raise TwinError(f"step_hours: got {step_hours!r}; allowed > 0")
        step_ns = round(step_hours * 3.6e12)
    index = np.rint((ns - ns[0]) / step_ns).astype(np.int64)
    m = int(index[-1]) + 1
    ok = np.ones(m, dtype=bool)
    observed = np.zeros(m, dtype=bool)
    np.logical_and.at(ok, index, operable)
    observed[index] = True
    grid = ns[0] + np.arange(m, dtype=np.int64) * step_ns
    return RegularSeries(grid.astype("datetime64[ns]"), ok & observed, observed, step_ns / 3.6e12)


@dataclass(frozen=True)
class WindowStats:
    """Windows of at least `min_hours` in an operable series.

    Attributes:
        min_hours: [h] W.
        step_hours: [h] the series' step.
        shift: (start hour, end hour) of the daily work shift, or None (round the clock).
        lengths: [h] every window's length, ≥ W, in time order.
        waits: [h] waiting time for a W-hour window from each start time that has one.
        censored: start times with no W-hour window before the end of the record.
    """

    min_hours: float
    step_hours: float
    shift: tuple[int, int] | None
    lengths: np.ndarray
    waits: np.ndarray
    censored: int

    @property
    def count(self) -> int:
        return int(self.lengths.size)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: count, length statistics and histogram, waiting-time mean/percentiles."""
        waits = self.waits
        out: dict[str, Any] = {
            "min_hours": self.min_hours, "step_hours": self.step_hours,
            "shift": list(self.shift) if self.shift else None, "count": self.count,
            "hours_in_windows": float(self.lengths.sum()),
            "length_mean": float(self.lengths.mean()) if self.count else None,
            "length_max": float(self.lengths.max()) if self.count else None,
            "lengths": [float(v) for v in self.lengths],
            "wait_mean": float(waits.mean()) if waits.size else None,
            "censored_starts": self.censored,
        }  # fmt: skip
        for p in PERCENTILES:
            out[f"wait_p{p}"] = float(np.percentile(waits, p)) if waits.size else None
        return out


def window_stats(
    operable: np.ndarray,
    step_hours: float,
    min_hours: float,
    *,
    times: np.ndarray | None = None,
    shift: tuple[int, int] | None = None,
) -> WindowStats:
    """Windows of at least `min_hours` [h] and the waiting time for one.

    Args:
        operable: (m,) bool, one per step of a regular series.
        step_hours: [h] the step (> 0).
        min_hours: [h] W, > 0; a window needs ceil(W / step) steps.
        times: (m,) datetime64 of the steps; needed with `shift`.
        shift: (start, end) hours of the day, 0 ≤ start < end ≤ 24: a step counts only if its
            time of day lies in [start, end).

    Raises:
        TwinError: a bad step, W or shift, or a shift without times.
    """
    ok = np.asarray(operable, dtype=bool).copy()
    if not math.isfinite(step_hours) or step_hours <= 0:
        raise TwinError(f"step_hours: got {step_hours!r}; allowed > 0")
    if not math.isfinite(min_hours) or min_hours <= 0:
        raise TwinError(f"min_hours: got {min_hours!r}; allowed > 0")
    if shift is not None:
        start, end = shift
        if not 0 <= start < end <= 24:
            raise TwinError(f"shift: got {shift!r}; allowed (start, end) hours, 0 ≤ start < "
                            "end ≤ 24")  # fmt: skip
        if times is None:
            raise TwinError("shift: needs the times of the steps")
        hours = pd.DatetimeIndex(np.asarray(times, dtype="datetime64[ns]"))
        hour = hours.hour + hours.minute / 60.0
        ok &= np.asarray((hour >= start) & (hour < end))
    need = max(1, math.ceil(min_hours / step_hours - 1e-9))
    if ok.size == 0:
        return WindowStats(float(min_hours), float(step_hours), shift, np.zeros(0), np.zeros(0), 0)
    # operable steps ahead of each step, itself included (a run's length from here): the
    # distance to the next not-operable step, a reverse running minimum
    steps = np.arange(ok.size)
    next_bad = np.minimum.accumulate(np.where(ok, ok.size, steps)[::-1])[::-1]
    ahead = next_bad - steps
    starts = np.flatnonzero(ok & np.concatenate([[True], ~ok[:-1]]))
    runs = ahead[starts]
    lengths = runs[runs >= need] * step_hours
    # the earliest step ≥ i that opens a W-hour window: a reverse running minimum
    opens = np.where(ahead >= need, np.arange(ok.size), ok.size)
    next_open = np.minimum.accumulate(opens[::-1])[::-1]
    found = next_open < ok.size
    waits = (next_open[found] - np.flatnonzero(found)) * step_hours
    return WindowStats(float(min_hours), float(step_hours), shift, lengths.astype(float),
                       waits.astype(float), int((~found).sum()))  # fmt: skip

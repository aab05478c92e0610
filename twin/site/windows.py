"""Weather windows of a record's operable / not rows, measured on the rows themselves.

Each row stands for one time step of the record (`record_step`: its median spacing) from its
time. A *window* is a run of operable rows, each within 1.5 steps of the one before (a longer
gap is unknown weather and ends the run), optionally only within a daily work shift (e.g.
07-19 h: a row counts only if it starts within the shift, so a window never spans the night).
Its length is from its first row's time to its last row's time plus one step. The *waiting
time* for a window of W hours, from a row, is the time until the earliest row from which W
hours are operable (0 if the window is open at that row); rows with no such row before the
record ends are left out and counted (`censored`). Memory and work are proportional to the
rows: no regular grid is built, so a record's spacing cannot make it larger.

    step = record_step(times)
    stats = window_stats(operable, step, 12.0, times=times, shift=(7, 19))
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
#: [h] the step of a record with a single row (or all rows at one time)
DEFAULT_STEP_HOURS = 1.0
#: a gap longer than this many steps between two rows ends a window
GAP_STEPS = 1.5


def record_step(times: np.ndarray) -> float:
    """[h] a record's time step: the median spacing of its sorted times (DEFAULT_STEP_HOURS for
    one row)."""
    ns = np.sort(np.asarray(times, dtype="datetime64[ns]")).astype(np.int64)
    gaps = np.diff(ns)
    gaps = gaps[gaps > 0]
    return float(np.median(gaps)) / 3.6e12 if gaps.size else DEFAULT_STEP_HOURS


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
    """Windows of at least `min_hours` [h] and the waiting time for one (module docstring).

    Args:
        operable: (n,) bool, one per row, in time order.
        step_hours: [h] the time a row stands for (> 0), e.g. `record_step(times)`.
        min_hours: [h] W, > 0.
        times: (n,) datetime64 of the rows, increasing; None: rows every `step_hours`. Needed
            with `shift`.
        shift: (start, end) hours of the day, 0 ≤ start < end ≤ 24: a row counts only if its
            time of day lies in [start, end).

    Raises:
        TwinError: a bad step, W or shift, a shift without times, or times out of order.
    """
    ok = np.asarray(operable, dtype=bool).copy()
    if not math.isfinite(step_hours) or step_hours <= 0:
        raise TwinError(f"step_hours: got {step_hours!r}; allowed > 0")
    if not math.isfinite(min_hours) or min_hours <= 0:
        raise TwinError(f"min_hours: got {min_hours!r}; allowed > 0")
    hours = _row_hours(ok.size, step_hours, times)
    if shift is not None:
        start, end = shift
        if not 0 <= start < end <= 24:
            raise TwinError(f"shift: got {shift!r}; allowed (start, end) hours, 0 ≤ start < "
                            "end ≤ 24")  # fmt: skip
        if times is None:
            raise TwinError("shift: needs the times of the steps")
        stamps = pd.DatetimeIndex(np.asarray(times, dtype="datetime64[ns]"))
        of_day = stamps.hour + stamps.minute / 60.0
        ok &= np.asarray((of_day >= start) & (of_day < end))
    n = ok.size
    if n == 0:
        return WindowStats(float(min_hours), float(step_hours), shift, np.zeros(0), np.zeros(0), 0)
    rows = np.arange(n)
    # row k + 1 continues row k's run if both are operable and no gap lies between them
    joined = ok[:-1] & ok[1:] & (np.diff(hours) < GAP_STEPS * step_hours)
    ends = ok & np.concatenate([~joined, [True]])
    starts = ok & np.concatenate([[True], ~joined])
    # each row's run end: the first end at or after it, a reverse running minimum
    run_end = np.minimum.accumulate(np.where(ends, rows, n)[::-1])[::-1]
    ahead = np.where(ok, hours[np.minimum(run_end, n - 1)] - hours + step_hours, 0.0)
    runs = ahead[starts]
    tolerance = 1e-6 * min(step_hours, min_hours)  # float noise of the hours, not a step
    lengths = runs[runs >= min_hours - tolerance]
    # the earliest row at or after each row that opens a W-hour window
    opens = np.where(ahead >= min_hours - tolerance, rows, n)
    next_open = np.minimum.accumulate(opens[::-1])[::-1]
    found = next_open < n
    waits = hours[next_open[found]] - hours[found]
    return WindowStats(float(min_hours), float(step_hours), shift, lengths.astype(float),
                       waits.astype(float), int((~found).sum()))  # fmt: skip


def _row_hours(n: int, step_hours: float, times: np.ndarray | None) -> np.ndarray:
    """[h] each row's time from the first row's (rows every step without times)."""
    if times is None:
        return np.arange(n) * step_hours
    ns = np.asarray(times, dtype="datetime64[ns]").astype(np.int64)
    if ns.shape != (n,):
        raise TwinError(f"times: {ns.shape} for {n} rows; allowed one time per row")
    if np.any(np.diff(ns) < 0):
        raise TwinError("times: out of order; allowed increasing times, one per row")
    return (ns - ns[0]) / 3.6e12 if n else np.zeros(0)

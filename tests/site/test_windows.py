"""Weather windows on hand-made series: counts, lengths, work shifts, waiting times, gaps, all
measured on the rows (no grid)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import TwinError
from twin.site.windows import record_step, window_stats

#: hourly: windows of 3, 1, 5 and 2 hours
SERIES = np.array([1, 1, 1, 0, 1, 0, 0, 1, 1, 1, 1, 1, 0, 1, 1], dtype=bool)


def test_counts_and_lengths_of_windows_of_at_least_w_hours() -> None:
    """Windows are runs of operable rows at least W hours long, measured in the record's step;
    none qualify when W is too long, and an empty record has no wait."""
    stats = window_stats(SERIES, 1.0, 2.0)
    assert stats.lengths.tolist() == [3.0, 5.0, 2.0] and stats.count == 3
    assert window_stats(SERIES, 1.0, 4.0).lengths.tolist() == [5.0]
    assert window_stats(SERIES, 0.5, 2.0).lengths.tolist() == [2.5]  # 5 steps of 0.5 h ≥ 2 h
    assert window_stats(SERIES, 1.0, 6.0).count == 0
    assert window_stats(np.zeros(0, dtype=bool), 1.0, 2.0).to_dict()["wait_mean"] is None


def test_waiting_time_for_a_window_by_hand() -> None:
    """The wait from each row for a W-hour window matches a hand count; rows with none before
    the record ends are censored, and the summary's mean and median are of the waits."""
    stats = window_stats(SERIES, 1.0, 3.0)
    # from each hour, hours until 3 operable hours in a row can start:
    # 0→0; 1→6 (next at 7); 2..6→5,4,3,2,1; 7,8,9→0; 10..14: none left (censored)
    expected = [0, 6, 5, 4, 3, 2, 1, 0, 0, 0]
    assert stats.waits.tolist() == expected and stats.censored == 5
    summary = stats.to_dict()
    assert summary["wait_mean"] == pytest.approx(np.mean(expected))
    assert summary["wait_p50"] == pytest.approx(np.percentile(expected, 50))


def test_work_shift_cuts_windows_at_night() -> None:
    """A daily shift cuts windows at its ends and moves waits to the next morning; a shift
    needs times and start < end."""
    times = np.datetime64("2024-01-01T00:00") + np.arange(48) * np.timedelta64(1, "h")
    operable = np.ones(48, dtype=bool)
    stats = window_stats(operable, 1.0, 4.0, times=times, shift=(7, 19))
    assert stats.lengths.tolist() == [12.0, 12.0]  # 07-19 h each day, never across the night
    assert window_stats(operable, 1.0, 4.0).lengths.tolist() == [48.0]
    # from 16 h on day 1 the next 4-hour window in the shift opens at 07 h next day
    waits = window_stats(operable, 1.0, 4.0, times=times, shift=(7, 19)).waits
    assert waits[16] == pytest.approx(31 - 16)
    with pytest.raises(TwinError, match="shift"):
        window_stats(operable, 1.0, 4.0, shift=(7, 19))
    with pytest.raises(TwinError, match="0 ≤ start < end ≤ 24"):
        window_stats(operable, 1.0, 4.0, times=times, shift=(19, 7))


def test_a_gap_between_rows_ends_a_window_and_is_waited_over() -> None:
    """Rows at 0, 1, 2, 5 and 6 h, all operable: the 3-hour gap ends the first window; waits
    are measured in hours between rows."""
    hours = np.array([0, 1, 2, 5, 6], dtype="timedelta64[h]")
    times = np.datetime64("2024-01-01T00:10") + hours
    step = record_step(times)
    assert step == pytest.approx(1.0)
    stats = window_stats(np.ones(5, dtype=bool), step, 2.0, times=times)
    assert stats.lengths.tolist() == [3.0, 2.0]
    # a 3-hour window opens at 0 h only: from the later rows none is left (censored)
    three = window_stats(np.ones(5, dtype=bool), step, 3.0, times=times)
    assert three.waits.tolist() == [0.0] and three.censored == 4
    # a row not operable before the gap: from 0 h the next 2-hour window opens at 5 h
    waits = window_stats(np.array([0, 1, 0, 1, 1], dtype=bool), step, 2.0, times=times).waits
    assert waits.tolist() == [5.0, 4.0, 3.0, 0.0]


def test_windows_are_measured_on_the_rows_whatever_their_spacing() -> None:
    """101 rows a nanosecond apart and one row a year later (a grid at the median step would
    have 3e16 points): the windows are those of the rows, at once."""
    ns = np.concatenate([np.arange(101), [365 * 24 * 3_600_000_000_000]])
    times = np.datetime64("2024-01-01", "ns") + ns.astype("timedelta64[ns]")
    step = record_step(times)
    assert step == pytest.approx(1 / 3.6e12)
    stats = window_stats(np.ones(102, dtype=bool), step, 50 / 3.6e12, times=times)
    assert stats.count == 1 and stats.lengths[0] == pytest.approx(101 / 3.6e12)
    assert stats.waits.size == 52 and stats.censored == 50  # rows 0-51 open a window


def test_single_row_and_no_window_give_empty_statistics() -> None:
    """One row, or no operable row: no window, no wait, every row censored, nothing raised."""
    one = window_stats(np.ones(1, dtype=bool), record_step(np.array(["2024-01-01"],
                       dtype="datetime64[ns]")), 6.0)  # fmt: skip
    assert one.count == 0 and one.censored == 1 and one.to_dict()["length_max"] is None
    none = window_stats(np.zeros(5, dtype=bool), 1.0, 1.0).to_dict()
    assert none["count"] == 0 and none["wait_p50"] is None and none["censored_starts"] == 5

"""Weather windows on hand-made series: counts, lengths, work shifts, waiting times, gaps."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import TwinError
from twin.site.windows import regular_series, window_stats

#: hourly: windows of 3, 1, 5 and 2 hours
SERIES = np.array([1, 1, 1, 0, 1, 0, 0, 1, 1, 1, 1, 1, 0, 1, 1], dtype=bool)


def test_counts_and_lengths_of_windows_of_at_least_w_hours() -> None:
    stats = window_stats(SERIES, 1.0, 2.0)
    assert stats.lengths.tolist() == [3.0, 5.0, 2.0] and stats.count == 3
    assert window_stats(SERIES, 1.0, 4.0).lengths.tolist() == [5.0]
    assert window_stats(SERIES, 0.5, 2.0).lengths.tolist() == [2.5]  # 5 steps of 0.5 h ≥ 2 h
    assert window_stats(SERIES, 1.0, 6.0).count == 0
    assert window_stats(np.zeros(0, dtype=bool), 1.0, 2.0).to_dict()["wait_mean"] is None


def test_waiting_time_for_a_window_by_hand() -> None:
    stats = window_stats(SERIES, 1.0, 3.0)
    # from each hour, hours until 3 operable hours in a row can start:
    # 0→0; 1→6 (next at 7); 2..6→5,4,3,2,1; 7,8,9→0; 10..14: none left (censored)
    expected = [0, 6, 5, 4, 3, 2, 1, 0, 0, 0]
    assert stats.waits.tolist() == expected and stats.censored == 5
    summary = stats.to_dict()
    assert summary["wait_mean"] == pytest.approx(np.mean(expected))
    assert summary["wait_p50"] == pytest.approx(np.percentile(expected, 50))


def test_work_shift_cuts_windows_at_night() -> None:
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


def test_regular_series_turns_gaps_into_not_operable() -> None:
    hours = np.array([0, 1, 2, 5, 6], dtype="timedelta64[h]")
    times = np.datetime64("2024-01-01T00:10") + hours
    series = regular_series(times, np.ones(5, dtype=bool))
    assert series.step_hours == pytest.approx(1.0)
    assert series.operable.tolist() == [True, True, True, False, False, True, True]
    assert series.observed.tolist() == series.operable.tolist()
    assert window_stats(series.operable, 1.0, 3.0).lengths.tolist() == [3.0]

"""The live motion source: its newest sample while live, None (fall back) once stale."""

from __future__ import annotations

import math

import pytest

from twin.sim.motion_live import LiveMotion


def test_follows_then_falls_back_when_stale() -> None:
    """The newest sample is followed while samples arrive; after stale_after it is None."""
    live = LiveMotion("test", stale_after=1.0)
    live.push([(0.0, (0.1, 0.01, 0.02)), (0.02, (0.2, 0.03, 0.04))], now=10.0)
    assert live.latest(10.5) == (0.2, 0.03, 0.04)
    assert live.live(10.5)
    assert live.latest(11.5) is None and not live.live(11.5)
    assert live.status(11.5)["live"] is False


def test_non_finite_sample_never_handed_out() -> None:
    """A NaN or infinite sample is counted and skipped; the last good one is held."""
    live = LiveMotion("test")
    live.push([(0.0, (0.1, 0.0, 0.0))], now=0.0)
    live.push([(0.02, (math.nan, 0.0, 0.0)), (0.04, (0.0, math.inf, 0.0))], now=0.1)
    assert live.latest(0.1) == (0.1, 0.0, 0.0)
    assert live.counts["non-finite"] == 2 and live.counts["samples"] == 1


def test_feed_parses_and_counts() -> None:
    """Bytes fed are parsed: a good TSS1 line stored, a malformed line counted by reason."""
    from twin.motion.tss1 import format_tss1

    live = LiveMotion("test")
    live.feed((format_tss1(0.5, 0.01, 0.02) + "\r\nnot a sentence\r\n").encode(), now=1.0)
    heave = live.latest(1.0)
    assert heave is not None and heave[0] == pytest.approx(0.5, abs=0.01)
    assert sum(n for r, n in live.counts.items() if r not in ("datagrams", "samples")) == 1


def test_buffer_is_bounded() -> None:
    """The buffer keeps its newest `size` samples only."""
    live = LiveMotion("test", size=3)
    live.push([(float(k), (float(k), 0.0, 0.0)) for k in range(10)], now=0.0)
    assert [s[0] for s in live.window()] == [7.0, 8.0, 9.0]


def test_bad_settings_refused() -> None:
    """A non-positive staleness or an empty buffer is a ValueError naming what is allowed."""
    with pytest.raises(ValueError, match="allowed"):
        LiveMotion("test", stale_after=0.0)

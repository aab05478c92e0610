"""The replay's lines (`twin.motion.replay.sentences`) for a log that lacks a channel: a
channel absent from the whole log is sent as 0, not read as a gap that drops every line."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twin.motion.nmea import read_nmea
from twin.motion.replay import sentences
from twin.motion.series import MotionSeries


@pytest.mark.parametrize("fmt", ["psxn", "pashr", "tss1"])
def test_a_log_without_heave_replays_every_sample(fmt: str) -> None:
    """A roll-and-pitch log (no heave column) of 20 samples gives 20 motion lines, and
    reading them back gives its roll to the format's resolution (0.01°) and heave 0."""
    t = np.arange(20) / 10.0
    motion = np.full((20, 6), np.nan)
    motion[:, 3], motion[:, 4] = 0.02 * np.sin(t), 0.01 * np.cos(t)
    lines = [line for _, line in sentences(MotionSeries(t, motion, ("roll", "pitch")), fmt)]
    back = read_nmea(lines, rate_hz=10.0)
    assert len(back) == 20 and back.issues == {}
    np.testing.assert_allclose(back.motion[:, 3], motion[:, 3], atol=math.radians(0.006))
    np.testing.assert_array_equal(back.motion[:, 2], 0.0)


def test_a_gap_in_the_log_is_not_sent() -> None:
    """A second without samples (> 5 steps) in a heave log is a sensor dropout: nothing is
    sent there, while a log that lacks roll and pitch still sends its other samples."""
    t = np.r_[np.arange(5), np.arange(15, 20)] / 10.0
    motion = np.full((10, 6), np.nan)
    motion[:, 2] = 0.1
    lines = list(sentences(MotionSeries(t, motion, ("heave",)), "tss1"))
    assert 5 <= len(lines) < 20

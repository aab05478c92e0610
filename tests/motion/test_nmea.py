"""The sentence and TSS1 parsers (`twin.motion.nmea`, `twin.motion.tss1`) and the live stream
(`twin.motion.stream`): good lines in each sensor's convention become the twin's; bad lines
(checksum, malformed, unsupported, no time, out of order) are counted and skipped, never
raised; quality flags count spikes and frozen values."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from twin.motion.nmea import Reading, Skip, flag_quality, parse_line, read_nmea, sentence
from twin.motion.stream import MAX_LINE, MotionStream
from twin.motion.tss1 import format_tss1, parse_tss1


def test_psxn_23_turns_into_the_twins_convention() -> None:
    """$PSXN,23 roll (port up +), pitch (bow up +), heading, heave (down +) → roll, −pitch
    [rad], heading [deg], −heave [m]."""
    got = parse_line(sentence("PSXN,23,1.50,-2.00,330.56,0.25"))
    assert isinstance(got, Reading) and got.time_of_day is None
    assert got.motion == pytest.approx((-0.25, math.radians(1.5), math.radians(2.0)))
    assert got.heading == pytest.approx(330.56)


def test_pashr_carries_its_time_of_day_and_heave_up() -> None:
    """$PASHR gives its own time of day [s], heave positive up, pitch negated."""
    got = parse_line(sentence("PASHR,085335.500,224.19,T,-01.26,+00.83,+00.12,0.1,0.1,0.2,1,0"))
    assert isinstance(got, Reading)
    assert got.time_of_day == pytest.approx(8 * 3600 + 53 * 60 + 35.5)
    assert got.motion == pytest.approx((0.12, math.radians(-1.26), -math.radians(0.83)))


@pytest.mark.parametrize("talker", ["HE", "GP"])
def test_hdt_is_a_heading_without_motion(talker: str) -> None:
    """$HEHDT and $GPHDT give the true heading and no motion sample."""
    got = parse_line(sentence(f"{talker}HDT,274.07,T"))
    assert isinstance(got, Reading) and got.motion is None and got.heading == pytest.approx(274.07)


@pytest.mark.parametrize(
    ("line", "reason"),
    [
        ("$PSXN,23,1.50,-2.00,330.56,0.25*00", "checksum"),
        ("$PSXN,23,1.0,2.0,3.0,4.0", "checksum"),  # none at all
        (sentence("PSXN,23,one,two,three,four"), "malformed"),
        ("PSXN,23,1,2,3,4", "malformed"),
        (sentence("GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"), "unsupported"),
        (":00FF60 0012F 0150  0225", "malformed"),  # one character short
        ("\x00\x01garbage", "malformed"),
    ],
)
def test_a_bad_line_is_a_skip_with_its_reason(line: str, reason: str) -> None:
    """Checksum errors, malformed and unsupported lines come back as a `Skip` naming why."""
    got = parse_line(line)
    assert isinstance(got, Skip) and got.reason == reason, got


def test_tss1_round_trips_and_reads_its_fields() -> None:
    """A TSS1 string of known values reads back to the format's resolution (cm, 0.01°), with
    its status flag, settling state and two's-complement vertical acceleration."""
    line = format_tss1(-0.456, math.radians(3.21), math.radians(-1.5), "g", 0.5, -0.2)
    assert len(line) == 25 and line.startswith(":")
    got = parse_tss1(line + "\r\n")
    assert got.heave == pytest.approx(-0.46) and got.roll == pytest.approx(math.radians(3.21))
    assert got.pitch == pytest.approx(math.radians(-1.5))
    assert got.status == "G" and got.settling
    assert got.vertical_acceleration == pytest.approx(-0.2, abs=0.000625)
    with pytest.raises(ValueError, match="status"):
        format_tss1(0.0, 0.0, 0.0, "X")


@given(st.floats(-9.0, 9.0), st.floats(-0.5, 0.5), st.floats(-0.5, 0.5))
def test_every_format_reads_back_what_it_wrote(heave: float, roll: float, pitch: float) -> None:
    """format → parse gives back heave, roll and pitch to each format's resolution."""
    for line, step in [
        (format_tss1(heave, roll, pitch), (0.005, math.radians(0.005))),
        (sentence(f"PSXN,23,{math.degrees(roll):.3f},{-math.degrees(pitch):.3f},10.0,"
                  f"{-heave:.3f}"), (0.0005, math.radians(0.0005))),
    ]:
        got = parse_line(line)
        assert isinstance(got, Reading) and got.motion is not None
        assert abs(got.motion[0] - heave) <= step[0] + 1e-12
        assert abs(got.motion[1] - roll) <= step[1] + 1e-12
        assert abs(got.motion[2] - pitch) <= step[1] + 1e-12


def test_a_log_of_stamped_lines_counts_what_it_skips() -> None:
    """Stamped lines become samples at their stamps; a checksum error, a line without time
    after stamped ones, an out-of-order stamp and a bad stamp are counted; headings become yaw
    about their mean (counter-clockwise)."""
    lines = [
        "2026-08-01T14:00:00.000Z " + sentence("HEHDT,10.0,T"),
        "2026-08-01T14:00:00.000Z " + sentence("PSXN,23,1.0,0.0,10.0,0.1"),
        "2026-08-01T14:00:00.100Z " + format_tss1(0.2, 0.0, 0.0),
        "2026-08-01T14:00:00.200Z " + sentence("HEHDT,14.0,T"),
        "2026-08-01T14:00:00.200Z " + format_tss1(0.3, 0.0, 0.0),
        "2026-08-01T14:00:00.150Z " + format_tss1(0.4, 0.0, 0.0),  # back in time
        "2026-08-01T14:00:00.300Z $PSXN,23,1.0,0.0,10.0,0.1*00",  # bad checksum
        "yesterday " + format_tss1(0.5, 0.0, 0.0),  # bad stamp
    ]
    series = read_nmea(lines, source="test")
    np.testing.assert_allclose(series.time, [0.0, 0.1, 0.2])
    np.testing.assert_allclose(series.motion[:, 2], [-0.1, 0.2, 0.3])
    assert series.start == np.datetime64("2026-08-01T14:00:00")
    assert series.issues == {"out of order": 1, "checksum": 1, "malformed": 1}
    assert series.channels == ("heave", "roll", "pitch", "yaw")
    np.testing.assert_allclose(series.heading, [10.0, 10.0, 14.0])
    assert series.motion[0, 5] > 0 > series.motion[2, 5]  # turning clockwise: yaw falls


def test_lines_without_time_need_a_rate() -> None:
    """Without stamps, TSS1 lines are samples k / rate; with no rate they are counted as
    `no time`."""
    lines = [format_tss1(0.01 * k, 0.0, 0.0) for k in range(5)]
    assert len(read_nmea(lines, rate_hz=10.0).time) == 5
    assert read_nmea(lines).issues == {"no time": 5}


def test_the_stream_joins_split_datagrams_and_bounds_its_buffer() -> None:
    """A sentence split over two datagrams is one sample; several lines in one datagram are
    samples a microsecond apart; a line without an end longer than MAX_LINE is dropped and
    counted; the stream keeps no history."""
    stream = MotionStream("udp test")
    whole = sentence("PSXN,23,1.0,-2.0,90.0,0.5")
    assert stream.feed(whole[:10].encode(), 1.0) == []
    first = stream.feed((whole[10:] + "\r\n" + format_tss1(0.1, 0.0, 0.0) + "\r\n").encode(), 1.0)
    assert [round(t, 6) for t, _ in first] == [1.0, 1.000001]
    assert stream.feed(b"x" * (MAX_LINE + 1), 2.0) == [] and stream.issues == {"too long": 1}
    assert stream.feed(b"\xff\xfe\n", 2.0) == [] and stream.issues["malformed"] == 1
    assert len(stream._assembler.times) == 1  # only the newest sample is held


def test_quality_flags_count_spikes_and_frozen_values() -> None:
    """A 1 m heave spike in a smooth record is one spike; 30 repeats of one roll value are 30
    frozen samples; a smooth record (absent channels NaN) flags nothing."""
    t = np.arange(200) * 0.1
    motion = np.c_[np.full((200, 2), np.nan), 0.5 * np.sin(t), 0.01 * np.sin(0.7 * t),
                   0.02 * np.cos(0.5 * t), np.zeros(200) + 1e-3 * t]  # fmt: skip
    assert flag_quality(motion) == {}
    spiky = motion.copy()
    spiky[100, 2] += 1.0
    spiky[20:50, 3] = 0.004
    assert flag_quality(spiky) == {"spike": 1, "frozen": 30}


def test_stamped_pashr_lines_start_at_their_first_stamp() -> None:
    """A receive stamp wins over PASHR's own time of day: the series starts at the first stamp
    and its times follow the stamps (not the stamp plus the time of day)."""
    lines = [f"2026-08-01T16:30:{s:02d}.500Z "
             + sentence(f"PASHR,1630{s:02d}.000,158.09,T,-0.30,+0.31,+0.01,0.029,0.029,0.059,1,1")
             for s in range(29, 33)]  # fmt: skip
    series = read_nmea(lines)
    assert series.start == np.datetime64("2026-08-01T16:30:29.500")
    np.testing.assert_allclose(series.time, [0.0, 1.0, 2.0, 3.0])
    unstamped = read_nmea([line.split(" ", 1)[1] for line in lines])
    np.testing.assert_allclose(unstamped.time, [0.0, 1.0, 2.0, 3.0])  # its own times of day


def test_the_stream_reads_datagrams_without_line_ends() -> None:
    """One sentence per datagram and no CR LF (some senders): each datagram is a sample as it
    comes; a split one still waits for its rest, and a tail that never parses is not a sample."""
    stream = MotionStream("udp test")
    got = [stream.feed(format_tss1(0.01 * k, 0.0, 0.0).encode(), float(k)) for k in range(3)]
    assert [len(g) for g in got] == [1, 1, 1] and stream.issues == {}
    whole = sentence("PSXN,23,1.0,-2.0,90.0,0.5")
    assert stream.feed(whole[:-1].encode(), 3.0) == []  # its checksum is cut: not yet whole
    assert len(stream.feed(whole[-1:].encode(), 3.5)) == 1
    assert stream.feed(b"$GPHDT,123.456,T", 4.0) == []  # no checksum: waits, never a sample


def test_a_log_that_opens_with_motion_before_heading_keeps_its_yaw() -> None:
    """TSS1 lines before the first $HEHDT take its heading: the series has yaw and a finite
    heading throughout, the later heading change seen as yaw."""
    lines = [format_tss1(0.1, 0.0, 0.0), format_tss1(0.1, 0.0, 0.0), sentence("HEHDT,20.0,T"),
             format_tss1(0.1, 0.0, 0.0), sentence("HEHDT,22.0,T"), format_tss1(0.1, 0.0, 0.0)]
    series = read_nmea(lines, rate_hz=10.0)
    assert "yaw" in series.channels and series.heading is not None
    np.testing.assert_allclose(series.heading, [20.0, 20.0, 20.0, 22.0])
    assert series.motion[0, 5] > 0 > series.motion[3, 5]

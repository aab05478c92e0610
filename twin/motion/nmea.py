"""NMEA 0183 sentences of motion sensors, parsed by pynmea2 and turned into the twin's frame.

- Kongsberg `$PSXN,23` (roll, pitch, heading, heave): roll positive port side up, pitch
  positive bow up, heave positive down (pynmea2's `SXN23`; Kongsberg Seatex MRU manual);
- `$PASHR` (time of day, heading, roll, pitch, heave, accuracies; pynmea2's `ASHRATT`): roll
  positive port side up, pitch positive bow up, heave positive up;
- `$HEHDT` / `$GPHDT` (any talker's `HDT`): true heading [deg], clockwise from north;
- the TSS1 string (`twin.motion.tss1`, no checksum, no time).

The twin's convention (docs/frames.md) has pitch positive bow *down* (right-handed about y to
port) and heave up, so pitch is negated and PSXN's heave too; a sensor mounted otherwise is
corrected by its sensor file (`twin.motion.sensor.Sensor.signs`). Heading becomes yaw as its
oscillation about the record's mean, counter-clockwise (yaw = −(heading − mean)).

A sentence's checksum is checked (pynmea2); a bad line is counted by its reason and skipped,
never raised. Reasons: `checksum`, `malformed`, `unsupported`, `no time`, `out of order`.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass
from functools import reduce

import numpy as np
import pynmea2

from twin.motion.series import CHANNELS, MotionSeries
from twin.motion.tss1 import parse_tss1

HEAVE, ROLL, PITCH = CHANNELS.index("heave"), CHANNELS.index("roll"), CHANNELS.index("pitch")


@dataclass(frozen=True)
class Reading:
    """What one line said: the time of day [s] it carries (PASHR) or None, the heave [m],
    roll and pitch [rad] in the twin's convention (None for a heading-only sentence), and
    the true heading [deg] (None where the sentence has none)."""

    time_of_day: float | None
    motion: tuple[float, float, float] | None
    heading: float | None


@dataclass(frozen=True)
class Skip:
    """A line that was not used, and why (one of the module doc's reasons)."""

    reason: str
    detail: str = ""


def checksum(body: str) -> str:
    """The NMEA checksum of a sentence's body (between `$` and `*`): two hex digits."""
    return f"{reduce(lambda a, c: a ^ ord(c), body, 0):02X}"


def sentence(body: str) -> str:
    """`$body*CS`, the sentence with its checksum (no line end)."""
    return f"${body}*{checksum(body)}"


def parse_line(line: str) -> Reading | Skip:
    """One line (a sentence or a TSS1 string, without any time stamp in front) as a `Reading`,
    or the `Skip` that says why it is not one. Never raises."""
    text = line.strip()
    if text.startswith(":"):
        try:
            tss = parse_tss1(text)
        except ValueError as error:
            return Skip("malformed", str(error))
        return Reading(None, (tss.heave, tss.roll, tss.pitch), None)
    if not text.startswith("$"):
        return Skip("malformed", f"not a sentence: {text[:40]!r}")
    try:
        message = pynmea2.parse(text, check=True)
    except pynmea2.ChecksumError as error:
        return Skip("checksum", str(error)[:80])
    except pynmea2.SentenceTypeError as error:
        return Skip("unsupported", str(error)[:80])
    except (pynmea2.ParseError, ValueError, AttributeError) as error:
        return Skip("malformed", str(error)[:80])
    try:
        return _reading(message)
    except (TypeError, ValueError) as error:
        return Skip("malformed", f"{type(message).__name__}: {error}"[:80])


def _reading(message: pynmea2.NMEASentence) -> Reading | Skip:
    """The `Reading` of a parsed sentence of a supported kind."""
    kind = type(message).__name__
    if kind == "SXN23":
        roll, pitch = math.radians(float(message.roll)), -math.radians(float(message.pitch))
        return Reading(None, (-float(message.heave), roll, pitch), float(message.head))
    if kind == "ASHRATT":
        stamp = message.timestamp
        seconds = stamp.hour * 3600 + stamp.minute * 60 + stamp.second + stamp.microsecond / 1e6
        return Reading(seconds, (float(message.heave), math.radians(float(message.roll)),
                                 -math.radians(float(message.pitch))),
                       float(message.true_heading))  # fmt: skip
    if kind == "HDT":
        return Reading(None, None, float(message.heading))
    return Skip("unsupported", kind)


class Assembler:
    """Readings in, samples out: heading sentences update the heading the next motion
    sentence is stamped with; each motion sentence is one sample at its own time of day
    (PASHR), else the time the caller gives (a log's stamp, an arrival time, a rate).
    Counts what it skips (`issues`)."""

    def __init__(self) -> None:
        self.issues: Counter[str] = Counter()
        self.times: list[float] = []
        self.rows: list[tuple[float, float, float]] = []
        self.headings: list[float] = []
        self._heading = math.nan
        self._day = 0.0  # [s] added to PASHR's time of day across midnight

    def add(self, line: str, t: float | None, arrival: bool = False,
            stamped: bool = False) -> bool:  # fmt: skip
        """Add one line with the time t [s] it came at (None: only its own time); True when it
        made a sample. With `arrival`, t is when the line arrived (several lines of one
        datagram share it): a sample no later than the one before is put a microsecond after
        it, not refused as out of order. With `stamped`, t is the line's own receive stamp
        and wins over a sentence's time of day (the series' start is the first stamp)."""
        reading = parse_line(line)
        if isinstance(reading, Skip):
            self.issues[reading.reason] += 1
            return False
        if reading.heading is not None and math.isfinite(reading.heading):
            self._heading = reading.heading % 360.0
        if reading.motion is None:
            return False
        if reading.time_of_day is not None and not stamped:
            t = self._day + reading.time_of_day
            if self.times and t < self.times[-1] - 43_200.0:  # past midnight
                self._day += 86_400.0
                t += 86_400.0
        if t is None:
            self.issues["no time"] += 1
            return False
        if self.times and t <= self.times[-1]:
            if not arrival or reading.time_of_day is not None:
                self.issues["out of order"] += 1
                return False
            t = self.times[-1] + 1e-6
        if not all(math.isfinite(v) for v in reading.motion):
            self.issues["malformed"] += 1
            return False
        self.times.append(t)
        self.rows.append(reading.motion)
        self.headings.append(self._heading)
        return True

    def series(self, source: str, start: np.datetime64 | None = None) -> MotionSeries:
        """What was added as a `MotionSeries` (heave, roll, pitch and, where any heading came,
        yaw), times from the first sample, quality flags counted (`flag_quality`). Samples
        before the first heading sentence take its heading (a compass sentence comes every
        0.1-1 s), so a log that opens with a motion line keeps its yaw."""
        time = np.asarray(self.times, dtype=float)
        motion = np.full((time.size, 6), np.nan)
        if time.size:
            motion[:, [HEAVE, ROLL, PITCH]] = np.asarray(self.rows)
        channels = ["heave", "roll", "pitch"]
        heading = np.asarray(self.headings, dtype=float)
        known = np.isfinite(heading)
        has_heading = bool(np.any(known))
        if has_heading:
            heading[: int(np.argmax(known))] = heading[known][0]
        if has_heading:
            unwrapped = np.unwrap(np.radians(heading))
            motion[:, CHANNELS.index("yaw")] = -(unwrapped - unwrapped.mean())
            channels.append("yaw")
        t0 = float(time[0]) if time.size else 0.0
        if start is not None and time.size:
            start = start + np.timedelta64(round(t0 * 1e9), "ns")
        issues = dict(self.issues) | flag_quality(motion)
        return MotionSeries(time - t0, motion, tuple(c for c in CHANNELS if c in channels),
                            start, issues, source, heading if has_heading else None)  # fmt: skip


#: a sample differing from its neighbours' median by more than this many times their median
#: absolute deviation (and by SPIKE_FLOOR) is a spike; a channel holding one value for FROZEN
#: samples or more is frozen
SPIKE_MAD, SPIKE_FLOOR, FROZEN = 6.0, (0.05, 0.005), 25


def flag_quality(motion: np.ndarray) -> dict[str, int]:
    """Counts of flagged samples in (N, 6) motion: `spike` (a sample far from the median of
    the 11 around it: > SPIKE_MAD × their median absolute deviation and > SPIKE_FLOOR, 5 cm or
    5 mrad), `frozen` (samples in runs of ≥ FROZEN identical values of a channel). Flagged,
    not removed: the estimator and the report say what they rest on."""
    out: dict[str, int] = {}
    n = motion.shape[0]
    if n < 11:
        return out
    spikes = frozen = 0
    for c in range(6):
        x = motion[:, c]
        if not np.all(np.isfinite(x)):
            continue
        windows = np.lib.stride_tricks.sliding_window_view(np.pad(x, 5, mode="edge"), 11)
        median = np.median(windows, axis=1)
        mad = np.median(np.abs(windows - median[:, None]), axis=1)
        floor = SPIKE_FLOOR[0] if c < 3 else SPIKE_FLOOR[1]
        spikes += int(np.count_nonzero(np.abs(x - median) > np.maximum(SPIKE_MAD * mad, floor)))
        change = np.flatnonzero(np.diff(x) != 0.0)
        runs = np.diff(np.r_[-1, change, n - 1])
        frozen += int(runs[runs >= FROZEN].sum())
    if spikes:
        out["spike"] = spikes
    if frozen:
        out["frozen"] = frozen
    return out


def read_nmea(
    lines: Iterable[str],
    rate_hz: float | None = None,
    start: np.datetime64 | None = None,
    source: str = "",
) -> MotionSeries:
    """Motion from NMEA/TSS1 lines. A line may begin with its receive time, an ISO 8601 UTC
    stamp (`2026-08-01T14:00:00.125Z $PSXN,...`) or seconds (`12.340 :00FF60 ...`); without
    one, a PASHR sentence's own time of day is used (its day from `start`, else day 0, rolled
    over at midnight), else sample k is at k / rate_hz. Bad lines are counted, never raised.
    """
    assembler = Assembler()
    made = 0
    first_stamp: np.datetime64 | None = None
    for raw in lines:
        text = raw.strip()
        if not text:
            continue
        stamp, _, rest = text.partition(" ") if text[0] not in "$:" else ("", "", text)
        t: float | None = None
        if stamp:
            t, when = _stamp(stamp)
            if t is None and when is None:
                assembler.issues["malformed"] += 1
                continue
            if when is not None:
                first_stamp = when if first_stamp is None else first_stamp
                t = float((when - first_stamp) / np.timedelta64(1, "ns")) * 1e-9
        elif rate_hz:
            t = made / rate_hz
        made += assembler.add(rest if stamp else text, t, stamped=bool(stamp))
    return assembler.series(source, first_stamp if first_stamp is not None else start)


def _stamp(text: str) -> tuple[float | None, np.datetime64 | None]:
    """(seconds, None) or (None, UTC time) of a line's leading stamp; (None, None) if neither."""
    try:
        return float(text), None
    except ValueError:
        pass
    try:
        return None, np.datetime64(text.rstrip("Zz"), "ns")
    except ValueError:
        return None, None

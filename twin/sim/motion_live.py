"""The live motion source the live session reads: the newest measured hull motion from a
stream (UDP, a serial port), held in a bounded buffer, and whether it is still live.

A sample is (t [s], (heave [m], roll, pitch [rad])) in the twin's convention
(`twin.motion.nmea`). A non-finite sample is counted and never stored, so `latest` never
hands out NaN; a source that has sent nothing for `stale_after` seconds is stale.

The live session follows a stream through `StreamMotion`, a `Measured` source of base poses
for the one engine (`twin.sim.base_motion.MeasuredBase`, as a stored log's): the stream's
clock drives the simulation, anchored `LAG` behind the newest sample, which then steps only
as far as samples have arrived (a pose is interpolated between two received samples, never
extrapolated), so it trails the newest by under one step plus one tick of the loop. While
the stream is stale the simulation stands still, holding the last pose (never NaN); when
samples come again after a gap (or the stream's clock jumps by more than `RESYNC`), it
re-anchors to the newest sample and goes on from there, the gap skipped, not bridged by a
straight line.
"""

from __future__ import annotations

import math
import threading
from collections import Counter, deque
from collections.abc import Callable, Sequence

import numpy as np

from twin.motion.stream import MotionStream
from twin.sim.base_motion import BaseMotion, MeasuredBase, mount_for
from twin.sim.measured import poses_at
from twin.sim.scenario import Scenario
from twin.vessel import Mount

#: [s] without a sample after which a source is stale: five samples at the slowest MRU rate
#: the twin reads (5 Hz; docs/motion.md)
STALE_AFTER = 1.0
#: samples kept: 60 s at 50 Hz, the fastest rate an MRU sends; older ones are dropped
BUFFER = 3000
#: [s] how far behind the newest sample the followed simulation is anchored (the first
#: sample, after a gap): one 10 Hz sample, five at 50 Hz
LAG = 0.1
#: [s] a difference between the stream's clock and the simulation's, past their `LAG`, after
#: which the simulation re-anchors (a gap, a sender restarted on another clock)
RESYNC = STALE_AFTER

Sample = tuple[float, tuple[float, float, float]]


class LiveMotion:
    """Thread-safe buffer of a live stream's samples (a writer thread, readers elsewhere).

    Attributes:
        source: what feeds it ("udp 127.0.0.1:10110").
        stale_after: [s] of silence after which `live` is False.
        counts: "samples" stored, "non-finite" refused, and whatever the feeder adds
            ("datagrams", "refused sender", a parser's skip reasons).
    """

    def __init__(
        self, source: str, stale_after: float = STALE_AFTER, size: int = BUFFER,
        sensor_position: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:  # fmt: skip
        if not stale_after > 0 or size < 1:
            raise ValueError(f"live motion: stale_after {stale_after!r} s and size {size!r}; "
                             "allowed > 0 s and ≥ 1")  # fmt: skip
        self.source = source
        #: [m] the sensor's point in the vessel frame (`twin.motion.sensor.Sensor.position`)
        self.sensor_position = sensor_position
        self.stale_after = stale_after
        self.counts: Counter[str] = Counter()
        self._buffer: deque[Sample] = deque(maxlen=size)
        self._arrived = -math.inf  # [s] clock time of the newest stored sample
        self._lock = threading.Lock()
        self._stream = MotionStream(source)

    def feed(self, data: bytes, now: float) -> None:
        """Parse a datagram's bytes that arrived at clock time `now` [s] (one feeder thread
        only): its samples are stored, what the parser skipped is counted by reason."""
        before = self._stream.issues
        samples = self._stream.feed(data, now)
        after = self._stream.issues
        with self._lock:
            self.counts["datagrams"] += 1
            self.counts.update({r: n - before.get(r, 0) for r, n in after.items()
                                if n > before.get(r, 0)})  # fmt: skip
        self.push(samples, now)

    def push(self, samples: list[Sample], now: float) -> None:
        """Store samples that arrived at clock time `now` [s]; non-finite ones are counted."""
        good = [s for s in samples if all(math.isfinite(v) for v in (s[0], *s[1]))]
        with self._lock:
            last = self._buffer[-1][0] if self._buffer else -math.inf
            ordered = []
            for s in good:  # the buffer's times increase, as interpolation needs
                if s[0] > last:
                    ordered.append(s)
                    last = s[0]
            self._buffer.extend(ordered)
            self.counts["samples"] += len(ordered)
            self.counts["non-finite"] += len(samples) - len(good)
            if len(good) > len(ordered):
                self.counts["out of order"] += len(good) - len(ordered)
            good = ordered
            if good:
                self._arrived = now

    def count(self, reason: str, n: int = 1) -> None:
        """Add n to a feeder's counter (a datagram received, a sender refused, …)."""
        with self._lock:
            self.counts[reason] += n

    def live(self, now: float) -> bool:
        """Whether a sample arrived within `stale_after` of clock time `now` [s]."""
        with self._lock:
            return now - self._arrived <= self.stale_after

    def latest(self, now: float) -> tuple[float, float, float] | None:
        """The newest (heave [m], roll, pitch [rad]) while live, else None (fall back)."""
        with self._lock:
            if not self._buffer or now - self._arrived > self.stale_after:
                return None
            return self._buffer[-1][1]

    def newest(self) -> float | None:
        """[s] the newest stored sample's time (stale or not), None before the first."""
        with self._lock:
            return self._buffer[-1][0] if self._buffer else None

    def since(self, t0: float) -> tuple[np.ndarray, np.ndarray]:
        """The samples from the last one at or before `t0` [s] on (all if none is): times
        (M,) [s] and motion (M, 6) [m, rad] in `CHANNELS` order, surge, sway and yaw NaN (not
        measured). Read from the newest back, so following a stream costs a few samples."""
        with self._lock:
            picked: list[Sample] = []
            for sample in reversed(self._buffer):
                picked.append(sample)
                if sample[0] <= t0:
                    break
        picked.reverse()
        motion = np.full((len(picked), 6), np.nan)
        motion[:, 2:5] = [m for _, m in picked] if picked else np.empty((0, 3))
        return np.array([t for t, _ in picked], dtype=float), motion

    def window(self) -> list[Sample]:
        """A copy of the buffered samples, oldest first (for the onboard estimate)."""
        with self._lock:
            return list(self._buffer)

    def status(self, now: float) -> dict[str, object]:
        """What the viewer and the API show: the source, live or stale, the counts and the
        newest sample (t [s], heave [m], roll, pitch [rad]; kept while stale), or None."""
        with self._lock:
            age = now - self._arrived
            newest = self._buffer[-1] if self._buffer else None
            return {
                "source": self.source,
                "live": age <= self.stale_after,
                "age_s": age if math.isfinite(age) else None,
                "counts": dict(self.counts),
                "latest": None if newest is None else dict(
                    zip(("t", "heave", "roll", "pitch"), map(float, (newest[0], *newest[1])),
                        strict=True)),
            }  # fmt: skip


class StreamMotion:
    """The mount's base poses from a live stream (a `twin.sim.base_motion.Measured`): run time
    t [s] reads the stream at t + `offset`, interpolated as a stored log is
    (`twin.sim.measured.poses_at`; held at the newest sample past it, the rest pose before
    the first). `due` says how many steps the samples that arrived allow, and anchors
    `offset` (module docstring).

    Attributes:
        live: the stream's buffer; mount: the mechanism's mount.
        offset: [s] stream time minus run time (None until the first sample).
        resyncs: times the offset was anchored (the first sample, then each gap or jump).
    """

    #: the engine samples one step ahead at a time: the next sample may not have arrived
    horizon: int | None = 1

    def __init__(self, live: LiveMotion, mount: Mount) -> None:
        self.live, self.mount = live, mount
        self.offset: float | None = None
        self.resyncs = 0

    def _anchor(self, newest: float, t: float) -> float:
        self.offset = newest - LAG - t
        self.resyncs += 1
        return self.offset

    def due(self, t: float, dt: float, now: float) -> int:
        """Steps of dt [s] from run time t [s] whose poses have arrived by clock time `now`
        [s] (`LiveMotion.live`); 0 while the stream is stale or silent (the run holds)."""
        newest = self.live.newest()
        if newest is None or not self.live.live(now):
            return 0
        offset = self.offset if self.offset is not None else math.nan
        ahead = newest - offset - t
        if not abs(ahead - LAG) <= RESYNC:  # the first sample, a gap, a jump of the clock
            ahead = newest - self._anchor(newest, t) - t
        return max(0, int(ahead / dt + 1e-9))

    def poses(self, t: np.ndarray) -> np.ndarray:
        """(N, 6) [m, rad] the mount's base poses at run times t (N,) [s], always finite."""
        t = np.asarray(t, dtype=float)
        newest = self.live.newest()
        if newest is None or t.size == 0:  # nothing measured yet: the hull at rest
            return poses_at(np.zeros(1), np.full((1, 6), np.nan), t, (0.0, 0.0, 0.0), self.mount)
        offset = self.offset if self.offset is not None else self._anchor(newest, float(t[0]))
        at = t + offset
        time, motion = self.live.since(float(at.min()))
        return poses_at(time, motion, at, self.live.sensor_position, self.mount)


def stream_motions(live: LiveMotion) -> Callable[[Sequence[Scenario]], list[BaseMotion]]:
    """`Simulation`'s `motions` for a run that follows `live`: every lane on one mount reads
    one `StreamMotion` (so a comparison lane sees the same hull motion at the same offset),
    kept across sea changes (the stream is the sea)."""
    streams: dict[str, StreamMotion] = {}

    def motions(scenarios: Sequence[Scenario]) -> list[BaseMotion]:
        out: list[BaseMotion] = []
        for s in scenarios:
            if s.mechanism not in streams:
                streams[s.mechanism] = StreamMotion(live, mount_for(s.mechanism))
            out.append(MeasuredBase(streams[s.mechanism]))
        return out

    return motions

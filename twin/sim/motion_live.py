"""The live motion source the live session reads: the newest measured hull motion from a
stream (UDP, a serial port), held in a bounded buffer, and whether it is still live.

A sample is (t [s], (heave [m], roll, pitch [rad])) in the twin's convention
(`twin.motion.nmea`). A non-finite sample is counted and never stored, so `latest` never
hands out NaN; a source that has sent nothing for `stale_after` seconds is stale, and the
live session falls back to its synthesised sea (and says so).
"""

from __future__ import annotations

import math
import threading
from collections import Counter, deque

from twin.motion.stream import MotionStream

#: [s] without a sample after which a source is stale: five samples at the slowest MRU rate
#: the twin reads (5 Hz; docs/motion.md)
STALE_AFTER = 1.0
#: samples kept: 60 s at 50 Hz, the fastest rate an MRU sends; older ones are dropped
BUFFER = 3000

Sample = tuple[float, tuple[float, float, float]]


class LiveMotion:
    """Thread-safe buffer of a live stream's samples (a writer thread, readers elsewhere).

    Attributes:
        source: what feeds it ("udp 127.0.0.1:10110").
        stale_after: [s] of silence after which `live` is False.
        counts: "samples" stored, "non-finite" refused, and whatever the feeder adds
            ("datagrams", "refused sender", a parser's skip reasons).
    """

    def __init__(self, source: str, stale_after: float = STALE_AFTER,
                 size: int = BUFFER) -> None:  # fmt: skip
        if not stale_after > 0 or size < 1:
            raise ValueError(f"live motion: stale_after {stale_after!r} s and size {size!r}; "
                             "allowed > 0 s and ≥ 1")  # fmt: skip
        self.source = source
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
            self._buffer.extend(good)
            self.counts["samples"] += len(good)
            self.counts["non-finite"] += len(samples) - len(good)
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

    def window(self) -> list[Sample]:
        """A copy of the buffered samples, oldest first (for the onboard estimate)."""
        with self._lock:
            return list(self._buffer)

    def status(self, now: float) -> dict[str, object]:
        """What the viewer and the API show: the source, live or stale, and the counts."""
        with self._lock:
            age = now - self._arrived
            return {
                "source": self.source,
                "live": age <= self.stale_after,
                "age_s": age if math.isfinite(age) else None,
                "counts": dict(self.counts),
            }

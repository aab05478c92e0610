"""A live byte stream of sentences (UDP datagrams, a serial port) parsed as it comes: a
datagram may hold several lines, or half of one; each complete line becomes a sample stamped
with its own time (PASHR) or its arrival, and what is skipped is counted, never raised."""

from __future__ import annotations

from twin.motion.nmea import Assembler, Skip, parse_line

#: [bytes] the longest line kept while waiting for its end (an NMEA sentence is ≤ 82
#: characters; a stream without line ends must not grow a buffer without bound)
MAX_LINE = 256


class MotionStream:
    """Parses a stream's bytes into motion samples.

    Attributes:
        source: what the stream is ("udp 127.0.0.1:10110").
        issues: reason → count of lines skipped so far (`Assembler`'s, plus `too long`).
    """

    def __init__(self, source: str = "stream") -> None:
        self.source = source
        self._assembler = Assembler()
        self._pending = b""
        self._emitted = 0  # samples of the assembler's already handed out

    @property
    def issues(self) -> dict[str, int]:
        return dict(self._assembler.issues)

    def feed(self, data: bytes, now: float) -> list[tuple[float, tuple[float, float, float]]]:
        """The samples the bytes complete: (t [s], (heave [m], roll, pitch [rad])) each, in
        the twin's convention (`twin.motion.nmea`), t the sentence's own time of day or `now`
        [s], the arrival time."""
        lines = (self._pending + data).split(b"\n")
        self._pending = lines.pop()
        if self._pending and _whole(self._pending):
            # a sender that puts one sentence in each datagram without a line end: a tail
            # that already parses (its checksum, or TSS1's fixed layout, checks out) is whole
            lines.append(self._pending)
            self._pending = b""
        if len(self._pending) > MAX_LINE:
            self._assembler.issues["too long"] += 1
            self._pending = b""
        for raw in lines:
            try:
                text = raw.decode("ascii").strip()
            except UnicodeDecodeError:
                self._assembler.issues["malformed"] += 1
                continue
            if text:
                self._assembler.add(text, now, arrival=True)
        a = self._assembler
        out = list(zip(a.times[self._emitted :], a.rows[self._emitted :], strict=True))
        # keep only the newest sample: the next one is checked against its time, and a
        # stream that runs for days holds no history here (its consumer keeps what it needs)
        del a.times[:-1], a.rows[:-1], a.headings[:-1]
        self._emitted = len(a.times)
        return out


def _whole(tail: bytes) -> bool:
    """Whether bytes without a line end are a whole line: ASCII that parses (`parse_line`)."""
    if len(tail) > MAX_LINE:
        return False
    try:
        return not isinstance(parse_line(tail.decode("ascii")), Skip)
    except UnicodeDecodeError:
        return False

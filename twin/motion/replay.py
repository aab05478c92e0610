"""A motion log sent back out as the sentences an MRU sends, over UDP: for demos and tests of
the live path (`twin serve --motion-udp`), `twin motion-replay LOG --udp HOST:PORT --rate HZ`.

Each sample becomes one motion sentence in the chosen format (`$PSXN,23`, `$PASHR` or TSS1)
and, where the log has a heading and the format carries none (TSS1), a `$HEHDT` before it.
Values go out in each format's own convention (`twin.motion.nmea`'s module doc), so reading
them back gives the log's motion to the format's resolution.
"""

from __future__ import annotations

import math
import socket
import time
from collections.abc import Callable, Iterator

import numpy as np

from twin.errors import TwinError
from twin.motion.nmea import sentence
from twin.motion.series import CHANNELS, MotionSeries
from twin.motion.tss1 import format_tss1

FORMATS = ("psxn", "pashr", "tss1")
HEAVE, ROLL, PITCH = CHANNELS.index("heave"), CHANNELS.index("roll"), CHANNELS.index("pitch")


def sentences(series: MotionSeries, fmt: str = "psxn", rate_hz: float | None = None
              ) -> Iterator[tuple[float, str]]:  # fmt: skip
    """(t [s], line) to send for each sample of the series resampled at `rate_hz` (default
    its own rate); absent channels are sent as 0.

    Raises:
        TwinError: an unknown format.
    """
    if fmt not in FORMATS:
        raise TwinError(f"motion replay: format {fmt!r}; allowed: {list(FORMATS)}")
    uniform = series.resampled(rate_hz or series.rate_hz)
    heading = uniform.heading
    # a gap is a NaN in a channel the log has; a channel it lacks is sent as 0 throughout
    sent = [c for c in (HEAVE, ROLL, PITCH) if CHANNELS[c] in series.channels]
    for k, t in enumerate(uniform.time):
        row = np.nan_to_num(uniform.motion[k])
        if not np.all(np.isfinite(uniform.motion[k, sent])) and k:
            continue  # a gap: nothing is sent, as a sensor that dropped out
        h = float(heading[k]) if heading is not None else None
        heave, roll, pitch = float(row[HEAVE]), float(row[ROLL]), float(row[PITCH])
        if fmt == "tss1":
            if h is not None:
                yield float(t), sentence(f"HEHDT,{h:.2f},T")
            yield float(t), format_tss1(heave, roll, pitch)
        elif fmt == "psxn":
            yield float(t), sentence(f"PSXN,23,{math.degrees(roll):.3f},"
                                     f"{-math.degrees(pitch):.3f},{h or 0.0:.2f},{-heave:.3f}")
        else:
            day = (float(t) + (_seconds_of_day(series.start) or 0.0)) % 86_400.0
            hh, rest = divmod(day, 3600.0)
            mm, ss = divmod(rest, 60.0)
            yield float(t), sentence(
                f"PASHR,{int(hh):02d}{int(mm):02d}{ss:06.3f},{h or 0.0:.2f},T,"
                f"{math.degrees(roll):+.2f},{-math.degrees(pitch):+.2f},{heave:+.2f},"
                "0.010,0.010,0.010,1,1")  # fmt: skip


def _seconds_of_day(start: np.datetime64 | None) -> float | None:
    """[s] since midnight UTC of a start time, or None."""
    if start is None:
        return None
    midnight = start.astype("datetime64[D]")
    return float((start - midnight) / np.timedelta64(1, "ns")) * 1e-9


def send(
    series: MotionSeries,
    host: str,
    port: int,
    fmt: str = "psxn",
    rate_hz: float | None = None,
    speed: float = 1.0,
    sleep: Callable[[float], None] = time.sleep,
    clock: Callable[[], float] = time.monotonic,
) -> int:
    """Send the series to host:port over UDP, one datagram per line (CR LF ended), paced at
    `speed` × real time; returns the lines sent.

    Raises:
        TwinError: speed outside [0.1, 100], or a port outside 1-65535.
    """
    if not 0.1 <= speed <= 100.0:
        raise TwinError(f"motion replay: speed {speed!r}; allowed 0.1 to 100")
    if not 1 <= int(port) <= 65535:
        raise TwinError(f"motion replay: port {port!r}; allowed 1-65535")
    sent = 0
    begin = clock()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        for t, line in sentences(series, fmt, rate_hz):
            wait = begin + t / speed - clock()
            if wait > 0:
                sleep(wait)
            sock.sendto((line + "\r\n").encode("ascii"), (host, int(port)))
            sent += 1
    return sent

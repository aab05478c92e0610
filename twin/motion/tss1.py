"""The TSS1 heave-roll-pitch string, the fixed-width format most MRUs send and most gangways
and cranes accept (TSS Ltd, "TSS1 output format"; Teledyne TSS DMS-05/3DMS manuals):

    :XXAAAA MHHHHQMRRRRSMPPPP<CR><LF>

XX the horizontal acceleration (hex, 3.83 cm/s² per unit), AAAA the vertical acceleration
(hex, two's complement, 0.0625 cm/s² per unit), M a sign (space or '-'), HHHH the heave
[cm] positive up, Q the status flag (U/u unaided, G/g GPS aided, H/h heading aided, F/f fully
aided; lower case: settling), RRRR the roll [0.01°] positive port side up and PPPP the pitch
[0.01°] positive bow up. It has no checksum and no time: a receiver stamps its arrival.
"""

from __future__ import annotations

import math
import re
from typing import NamedTuple

#: the string's layout (25 characters before the line end)
PATTERN = re.compile(
    r"^:([0-9A-Fa-f]{2})([0-9A-Fa-f]{4}) ([ \-])(\d{4})([UuGgHhFf])([ \-])(\d{4}) ([ \-])(\d{4})$"
)
#: [m/s²] per unit of the horizontal and vertical accelerations
HORIZONTAL_UNIT, VERTICAL_UNIT = 0.0383, 0.000625
#: the status flags, what each says
STATUS = {"U": "unaided", "G": "GPS aided", "H": "heading aided", "F": "fully aided"}


class Tss1(NamedTuple):
    """One TSS1 record in the twin's convention: heave [m] up, roll [rad] port side up, pitch
    [rad] positive bow down (the string's bow-up pitch negated), accelerations [m/s²], status
    flag, settling (a lower-case flag)."""

    heave: float
    roll: float
    pitch: float
    horizontal_acceleration: float
    vertical_acceleration: float
    status: str
    settling: bool


def parse_tss1(line: str) -> Tss1:
    """A TSS1 string (its line end stripped) as a `Tss1`.

    Raises:
        ValueError: not 25 characters of the layout (the message says which part).
    """
    text = line.rstrip("\r\n")
    match = PATTERN.match(text)
    if match is None:
        raise ValueError(f"not a TSS1 string (':XXAAAA MHHHHQMRRRRSMPPPP', 25 characters): "
                         f"{text[:40]!r}")  # fmt: skip
    xx, aaaa, sh, hhhh, q, sr, rrrr, sp, pppp = match.groups()
    vertical = int(aaaa, 16)
    vertical -= 0x10000 if vertical >= 0x8000 else 0

    def signed(sign: str, digits: str) -> float:
        return -float(digits) if sign == "-" else float(digits)

    return Tss1(
        heave=signed(sh, hhhh) / 100.0,
        roll=math.radians(signed(sr, rrrr) / 100.0),
        pitch=-math.radians(signed(sp, pppp) / 100.0),
        horizontal_acceleration=int(xx, 16) * HORIZONTAL_UNIT,
        vertical_acceleration=vertical * VERTICAL_UNIT,
        status=q.upper(),
        settling=q.islower(),
    )


def format_tss1(heave: float, roll: float, pitch: float, status: str = "F",
                horizontal_acceleration: float = 0.0, vertical_acceleration: float = 0.0) -> str:
    """The TSS1 string (no line end) of heave [m] up, roll [rad] port up and pitch [rad] in the
    twin's convention (bow down positive), rounded to the format's cm and 0.01°; values beyond
    its four digits are clipped to ±99.99 m, ±99.99°.

    Raises:
        ValueError: a value that is not finite, or a status flag outside `STATUS`.
    """
    if not all(math.isfinite(v) for v in (heave, roll, pitch, horizontal_acceleration,
                                          vertical_acceleration)):  # fmt: skip
        raise ValueError("TSS1: every value must be finite")
    if status.upper() not in STATUS:
        raise ValueError(f"TSS1 status {status!r}; allowed: {sorted(STATUS)} "
                         "(lower case: settling)")

    def field(value: float) -> str:
        units = min(abs(round(value)), 9999)
        return f"{'-' if round(value) < 0 else ' '}{units:04d}"

    xx = min(max(round(horizontal_acceleration / HORIZONTAL_UNIT), 0), 0xFF)
    aaaa = min(max(round(vertical_acceleration / VERTICAL_UNIT), -0x8000), 0x7FFF) & 0xFFFF
    roll_field, pitch_field = field(math.degrees(roll) * 100.0), field(-math.degrees(pitch) * 100.0)
    return f":{xx:02X}{aaaa:04X} {field(heave * 100.0)}{status}{roll_field} {pitch_field}"

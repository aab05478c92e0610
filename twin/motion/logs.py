"""Motion logs from files: CSV or Parquet tables, or NMEA/TSS1 text (`twin.motion.nmea`).

A table has a `time` column (seconds, or ISO 8601 UTC times) and any of `surge, sway, heave`
[m] and `roll, pitch, yaw`, each angle in degrees or radians as its suffix says (`roll_deg`,
`pitch_rad`) or, bare, as the sensor file's `angle_unit` (default degrees). Values are in
the sensor's own convention; the sensor file's signs turn them into the twin's
(`twin.motion.sensor.Sensor`). Rows with a missing or non-finite time, or out of order, are
skipped and counted; a missing value leaves its channel NaN at that row.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from twin.errors import TwinError
from twin.motion.nmea import flag_quality, read_nmea
from twin.motion.sensor import Sensor
from twin.motion.series import CHANNELS, MotionSeries

#: [bytes] the largest log read (a day at 50 Hz as CSV is about 40 MB)
MAX_LOG = 256 * 1024 * 1024
ANGLES = ("roll", "pitch", "yaw")


def read_motion(path: str | Path, sensor: Sensor | None = None,
                rate_hz: float | None = None) -> MotionSeries:
    """A motion log by its content: Parquet (its magic bytes), NMEA/TSS1 text (lines that
    start with `$`, `:` or a time stamp and `$`/`:`), else a CSV table; the sensor's signs
    applied (`Sensor.to_vessel`; default `Sensor()`).

    Raises:
        TwinError: a missing or oversized file, a table without `time` or without any motion
            column, or no sample left (each named with what is allowed).
    """
    path = Path(path)
    sensor = sensor or Sensor()
    if not path.is_file():
        raise TwinError(f"motion log {path}: no such file")
    if path.stat().st_size > MAX_LOG:
        raise TwinError(f"motion log {path}: {path.stat().st_size} bytes; allowed ≤ {MAX_LOG}")
    with path.open("rb") as handle:
        head = handle.read(4096)
    if head.startswith(b"PAR1"):
        series = read_motion_log(path, sensor)
    elif _looks_like_nmea(head):
        with path.open(encoding="ascii", errors="replace") as lines:
            series = sensor.to_vessel(read_nmea(lines, rate_hz=rate_hz, source=path.name))
    else:
        series = read_motion_log(path, sensor)
    if len(series) < 2:
        raise TwinError(f"motion log {path}: {len(series)} usable samples (skipped: "
                        f"{series.issues or 'none'}); a log needs two or more")  # fmt: skip
    return series


def _looks_like_nmea(head: bytes) -> bool:
    """Whether a file's first line is a sentence or TSS1 string, maybe after a time stamp."""
    first = head.split(b"\n", 1)[0].strip()
    return first[:1] in (b"$", b":") or b" $" in first or b" :" in first


def read_motion_log(path: str | Path, sensor: Sensor | None = None) -> MotionSeries:
    """A CSV or Parquet motion table (module doc) as a `MotionSeries` in the twin's convention.

    Raises:
        TwinError: no `time` column, no motion column, an unknown angle suffix.
    """
    path = Path(path)
    sensor = sensor or Sensor()
    try:
        with path.open("rb") as handle:  # Parquet by its magic bytes, whatever the file's name
            parquet = handle.read(4) == b"PAR1"
        table = pd.read_parquet(path) if parquet else pd.read_csv(path)
    except (OSError, ValueError, ImportError) as error:
        raise TwinError(f"motion log {path}: cannot read it as a table ({error})") from None
    table.columns = [str(c).strip().lower() for c in table.columns]
    if "time" not in table.columns:
        raise TwinError(f"motion log {path}: no `time` column; columns: {list(table.columns)}")
    motion = np.full((len(table), 6), np.nan)
    found = []
    for c, name in enumerate(CHANNELS):
        column, scale = _column(table, name, sensor.angle_unit)
        if column is not None:
            motion[:, c] = pd.to_numeric(table[column], errors="coerce").to_numpy() * scale
            found.append(name)
    if not found:
        raise TwinError(f"motion log {path}: no motion column; allowed: {list(CHANNELS)} (angles "
                        "with _deg or _rad)")  # fmt: skip
    seconds, start = _times(table["time"], path)
    good = np.isfinite(seconds)
    issues: dict[str, int] = {}
    if not good.all():
        issues["no time"] = int(np.count_nonzero(~good))
    seconds, motion = seconds[good], motion[good]
    # a row counts if it is later than every row before it: a step back or a repeat is dropped
    order = seconds > np.maximum.accumulate(np.r_[-np.inf, seconds[:-1]])
    if not order.all():
        issues["out of order"] = int(np.count_nonzero(~order))
    seconds, motion = seconds[order], motion[order]
    issues |= flag_quality(motion)
    t0 = float(seconds[0]) if seconds.size else 0.0
    series = MotionSeries(seconds - t0, motion, tuple(found), start, issues, path.name)
    return sensor.to_vessel(series)


def _column(table: pd.DataFrame, name: str, angle_unit: str) -> tuple[str | None, float]:
    """The table's column for a channel and its factor into [m] or [rad]."""
    if name in ANGLES:
        for suffix, unit in (("_deg", "deg"), ("_rad", "rad"), ("", angle_unit)):
            if name + suffix in table.columns:
                return name + suffix, np.pi / 180.0 if unit == "deg" else 1.0
        return None, 1.0
    return (name, 1.0) if name in table.columns else (None, 1.0)


def _times(column: pd.Series, path: Path) -> tuple[np.ndarray, np.datetime64 | None]:
    """(seconds (N,) with NaN where unreadable, UTC start or None) of a time column."""
    numbers = pd.to_numeric(column, errors="coerce")
    if numbers.notna().mean() > 0.5:
        return numbers.to_numpy(dtype=float), None
    stamps = pd.to_datetime(column, errors="coerce", utc=True)
    if stamps.notna().sum() == 0:
        raise TwinError(f"motion log {path}: `time` is neither seconds nor ISO 8601 times")
    first = stamps.dropna().iloc[0]
    seconds = (stamps - first).dt.total_seconds().to_numpy(dtype=float)
    return seconds, np.datetime64(first.tz_convert(None), "ns")

"""Measured base motion: a stored motion log (`twin.motion`) as a run's base motion, the
question "would each planner have held the gangway during yesterday's 14:00-15:00 transfer?".

A log is stored once, by the hash of its content (`store_log`), in the folder the environment
variable `TWIN_MOTION_LOGS` names (the server sets it to `<data-dir>/motion_logs` before its
workers start, so every process of a local cluster reads the same files), else
`data/motion_logs`. A scenario names it, `base_motion={"source": "log", "log": ID,
"offset": s}`; its run samples the measured motion at the sensor, moved to the mechanism's
mount by rigid-body kinematics (`twin.motion.mount.motion_at`), where the synthesised sea's
motion enters otherwise: one engine, another source of base poses.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import tempfile
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from twin.errors import TwinError
from twin.motion.logs import read_motion
from twin.motion.mount import motion_at
from twin.motion.series import CHANNELS, MotionSeries
from twin.vessel import Mount

#: the environment variable naming the log folder
LOG_DIR_ENV = "TWIN_MOTION_LOGS"
#: a log's ID: the first 16 hex digits of the SHA-256 of its stored bytes
LOG_ID = re.compile(r"^[0-9a-f]{16}$")
#: [bytes] most the stored logs may take together (an hour of six channels at 50 Hz is 12 MB):
#: there is no DELETE, so an upload past it is refused rather than filling the disk
MAX_STORED = 2 * 1024**3


def log_dir() -> Path:
    """The folder of stored logs (`LOG_DIR_ENV`, else data/motion_logs)."""
    return Path(os.environ.get(LOG_DIR_ENV, "data/motion_logs"))


def store_log(series: MotionSeries, sensor_position: tuple[float, float, float] = (0.0, 0.0, 0.0),
              directory: Path | None = None) -> str:  # fmt: skip
    """Store a series (in the twin's convention) measured at `sensor_position` [m] (vessel
    frame, from the centre of motion); returns its ID. Storing the same log twice gives the
    same ID and one file.

    Raises:
        TwinError: fewer than two samples, or no heave, roll or pitch.
    """
    if len(series) < 2:
        raise TwinError("motion log: two samples or more needed")
    if not {"heave", "roll", "pitch"} & set(series.channels):
        raise TwinError(f"motion log: channels {list(series.channels)}; at least one of heave, "
                        "roll, pitch needed")  # fmt: skip
    meta = {"channels": list(series.channels), "source": series.source, "issues": series.issues,
            "start": None if series.start is None else str(series.start),
            "sensor_position": [float(v) for v in sensor_position], "samples": len(series),
            "duration": series.duration, "rate_hz": series.rate_hz}  # fmt: skip
    buffer = io.BytesIO()
    np.savez(buffer, time=series.time, motion=series.motion, meta=np.array(json.dumps(meta)))
    data = buffer.getvalue()
    key = hashlib.sha256(data).hexdigest()[:16]
    folder = directory or log_dir()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{key}.npz"
    if not path.exists():
        held = sum(f.stat().st_size for f in folder.glob("*.npz"))
        if held + len(data) > MAX_STORED:
            raise TwinError(f"motion logs: the store holds {held / 2**20:.0f} MiB and this log "
                            f"{len(data) / 2**20:.1f} MiB; allowed ≤ {MAX_STORED / 2**20:.0f} "
                            "MiB together")  # fmt: skip
        tmp = path.with_suffix(".tmp")
        tmp.write_bytes(data)
        tmp.replace(path)
    return key


def store_samples(
    t: np.ndarray, motion: np.ndarray, start: np.datetime64 | None, name: str,
    sensor_position: tuple[float, float, float],
) -> str:
    """`store_log` of samples: times t (N,) [s], motion (N, 6) [m, rad] in `CHANNELS` order
    (NaN columns: not measured), the UTC start if known; its ID.

    Raises:
        TwinError: times not strictly increasing, shapes other than (N,) and (N, 6), or what
            `store_log` refuses.
    """
    channels = tuple(c for i, c in enumerate(CHANNELS) if not np.all(np.isnan(motion[:, i])))
    series = MotionSeries(t - t[0], motion, channels, start, {}, name)
    return store_log(series, sensor_position)


#: file name endings an uploaded file keeps (the readers sniff the content anyway)
SUFFIXES = (".csv", ".parquet", ".pq", ".txt", ".nmea", ".log")


def read_upload(data: bytes, name: str) -> MotionSeries:
    """The motion series of an uploaded file's bytes named `name`, read as `twin motion-log`
    reads a file (`twin.motion.logs.read_motion`, the format sniffed): a task for a bounded
    child (`twin.web.upload_worker`), so pandas' cost stays out of the server's process.

    Raises:
        TwinError: what `read_motion` refuses (no `time` column, no motion, no usable sample).
    """
    suffix = Path(name).suffix.lower()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"upload{suffix if suffix in SUFFIXES else '.txt'}"
        path.write_bytes(data)
        return read_motion(path)


def log_path(key: str, directory: Path | None = None) -> Path:
    """The stored file of a log ID.

    Raises:
        TwinError: not an ID, or no such log stored.
    """
    if not LOG_ID.match(key):
        raise TwinError(f"motion log {key!r}: not a log ID (16 hex digits)")
    path = (directory or log_dir()) / f"{key}.npz"
    if not path.is_file():
        raise TwinError(f"motion log {key!r}: not stored (upload it: POST /api/motion-logs)")
    return path


@lru_cache(maxsize=8)
def _load(path: Path, mtime: float) -> tuple[MotionSeries, tuple[float, float, float]]:
    del mtime  # part of the cache key: a replaced file is read again
    with np.load(path, allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
        start = None if meta["start"] is None else np.datetime64(meta["start"])
        series = MotionSeries(data["time"], data["motion"], tuple(meta["channels"]), start,
                              meta["issues"], meta["source"])  # fmt: skip
    return series, tuple(meta["sensor_position"])


def describe_log(key: str, directory: Path | None = None) -> dict[str, Any]:
    """A stored log's summary (id, name, samples, duration [s], median rate_hz, channels,
    issues, UTC start, sensor_position [m]) from its header alone: a list of logs reads no
    samples.

    Raises:
        TwinError: not an ID, or no such log stored.
    """
    with np.load(log_path(key, directory), allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
    return {"id": key, "name": meta["source"], "samples": meta["samples"],
            "duration": meta["duration"], "rate_hz": meta["rate_hz"],
            "channels": meta["channels"], "issues": meta["issues"],
            "start": None if meta["start"] is None else f"{meta['start']}Z",
            "sensor_position": meta["sensor_position"]}  # fmt: skip


def load_log(key: str, directory: Path | None = None
             ) -> tuple[MotionSeries, tuple[float, float, float]]:  # fmt: skip
    """(the series, its sensor position [m]) of a stored log (read once per process)."""
    path = log_path(key, directory)
    return _load(path, path.stat().st_mtime)


class MeasuredMotion:
    """A run's base motion from a stored log: the mount's pose at time t is the log's motion
    at `offset` + t [s] moved from the sensor to the mount.

    Args:
        key: the log's ID; mount: the mechanism's mount; offset: [s] where in the log the
            run starts; duration: [s] the run's, checked against the log.

    Raises:
        TwinError: no such log, or a run that would read past the log's end (with both
            lengths).
    """

    #: a stored log's poses may be sampled any number of steps ahead
    horizon: int | None = None

    def __init__(self, key: str, mount: Mount, offset: float = 0.0, duration: float = 0.0):
        self.series, self.sensor_position = load_log(key)
        self.mount, self.offset = mount, float(offset)
        if self.offset < 0 or self.offset + duration > self.series.duration + 1e-9:
            raise TwinError(f"base motion log {key}: the run reads {self.offset:g}-"
                            f"{self.offset + duration:g} s, the log lasts "
                            f"{self.series.duration:g} s")  # fmt: skip
        # a sensor dropout inside the run would be bridged by a straight line: refused
        gaps = self.series.gaps()
        crossed = gaps[(gaps[:, 1] > self.offset) & (gaps[:, 0] < self.offset + duration)]
        if crossed.size:
            raise TwinError(f"base motion log {key}: the run reads {self.offset:g}-"
                            f"{self.offset + duration:g} s, across a gap without samples "
                            f"from {crossed[0, 0]:g} to {crossed[0, 1]:g} s (a step over "
                            f"{self.series.gap_limit():g} s); choose an offset and duration "
                            "inside the samples")  # fmt: skip

    def poses(self, t: np.ndarray) -> np.ndarray:
        """(N, 6) [m, rad] the mount's base poses at run times t (N,) [s]: each channel
        interpolated linearly (absent channels 0), then `motion_at`; NaN past the log's end
        (a live session that runs on: the engine holds the last pose and counts it), not
        the last sample repeated as if measured."""
        at = np.asarray(t, dtype=float) + self.offset
        poses = poses_at(self.series.time, self.series.motion, at, self.sensor_position,
                         self.mount)  # fmt: skip
        poses[(at < self.series.time[0]) | (at > self.series.time[-1] + 1e-9)] = np.nan
        return poses


def poses_at(time: np.ndarray, motion: np.ndarray, at: np.ndarray,
             sensor_position: tuple[float, float, float], mount: Mount) -> np.ndarray:  # fmt: skip
    """(N, 6) [m, rad] a mount's base poses at times `at` (N,) [s] from measured samples:
    times (M,) [s] increasing, motion (M, 6) [m, rad] at the sensor in `CHANNELS` order (NaN:
    not measured), each channel interpolated linearly (held at its first and last value
    outside the samples; a channel with fewer than two finite samples is 0), then moved from
    `sensor_position` [m] to the mount (`motion_at`). The one interpolation of a stored log
    and a live stream."""
    sampled = np.zeros((at.size, 6))
    for c in range(6):
        column = motion[:, c]
        good = np.isfinite(column)
        if np.count_nonzero(good) >= 2:
            sampled[:, c] = np.interp(at, time[good], column[good])
    return motion_at(sampled, sensor_position, mount.lever_arm, mount.yaw)

"""Six degrees of freedom of measured motion against time, and what reading them skipped."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from twin.errors import TwinError

#: the six channels, in the vessel frame (x bow, y port, z up; docs/frames.md): surge, sway,
#: heave [m] of the measured point, roll, pitch, yaw [rad] (Z-Y-X, seed 000 eq (3))
CHANNELS = ("surge", "sway", "heave", "roll", "pitch", "yaw")


@dataclass(frozen=True)
class MotionSeries:
    """Measured motion, one row per sample, in the twin's frames and units.

    Attributes:
        time: (N,) [s] since `start`, strictly increasing.
        motion: (N, 6) [m, m, m, rad, rad, rad] surge, sway, heave, roll, pitch, yaw (`CHANNELS`)
            of the point the sensor reports; NaN in a channel the source does not give.
        channels: the measured channels' names (a subset of `CHANNELS`, in their order).
        start: UTC time of t = 0 (numpy datetime64[ns]), or None where the source has none.
        issues: reason → count of lines or samples skipped or flagged (empty: none).
        source: what it was read from (a file name, "udp 127.0.0.1:10110", …).
        heading: (N,) [deg] compass heading where the source gives one, else None; `yaw` is
            then its oscillation about the mean, counter-clockwise.
    """

    time: np.ndarray
    motion: np.ndarray
    channels: tuple[str, ...]
    start: np.datetime64 | None = None
    issues: dict[str, int] = field(default_factory=dict)
    source: str = ""
    heading: np.ndarray | None = None

    def __post_init__(self) -> None:
        t, m = np.asarray(self.time, dtype=float), np.asarray(self.motion, dtype=float)
        if t.ndim != 1 or m.shape != (t.size, 6):
            raise TwinError(f"motion series: time (N,) and motion (N, 6) needed, got "
                            f"{t.shape} and {m.shape}")  # fmt: skip
        if t.size > 1 and not np.all(np.diff(t) > 0):
            raise TwinError("motion series: times must increase strictly")
        unknown = set(self.channels) - set(CHANNELS)
        if unknown:
            raise TwinError(f"motion series: unknown channels {sorted(unknown)}; "
                            f"allowed: {list(CHANNELS)}")  # fmt: skip
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "motion", m)

    def __len__(self) -> int:
        return int(self.time.size)

    @property
    def duration(self) -> float:
        """[s] from the first sample to the last (0 for fewer than two)."""
        return float(self.time[-1] - self.time[0]) if len(self) > 1 else 0.0

    @property
    def rate_hz(self) -> float:
        """[Hz] the median sample rate (0 for fewer than two samples)."""
        return float(1.0 / np.median(np.diff(self.time))) if len(self) > 1 else 0.0

    def window(self, t0: float, t1: float) -> MotionSeries:
        """The samples with t0 ≤ t < t1 [s], times kept (not shifted)."""
        keep = (self.time >= t0) & (self.time < t1)
        heading = None if self.heading is None else self.heading[keep]
        return replace(self, time=self.time[keep], motion=self.motion[keep], heading=heading)

    def gap_limit(self, max_gap: float | None = None) -> float:
        """[s] the longest step between samples that is not a gap: `max_gap`, default 5
        median steps (a sensor that skips a sample or two has not dropped out)."""
        if max_gap is not None:
            return float(max_gap)
        return 5.0 * float(np.median(np.diff(self.time))) if len(self) > 1 else 0.0

    def gaps(self, max_gap: float | None = None) -> np.ndarray:
        """(G, 2) [s] (last sample before, first after) of each gap (`gap_limit`)."""
        wide = np.flatnonzero(np.diff(self.time) > self.gap_limit(max_gap))
        return np.c_[self.time[wide], self.time[wide + 1]]

    def resampled(self, rate_hz: float, max_gap: float | None = None) -> MotionSeries:
        """The series on a uniform grid of `rate_hz` [Hz] from its first sample, each channel
        interpolated linearly; a grid point inside a gap longer than `max_gap` [s] (default 5
        median steps) is NaN, and the gaps are counted in `issues["gap"]`.

        Raises:
            TwinError: fewer than two samples, or a rate that is not finite and > 0.
        """
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise TwinError(f"motion series: rate {rate_hz!r} Hz; allowed: finite and > 0")
        if len(self) < 2:
            raise TwinError("motion series: resampling needs two samples or more")
        step = np.diff(self.time)
        gap = self.gap_limit(max_gap)
        # a millionth of a step of slack: 3.98 s at 1/0.02 Hz is 199 steps, not 198.999…
        steps = int(np.floor(self.duration * rate_hz + 1e-6))
        grid = self.time[0] + np.arange(steps + 1) / rate_hz
        out = np.full((grid.size, 6), np.nan)
        for c in range(6):
            good = np.isfinite(self.motion[:, c])
            if np.count_nonzero(good) >= 2:
                out[:, c] = np.interp(grid, self.time[good], self.motion[good, c])
        cell = np.clip(np.searchsorted(self.time, grid, side="right") - 1, 0, len(self) - 2)
        in_gap = step[cell] > gap
        out[in_gap] = np.nan
        issues = dict(self.issues)
        if np.any(step > gap):
            issues["gap"] = issues.get("gap", 0) + int(np.count_nonzero(step > gap))
        heading = None
        if self.heading is not None:
            heading = np.degrees(np.interp(grid, self.time, np.unwrap(np.radians(self.heading))))
            heading %= 360.0
        return replace(self, time=grid, motion=out, issues=issues, heading=heading)

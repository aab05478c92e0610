"""Where the motion sensor sits on the hull and how its channels are signed (`Sensor`).

An MRU reports its own point's translations and the hull's angles in its maker's convention:
Kongsberg's `$PSXN,23` gives heave positive down and pitch positive bow up, the TSS1 string
heave positive up. The twin's vessel frame is x to the bow, y to port, z up (docs/frames.md),
with roll positive port side up and pitch positive bow down (right-handed about y). A sensor
file states the sign of each channel once; the default (`Sensor()`) is a sensor at the centre
of motion already in the twin's convention.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from twin.errors import TwinError
from twin.motion.series import CHANNELS, MotionSeries


class Sensor(BaseModel):
    """A motion sensor on the hull.

    Attributes:
        position: [m] the sensor's point in the vessel frame (x bow, y port, z up) from the
            centre of motion, where `surge`, `sway` and `heave` are measured.
        signs: channel → +1 or −1: the factor that turns the sensor's channel into the twin's
            (e.g. heave −1 for a sensor whose heave is positive down).
        angle_unit: "deg" or "rad": the unit of angle columns without a suffix.
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    position: tuple[float, float, float] = Field(
        (0.0, 0.0, 0.0), description="[m] the sensor in the vessel frame from the centre of motion"
    )
    signs: dict[str, float] = Field(
        default_factory=lambda: dict.fromkeys(CHANNELS, 1.0),
        description="channel → +1 or −1 into the twin's convention (x bow, y port, z up)",
    )
    angle_unit: str = Field("deg", pattern="^(deg|rad)$", description="unit of bare angles")

    def model_post_init(self, context: object, /) -> None:
        unknown = set(self.signs) - set(CHANNELS)
        if unknown:
            raise TwinError(f"sensor: unknown channels {sorted(unknown)}; "
                            f"allowed: {list(CHANNELS)}")  # fmt: skip
        bad = {k: v for k, v in self.signs.items() if v not in (1.0, -1.0)}
        if bad:
            raise TwinError(f"sensor: signs {bad}; allowed: +1 or -1")
        self.signs.update({c: 1.0 for c in CHANNELS if c not in self.signs})

    @classmethod
    def load(cls, path: str | Path) -> Sensor:
        """A sensor file (YAML or JSON: `position`, `signs`, `angle_unit`).

        Raises:
            TwinError: the file cannot be read, or a field is out of range (named).
        """
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
            data = json.loads(text) if path.suffix == ".json" else yaml.safe_load(text)
            return cls.model_validate(data or {})
        except (OSError, ValueError, yaml.YAMLError) as error:
            if isinstance(error, ValidationError):
                raise TwinError(f"sensor file {path}: {error.errors()[0]['msg']} at "
                                f"{'.'.join(map(str, error.errors()[0]['loc']))}") from None
            raise TwinError(f"sensor file {path}: {error}") from None

    def factors(self) -> np.ndarray:
        """(6,) the sign of each channel, in `CHANNELS` order."""
        return np.array([self.signs[c] for c in CHANNELS])

    def to_vessel(self, series: MotionSeries) -> MotionSeries:
        """The series with the sensor's signs applied (the twin's convention); NaN stays NaN."""
        return replace(series, motion=series.motion * self.factors())

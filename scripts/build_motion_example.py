"""Build assets/motion/: a synthetic MRU log of the twin's own vessel and sea, for the README's
recorded-log path, `twin motion-replay` demos and tests.

Synthetic on purpose (say so wherever it is used): the `sov` hull's motion by the RAO path in
a JONSWAP sea of Hs 2.0 m, Tp 8 s from 30° off the starboard bow (Scenario heading 150°), as
an MRU 15 m forward, 4 m to starboard and 8 m up reports it in the Kongsberg `$PSXN,23`
convention (heave positive down, roll positive port up, pitch positive bow up, degrees), 30
minutes at 5 Hz from 2026-08-01 14:00 UTC, with 1 mm / 0.005° of white sensor noise and a
0.02° roll bias. `sensor.yaml` states that sensor.

    .venv/bin/python scripts/build_motion_example.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from twin.sim.base_motion import BaseMotion
from twin.sim.scenario import Scenario
from twin.vessel.motion import base_pose, superpose

OUT = Path(__file__).resolve().parents[1] / "assets" / "motion"
SENSOR = (15.0, -4.0, 8.0)
SEA = {"hs": 2.0, "tp": 8.0, "heading": 150.0, "seed": 7}
RATE, MINUTES = 5.0, 30


def main() -> None:
    """Write mru_example.csv and sensor.yaml."""
    duration = MINUTES * 60.0
    motion = BaseMotion.of(Scenario(**SEA, duration=duration))
    t = np.arange(0.0, duration, 1.0 / RATE)
    hull = superpose(t, motion.omega_e, motion.amplitude)
    at_sensor = base_pose(hull, SENSOR)
    rng = np.random.default_rng(11)
    heave = at_sensor[:, 2] - SENSOR[2] + rng.normal(0.0, 0.001, t.size)
    roll = np.degrees(at_sensor[:, 3]) + 0.02 + rng.normal(0.0, 0.005, t.size)
    pitch = np.degrees(at_sensor[:, 4]) + rng.normal(0.0, 0.005, t.size)
    times = pd.Timestamp("2026-08-01T14:00:00Z") + pd.to_timedelta(t, unit="s")
    OUT.mkdir(parents=True, exist_ok=True)
    pd.DataFrame({
        "time": times.strftime("%Y-%m-%dT%H:%M:%S.%fZ").str[:-4] + "Z",
        "heave": np.round(-heave, 4), "roll_deg": np.round(roll, 4),
        "pitch_deg": np.round(-pitch, 4),
    }).to_csv(OUT / "mru_example.csv", index=False)  # fmt: skip
    (OUT / "sensor.yaml").write_text(
        "# the MRU of mru_example.csv (scripts/build_motion_example.py): where it sits on the\n"
        "# hull [m] (vessel frame: x bow, y port, z up, from the centre of motion) and how its\n"
        "# channels turn into the twin's (Kongsberg's convention: heave down, pitch bow up)\n"
        f"position: [{SENSOR[0]}, {SENSOR[1]}, {SENSOR[2]}]\n"
        "signs: {heave: -1, pitch: -1}\n"
        "angle_unit: deg\n"
    )


if __name__ == "__main__":
    main()

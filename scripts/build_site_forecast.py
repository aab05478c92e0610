"""Build assets/site/forecast_example_46097_2019_08_20.csv: a forecast-shaped example from the
shipped NDBC 46097 record.

Not a forecast: five days of the buoy's own hourly sea states (20-24 August 2019, a storm on the
21st-23rd), taken every 3 hours and written in the form a forecast comes in (an `issued` column,
then time, hs, tp, direction), so the forecast view (`twin workability`, the browser's
Workability page) can be tried without a forecast provider. Deterministic: running it again
writes the same file (tests/site/test_records.py checks the shipped one).

    python scripts/build_site_forecast.py
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from twin.assets import asset_path
from twin.site import read_record

SOURCE = "46097h2019_08.txt"
TARGET = "forecast_example_46097_2019_08_20.csv"
#: the first forecast step (the record's hourly sea states are at 10 minutes past the hour)
ISSUED = np.datetime64("2019-08-20T00:10", "ns")
#: [h] the step and the number of steps: 5 days at 3 h, as a short-term workability forecast
STEP_HOURS, STEPS = 3, 40


def build() -> pd.DataFrame:
    """The example's rows: the record's sea states at ISSUED + 3 h × k, k = 0 … STEPS − 1."""
    record = read_record(asset_path("site", SOURCE))
    wanted = ISSUED + np.arange(STEPS) * np.timedelta64(STEP_HOURS, "h")
    assert record.time is not None and record.direction is not None  # 46097 reports MWD
    rows = np.searchsorted(record.time, wanted)
    if np.any(rows >= record.n) or np.any(record.time[np.minimum(rows, record.n - 1)] != wanted):
        raise ValueError(f"{SOURCE} lacks a sea state at some of the steps from {ISSUED}")
    stamp = pd.DatetimeIndex(wanted).strftime("%Y-%m-%dT%H:%MZ")
    return pd.DataFrame({
        "issued": [stamp[0]] * STEPS, "time": stamp, "hs": record.hs[rows],
        "tp": record.tp[rows], "direction": record.direction[rows],
    })  # fmt: skip


if __name__ == "__main__":
    path = asset_path("site", TARGET)
    build().to_csv(path, index=False)
    print(f"wrote {path}")

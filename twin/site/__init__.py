"""Site data: a site's wave record (buoy, time series, scatter diagram, forecast), the compass
conventions of its directions, and weather windows.

Layer: above `twin.sea` and `twin.vessel` (it speaks their conventions), below `twin.sim` (whose
`twin.runs.workability` turns a record into workability on the one engine).

    record = read_record(asset_path("site", "46097h2019_08.txt"))   # NDBC, sniffed
    beta = relative_heading(record.direction, vessel_heading=90.0)  # Scenario.heading [deg]
    stats = window_stats(operable, record_step(record.time), 12.0, times=record.time)
"""

from __future__ import annotations

from twin.site.heading import relative_heading, vessel_heading_for, wave_from
from twin.site.records import (
    SiteRecord,
    read_forecast,
    read_ndbc,
    read_record,
    read_scatter,
    read_timeseries,
)
from twin.site.windows import WindowStats, record_step, window_stats

__all__ = [
    "SiteRecord",
    "WindowStats",
    "read_forecast",
    "read_ndbc",
    "read_record",
    "read_scatter",
    "read_timeseries",
    "record_step",
    "relative_heading",
    "vessel_heading_for",
    "wave_from",
    "window_stats",
]

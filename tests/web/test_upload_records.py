"""`twin.web.upload_records` (issue 43): the text scan that prices an upload before any parser
sees it, the record's own checks, and the columns a job stores."""

from __future__ import annotations

import numpy as np
import pytest

from twin.site import SiteRecord
from twin.web.upload_records import (
    MAX_COLUMNS,
    MAX_GRID_STEPS,
    MAX_LINES,
    UploadRefused,
    check_grid,
    pack_record,
    prescan,
    unpack_record,
)


def test_prescan_counts_lines_and_first_line_columns() -> None:
    """Lines (a last one without a newline too) and the first line's columns, by commas or,
    for NDBC, white space."""
    scan = prescan("time,hs,tp\n1,2,3\n4,5,6")
    assert (scan.lines, scan.columns, scan.bytes) == (3, 3, 22)
    assert prescan("time,hs,tp\n1,2,3\n4,5,6\n").lines == 3
    assert prescan("#YY  MM DD hh mm WVHT DPD MWD\n").columns == 8


@pytest.mark.parametrize(
    ("text", "limit"),
    [
        ("hs," + ",".join(str(4 + i / 100) for i in range(MAX_COLUMNS)) + "\n", "MAX_COLUMNS"),
        ("time,hs,tp\n" + "x\n" * MAX_LINES, "MAX_LINES"),
        ("time,hs,tp\n2020-01-01,1,8\x00\n", "text"),
    ],
)
def test_prescan_refuses_what_is_over_naming_the_limit(text: str, limit: str) -> None:
    """Issue 43 finding 1 and 5: too many columns (pandas' cost is their square), too many
    lines, a NUL: refused by the scan, naming the limit."""
    with pytest.raises(UploadRefused) as refused:
        prescan(text)
    assert refused.value.limit == limit
    assert limit in str(refused.value) or "NUL character on line 2" in str(refused.value)


def test_a_grid_denser_than_the_rows_is_refused() -> None:
    """Issue 43 finding 2, the server's own bound whatever the reader allows: 101 rows 1 ns
    apart and one a second later make a grid of 1e9 steps (span / median step), over
    `MAX_GRID_STEPS`; an hourly year with a month's gap is not."""
    ns = np.concatenate([np.arange(101), [1_000_000_000]]).astype("datetime64[ns]")
    dense = SiteRecord(hs=np.ones(102), tp=np.full(102, 8.0), time=ns)
    with pytest.raises(UploadRefused, match="MAX_GRID_STEPS") as refused:
        check_grid(dense)
    assert refused.value.limit == "MAX_GRID_STEPS"
    hours = np.arange(8760 - 720).astype("timedelta64[h]") + np.datetime64("2020-01-01", "ns")
    hours[4000:] += np.timedelta64(720, "h")
    check_grid(SiteRecord(hs=np.ones(hours.size), tp=np.full(hours.size, 8.0), time=hours))
    assert MAX_GRID_STEPS > 8760


def test_packed_columns_read_back_equal() -> None:
    """What a job stores (`pack_record`) reads back to the same record, times to the
    nanosecond, a missing column still missing, the skipped counts kept."""
    time = np.datetime64("2020-01-01T00:00:00.000000001") + np.arange(3).astype(
        "timedelta64[h]")  # fmt: skip
    record = SiteRecord(hs=[1.0, 2.0, 3.5], tp=[8.0, 9.0, 10.0], time=time,
                        direction=[0.0, 90.0, 359.5], source="a.csv (timeseries)",
                        skipped={"hs missing": 1})  # fmt: skip
    back = unpack_record(pack_record(record))
    assert np.array_equal(back.time, record.time) and back.time.dtype == record.time.dtype
    for name in ("hs", "tp", "direction"):
        assert np.array_equal(getattr(back, name), getattr(record, name))
    assert back.heading is None and back.weight is None
    assert (back.source, back.skipped, back.kind) == (record.source, record.skipped, "timeseries")

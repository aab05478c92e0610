"""Site record readers: hand-made NDBC (historical and real-time layouts), time-series, Parquet,
scatter and forecast files, and a real NDBC real-time file; missing values skipped and counted
only where needed; duplicates and too-fine steps refused; malformed input named by file, line
and column."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.site.support import script_module
from twin.assets import asset_path
from twin.errors import TwinError
from twin.site import read_forecast, read_ndbc, read_record, read_scatter, read_timeseries

NDBC = """\
#YY  MM DD hh mm WDIR WSPD GST  WVHT   DPD   APD MWD   PRES
#yr  mo dy hr mn degT m/s  m/s     m   sec   sec deg    hPa
2019 08 01 01 10 222  1.7 99.0  1.07  8.30 99.00 295 1017.2
2019 08 01 00 10 231  1.6 99.0  1.20  9.10 99.00 300 1017.3
2019 08 01 02 10 227  1.6 99.0 99.00 99.00 99.00 999 1017.2
2019 08 01 03 10 227  1.6 99.0  1.30    MM 99.00 310 1017.2
2019 08 01 04 10 227  1.6 99.0  1.40 10.00 99.00 999 1017.2
2019 08 01 05 10 227  1.6 99.0  1.50 11.00 99.00 360 1017.2
"""


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_ndbc_keeps_every_row_with_hs_and_tp_and_counts_each_missing_marker(
    tmp_path: Path,
) -> None:
    """Without a direction required, every row with WVHT and DPD is kept (a direction missing on
    one of them leaves the column out, noted); with it required, that row is skipped as well."""
    record = read_ndbc(write(tmp_path, "b.txt", NDBC))
    assert record.n == 4  # 00:10, 01:10, 04:10 (no MWD) and 05:10, sorted by time
    np.testing.assert_allclose(record.hs, [1.20, 1.07, 1.40, 1.50])
    np.testing.assert_allclose(record.tp, [9.10, 8.30, 10.00, 11.00])
    assert record.direction is None and any("direction missing on 1" in n for n in record.notes)
    assert record.time[0] == np.datetime64("2019-08-01T00:10")
    # the all-missing row counts once, under its first missing column; MM is missing too
    assert record.skipped == {"WVHT missing": 1, "DPD missing": 1}
    directed = read_ndbc(tmp_path / "b.txt", require=["direction"])
    assert directed.n == 3 and directed.skipped == {**record.skipped, "MWD missing": 1}
    np.testing.assert_allclose(directed.direction, [300.0, 295.0, 0.0])  # 360° is north, 0°
    assert record.kind == "timeseries" and read_record(tmp_path / "b.txt").n == 4


def test_ndbc_old_header_with_two_digit_years_and_no_minutes(tmp_path: Path) -> None:
    """An old NDBC file (YY header, no minute column) reads 19YY at minute 0."""
    text = "YY MM DD hh WD   WSPD GST  WVHT  DPD   APD  MWD\n" \
           "96 01 01 00 270  5.0 6.0  2.10  12.0  8.0  280\n"  # fmt: skip
    record = read_record(write(tmp_path, "old.txt", text))
    assert record.time[0] == np.datetime64("1996-01-01T00:00") and record.hs[0] == 2.1


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("2019 08 01 06 10 227  1.6 99.0  1.50 11.00 99.00 360", "line 9: 12 fields"),
        ("2019 08 01 06 10 227  1.6 99.0  1.5x 11.00 99.00 360 1017.2", "line 9, column WVHT"),
        ("2019 13 01 06 10 227  1.6 99.0  1.50 11.00 99.00 360 1017.2", "line 9"),
        ("2019 08 01 06 10 227  1.6 99.0 -1.50 11.00 99.00 360 1017.2", "allowed hs ≥ 0"),
        ("2019 08 01 06 10 227  1.6 99.0  1.50 11.00 99.00 400 1017.2", "column MWD"),
    ],
)
def test_ndbc_malformed_lines_are_named(tmp_path: Path, line: str, message: str) -> None:
    """A malformed NDBC line is a TwinError naming the file, what is wrong and what is allowed."""
    path = write(tmp_path, "bad.txt", NDBC + line + "\n")
    with pytest.raises(TwinError, match=message.replace("(", r"\(")) as error:
        read_ndbc(path)
    assert "bad.txt" in str(error.value) and "allowed" in str(error.value)


def test_ndbc_header_must_name_the_wave_columns(tmp_path: Path) -> None:
    """A header without WVHT names the missing columns; a file that is not NDBC says so."""
    with pytest.raises(TwinError, match=r"columns \['WVHT'"):
        read_ndbc(write(tmp_path, "w.txt", "#YY MM DD hh mm DPD MWD\n2019 1 1 0 0 8 200\n"))
    with pytest.raises(TwinError, match="not an NDBC"):
        read_ndbc(write(tmp_path, "x.txt", "time,hs\n"))


def test_shipped_ndbc_record_reads_a_month_hourly() -> None:
    """The shipped 46097 August reads every one of its 744 hours, one sea state an hour, with
    directions and nothing skipped."""
    record = read_record(asset_path("site", "46097h2019_08.txt"))
    assert record.n == 744  # every hour of August 2019
    steps = np.diff(record.time).astype("timedelta64[m]").astype(int)
    assert set(steps.tolist()) == {60}
    # six rows an hour, the waves on the hh:10 row: one sea state per hour, no hour lost
    assert record.skipped == {} and record.direction is not None



def test_ndbc_without_a_direction_sensor_keeps_its_rows_without_direction(tmp_path: Path) -> None:
    """Every MWD missing (a buoy without directional waves): no direction, not no rows; one MWD
    present and a direction required: rows missing it are skipped and counted."""
    text = NDBC.replace(" 295 ", " 999 ").replace(" 300 ", " 999 ").replace(" 310 ", " 999 ")
    record = read_ndbc(write(tmp_path, "nodir.txt", text.replace(" 360 ", " 999 ")))
    assert record.direction is None and "no MWD" in record.source
    assert record.hs.tolist() == [1.2, 1.07, 1.4, 1.5]  # sorted by time; WVHT / DPD gaps skipped
    assert record.skipped == {"WVHT missing": 1, "DPD missing": 1}
    with pytest.raises(TwinError, match="MWD is missing on every row"):
        read_ndbc(tmp_path / "nodir.txt", require=["direction"])
    partial = read_ndbc(write(tmp_path, "partial.txt", text), require=["direction"])
    assert partial.direction is not None and partial.direction.tolist() == [360.0 % 360.0]
    assert partial.skipped["MWD missing"] == 3


def test_shipped_year_of_buoy_44005_reads_hourly_without_direction() -> None:
    """The shipped 44005 year reads 8,318 hours across all months without direction, the 29
    rows missing WVHT counted by reason."""
    record = read_record(asset_path("site", "44005h2012.txt"))
    assert record.direction is None
    assert record.n == 8347 - 29 and record.skipped == {"WVHT missing": 29}
    months = pd.DatetimeIndex(record.time).month
    assert set(months) == set(range(1, 13))  # January to mid-December 2012
    assert 0.2 < record.hs.min() and record.hs.max() < 9.0

CSV = """time,hs,tp,direction,heading
2024-01-01T00:00Z,1.0,8.0,270,0
2024-01-01T01:00,1.5,,270,0
2024-01-01T02:00+01:00,2.0,9.0,90,
2024-01-01T03:00,2.5,10.0,180,45
"""


def test_timeseries_csv_times_in_utc_and_missing_cells_skipped(tmp_path: Path) -> None:
    """Times in UTC; rows missing Tp skipped; a heading missing where the strategy needs it is
    a skipped row, where it does not, the column is left out and the row kept."""
    loose = read_timeseries(write(tmp_path, "s.csv", CSV))
    assert loose.n == 3 and loose.skipped == {"tp missing": 1} and loose.heading is None
    record = read_timeseries(tmp_path / "s.csv", require=["direction", "heading"])
    assert record.n == 2 and record.skipped == {"tp missing": 1, "heading missing": 1}
    np.testing.assert_allclose(record.hs, [1.0, 2.5])
    np.testing.assert_allclose(record.heading, [0.0, 45.0])
    assert record.time.tolist() == [np.datetime64("2024-01-01T00:00", "ns").item(),
                                    np.datetime64("2024-01-01T03:00", "ns").item()]  # fmt: skip
    # "02:00+01:00" was 01:00 UTC: its row was skipped for its heading, not misplaced
    forecast = read_forecast(tmp_path / "s.csv")
    assert forecast.kind == "forecast" and forecast.n == 3


def test_timeseries_zone_is_converted_to_utc(tmp_path: Path) -> None:
    """A time with a zone offset is converted to UTC."""
    text = "time,hs,tp,direction\n2024-01-01T02:00+01:00,1.0,8.0,10\n"
    record = read_timeseries(write(tmp_path, "z.csv", text))
    assert record.time[0] == np.datetime64("2024-01-01T01:00")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("time,hs\n2024-01-01,1\n", r"columns \['tp'\] missing"),
        (
            "time,hs,tp,direction\n2024-01-01,1,8,10\n2024-01-01T01,abc,8,10\n",
            "line 3, column hs: 'abc'",
        ),
        ("time,hs,tp,direction\nyesterday,1,8,10\n", "line 2, column time"),
        ("time,hs,tp,direction\n2024-01-01,1,0,10\n", "line 2, column tp: 0; allowed tp > 0"),
        ("time,hs,tp,direction\n2024-01-01,1,8,10,5\n", "more values than the header"),
    ],
)
def test_timeseries_malformed_input_is_named(tmp_path: Path, text: str, message: str) -> None:
    """Malformed time-series input is a TwinError saying what is wrong."""
    with pytest.raises(TwinError, match=message):
        read_timeseries(write(tmp_path, "m.csv", text))


def test_parquet_time_series(tmp_path: Path) -> None:
    """A Parquet series reads like a CSV: bracketed units ignored, a missing Hs skipped and
    counted, spreading kept."""
    frame = pd.DataFrame({
        "time": pd.date_range("2024-01-01", periods=3, freq="h", tz="UTC"),
        "Hs [m]": [1.0, np.nan, 2.0], "tp": [8.0, 8.0, 9.0], "direction": [0.0, 10.0, 20.0],
        "spreading": [5.0, 5.0, 5.0],
    })  # fmt: skip
    frame.to_parquet(tmp_path / "p.parquet")
    record = read_record(tmp_path / "p.parquet")
    assert record.n == 2 and record.skipped == {"hs missing": 1}
    np.testing.assert_allclose(record.spreading, [5.0, 5.0])


WIDE = """hs,4.5,6.5,8.5
0.5,10,20,
1.5,5,40,10
2.5,,3,2
"""


def test_scatter_wide_and_long_give_the_same_cells(tmp_path: Path) -> None:
    """A wide scatter table and its long form give the same cells and weights; empty cells are
    dropped."""
    wide = read_record(write(tmp_path, "wide.csv", WIDE))
    assert wide.kind == "scatter" and wide.time is None and wide.n == 7  # 2 empty cells
    assert wide.weight.sum() == 90 and np.isclose(wide.weights.sum(), 1.0)
    rows = [(h, t, w) for h, t, w in zip(wide.hs, wide.tp, wide.weight, strict=True)]
    long = "hs,tp,occurrence\n" + "".join(f"{h},{t},{w}\n" for h, t, w in rows)
    again = read_record(write(tmp_path, "long.csv", long))
    assert again.kind == "scatter"
    np.testing.assert_allclose(again.weight, wide.weight)
    np.testing.assert_allclose(again.tp, wide.tp)


def test_scatter_with_direction_and_bad_cells(tmp_path: Path) -> None:
    """A scatter with a direction column keeps each cell's direction; a negative occurrence, a
    Tp header that is not a number and an all-zero table are refused by line or reason."""
    text = "direction,hs,6,8\n0,1.0,5,5\n90,1.0,1,0\n"
    record = read_scatter(write(tmp_path, "d.csv", text))
    np.testing.assert_allclose(record.direction, [0.0, 90.0, 0.0])
    with pytest.raises(TwinError, match=r"line 3: occurrence -1"):
        read_scatter(write(tmp_path, "n.csv", "hs,6\n1,2\n2,-1\n"))
    with pytest.raises(TwinError, match="'x' is not a Tp value"):
        read_scatter(write(tmp_path, "x.csv", "hs,6,x\n1,2,3\n"))
    with pytest.raises(TwinError, match="every occurrence is zero"):
        read_scatter(write(tmp_path, "z.csv", "hs,6\n1,0\n"))


def test_read_record_rejects_unknown_kinds_and_missing_files(tmp_path: Path) -> None:
    """An unknown record kind names the allowed ones; a missing file says so."""
    with pytest.raises(TwinError, match="allowed ndbc, timeseries, scatter, forecast"):
        read_record(write(tmp_path, "a.csv", CSV), kind="grib")
    with pytest.raises(TwinError, match="no such file"):
        read_record(tmp_path / "none.csv")


def test_a_csv_with_an_issued_column_is_sniffed_as_a_forecast(tmp_path: Path) -> None:
    """`issued` marks a forecast; without it the same rows are a plain time series."""
    rows = "2019-08-20T00:10Z,1.5,9.0,300\n2019-08-20T03:10Z,1.7,9.5,310\n"
    plain = write(tmp_path, "plain.csv", "time,hs,tp,direction\n" + rows)
    issued = write(tmp_path, "issued.csv", "issued,time,hs,tp,direction\n"
                   + "".join(f"2019-08-20T00:10Z,{line}\n" for line in rows.splitlines()))
    assert read_record(plain).kind == "timeseries"
    forecast = read_record(issued)
    assert forecast.kind == "forecast" and forecast.hs.tolist() == [1.5, 1.7]


def test_the_shipped_forecast_example_is_the_buoys_record_every_3_hours() -> None:
    """40 steps of 3 h from 20 August 2019 00:10, each the 46097 record's own sea state at that
    hour, read as a forecast; the build script writes the shipped file again, to the byte."""
    build = script_module("build_site_forecast")
    path = asset_path("site", build.TARGET)
    forecast = read_record(path)
    assert forecast.kind == "forecast" and forecast.n == 40
    steps = np.diff(forecast.time).astype("timedelta64[h]").astype(int)
    assert set(steps.tolist()) == {3} and forecast.time[0] == np.datetime64("2019-08-20T00:10")
    buoy = read_record(asset_path("site", "46097h2019_08.txt"))
    at = np.searchsorted(buoy.time, forecast.time)
    assert np.array_equal(buoy.time[at], forecast.time)
    assert np.array_equal(buoy.hs[at], forecast.hs) and np.array_equal(buoy.tp[at], forecast.tp)
    assert np.array_equal(buoy.direction[at], forecast.direction)
    assert build.build().to_csv(index=False) == path.read_text()


#: NDBC's real-time layout (10-minute rows, newest first, MM missing), as in NDBC's realtime2
#: stdmet files: WVHT + DPD on the hh:10 row, WVHT + MWD on the hh:20 row
REALTIME = """\
#YY  MM DD hh mm WDIR WSPD GST  WVHT   DPD   APD MWD   PRES
#yr  mo dy hr mn degT m/s  m/s     m   sec   sec degT   hPa
2019 04 02 02 20 120  1.0   MM   1.6    MM    MM 262 1007.8
2019 04 02 02 10 120  1.0   MM   1.6    15    MM  MM 1007.9
2019 04 02 02 00  MM  0.0   MM    MM    MM    MM  MM 1007.9
2019 04 02 01 30 130  2.0   MM    MM    MM    MM  MM 1007.8
2019 04 02 01 20 120  1.0   MM   1.5    MM    MM 261 1007.8
2019 04 02 00 50 180  1.0   MM    MM    MM    MM 250 1007.9
2019 04 02 00 20 240  1.0   MM   1.7    MM    MM 274 1008.0
2019 04 02 00 10 220  1.0   MM   1.7    15    MM  MM 1008.1
"""


def test_ndbc_realtime_rows_merge_to_one_sea_state_per_hour(tmp_path: Path) -> None:
    """10-minute rows, newest first: each hour's WVHT and DPD come from one row, MWD from the
    row nearest it within the hour; an hour with no DPD beside WVHT is skipped and counted."""
    record = read_record(write(tmp_path, "46097.txt", REALTIME), require=["direction"])
    assert record.n == 2  # 00 h and 02 h; 01 h has WVHT but no DPD
    assert record.time.tolist() == [np.datetime64("2019-04-02T00:10", "ns").item(),
                                    np.datetime64("2019-04-02T02:10", "ns").item()]  # fmt: skip
    np.testing.assert_allclose(record.hs, [1.7, 1.6])
    np.testing.assert_allclose(record.tp, [15.0, 15.0])
    np.testing.assert_allclose(record.direction, [274.0, 262.0])  # hh:20, not hh:50 (40 min)
    assert record.skipped == {"DPD missing": 1}
    assert any("8 rows read as 2 hourly sea states" in note for note in record.notes)


def test_a_real_ndbc_realtime_file_is_read_to_its_full_hourly_count() -> None:
    """NDBC 46097's real-time stdmet file of 16 Feb - 2 Apr 2019 (assets/site/README.md): every
    hour holding a row with both WVHT and DPD, counted here straight from the text, is a sea
    state, with its MWD from the same hour; under 5 % lost, so no warning."""
    path = asset_path("site", "46097_realtime_2019_02_04.txt")
    hours, wave_hours = set(), set()
    for line in path.read_text().splitlines()[2:]:
        fields = line.split()
        hour = tuple(fields[:4])
        hours.add(hour)
        if fields[8] != "MM" and fields[9] != "MM":
            wave_hours.add(hour)
    record = read_record(path, require=["direction"])
    assert record.n == len(wave_hours) > 1000
    assert record.skipped == {"WVHT missing": len(hours) - len(wave_hours)}
    assert record.warnings() == [] and record.direction is not None
    assert record.time[0] == np.datetime64("2019-02-16T00:10")
    assert record.time[-1] == np.datetime64("2019-04-02T13:10")
    assert np.all(np.diff(record.time) > np.timedelta64(0))


def test_duplicate_times_are_refused_by_line_unless_merged(tmp_path: Path) -> None:
    """Two rows at one time: an error naming both lines; `first` keeps the first in the file,
    `mean` averages (directions on the circle: 350° and 10° give 0°)."""
    text = ("time,hs,tp,direction\n2024-01-01T00:00Z,1.0,8.0,350\n2024-01-01T01:00Z,2.0,9.0,0\n"
            "2024-01-01T00:00Z,3.0,10.0,10\n")  # fmt: skip
    path = write(tmp_path, "d.csv", text)
    with pytest.raises(TwinError, match=r"lines 2, 4 at 2024-01-01T00:00Z.*'mean' or 'first'"):
        read_record(path)
    first = read_record(path, duplicates="first")
    assert first.hs.tolist() == [1.0, 2.0]
    assert any("the first in the file" in n for n in first.notes)
    mean = read_record(path, duplicates="mean")
    np.testing.assert_allclose(mean.hs, [2.0, 2.0])
    np.testing.assert_allclose(mean.tp, [9.0, 9.0])
    assert min(mean.direction[0], 360.0 - mean.direction[0]) == pytest.approx(0.0, abs=1e-9)


def test_rows_closer_than_a_minute_are_refused(tmp_path: Path) -> None:
    """The finest step is MIN_STEP (60 s): rows 30 s apart are refused naming their lines."""
    text = "time,hs,tp\n2024-01-01T00:00:00Z,1.0,8.0\n2024-01-01T00:00:30Z,1.0,8.0\n"
    with pytest.raises(TwinError, match=r"lines 2 and 3 are 30 s apart.*at least 60 s"):
        read_record(write(tmp_path, "fine.csv", text))


def test_a_hindcast_of_hs_and_tp_alone_is_read_and_heavy_losses_warn(tmp_path: Path) -> None:
    """A time series with only time, Hs and Tp is a record; when more than 5 % of its rows
    are skipped, a warning names the reason and count."""
    rows = "".join(f"2024-01-01T{h:02d}:00Z,{'' if h < 3 else 1.0},8.0\n" for h in range(20))
    record = read_record(write(tmp_path, "h.csv", "time,hs,tp\n" + rows))
    assert record.n == 17 and record.direction is None
    assert record.warnings() == ["3 of 20 rows (15.0 %) skipped: hs missing"]
    assert record.summary()["warnings"] == record.warnings()


def test_a_year_with_one_mwd_keeps_every_hour_unless_direction_is_needed(tmp_path: Path) -> None:
    """44005's 2012 with MWD written on one row only (issue 38 finding 2): without a direction
    required every hour with WVHT and DPD is kept, no warning; required, the year shrinks to
    that one row and the warning names the reason and its count."""
    lines = asset_path("site", "44005h2012.txt").read_text().splitlines(keepends=True)
    fields = lines[1].split()
    mwd = lines[0].split().index("MWD")
    fields[mwd] = "270"
    lines[1] = " ".join(fields) + "\n"
    path = write(tmp_path, "44005_one_mwd.txt", "".join(lines))
    loose = read_record(path)
    assert loose.n == 8318 and loose.direction is None and loose.warnings() == []
    strict = read_record(path, require=["direction"])
    assert strict.n == 1 and strict.skipped["MWD missing"] == 8317
    assert strict.warnings()[0].startswith("8317 of 8347 rows (99.6 %) skipped: MWD missing")

"""Property test of the site readers (issue 41 item 7): a valid time series written to CSV and to
Parquet and read back by `twin.site.records.read_record` gives the rows written, in time order,
times exact and every value within one ulp (pandas' `to_numeric`, which the readers parse with,
is not correctly rounded: '19.003434951172274' reads as 19.003434951172277)."""

from __future__ import annotations

from pathlib import Path
from tempfile import TemporaryDirectory

import numpy as np
import pandas as pd
from hypothesis import given
from hypothesis import strategies as st

from tests.figures import fuzz
from twin.site.records import MIN_STEP, read_record, utc_column

#: [ulp] how far a value read may be from the value written: none (the readers parse with float)
PARSE_ULPS = 0
#: the first row's time; later rows follow at random gaps of at least MIN_STEP
START = np.datetime64("2019-08-01T00:00:00", "ns")
MIN_GAP = int(MIN_STEP / np.timedelta64(1, "s"))  # [s]


def finite(low: float, high: float, *, exclude_min: bool = False) -> st.SearchStrategy[float]:
    """Finite floats of [low, high] (`low` left out when `exclude_min`)."""
    return st.floats(low, high, exclude_min=exclude_min, allow_nan=False, allow_infinity=False)


@st.composite
def records(draw: st.DrawFn) -> pd.DataFrame:
    """A valid record in file order (shuffled): time (naive UTC, whole seconds, rows at least
    MIN_STEP apart), hs [m] ≥ 0, tp [s] > 0 and, on some records, direction [deg] in [0, 360)."""
    n = draw(st.integers(1, 12))
    gaps = draw(st.lists(st.integers(MIN_GAP, 10 * 86400), min_size=n, max_size=n))
    time = START + np.cumsum(gaps).astype("timedelta64[s]")
    frame = pd.DataFrame({
        "time": time.astype("datetime64[ns]"),
        "hs": draw(st.lists(finite(0.0, 30.0), min_size=n, max_size=n)),
        "tp": draw(st.lists(finite(0.0, 40.0, exclude_min=True), min_size=n, max_size=n)),
    })  # fmt: skip
    if draw(st.booleans()):
        direction = st.floats(0.0, 360.0, exclude_max=True, allow_nan=False)
        frame["direction"] = draw(st.lists(direction, min_size=n, max_size=n))
    order = draw(st.permutations(range(n)))
    return frame.iloc[list(order)].reset_index(drop=True)


def assert_rows(path: Path, written: pd.DataFrame) -> None:
    """The record read from `path` has the rows of `written`, sorted by time: the times exact,
    the values within PARSE_ULPS."""
    record = read_record(path)
    want = written.sort_values("time").reset_index(drop=True)
    assert record.kind == "timeseries" and record.skipped == {}
    np.testing.assert_array_equal(record.time, want["time"].to_numpy("datetime64[ns]"))
    for column in ("hs", "tp", "direction"):
        got = getattr(record, column)
        if column not in want:
            assert got is None
            continue
        assert got is not None
        np.testing.assert_array_max_ulp(got, want[column].to_numpy(float), maxulp=PARSE_ULPS)


@fuzz(60)
@given(records())
def test_a_record_written_to_csv_and_parquet_reads_back_to_the_same_rows(
    written: pd.DataFrame,
) -> None:
    """A random valid record (times, Hs, Tp, direction or none) written as CSV (ISO 8601 UTC
    text) and as Parquet reads back to the same rows in time order: times exact, values within
    one ulp."""
    with TemporaryDirectory() as folder:
        csv = Path(folder) / "record.csv"
        written.assign(time=utc_column(written["time"].to_numpy())).to_csv(csv, index=False)
        assert_rows(csv, written)
        parquet = Path(folder) / "record.parquet"
        written.to_parquet(parquet, index=False)
        assert_rows(parquet, written)

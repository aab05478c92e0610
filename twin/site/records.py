"""A site's wave record and its readers (pandas; no hand-written CSV parser).

Four inputs, one `SiteRecord`:

- `read_ndbc`: a NOAA NDBC standard meteorological file (columns WVHT [m], DPD [s], MWD
  [deg true, the direction waves come *from*]; `99.00` / `999` / `MM` mark a missing value;
  header lines `#YY  MM DD hh mm ...` and `#yr  mo dy hr mn ...`, or the older `YYYY ...` /
  `YY ...` single header with two-digit years and no minutes);
- `read_timeseries`: CSV or Parquet with columns `time`, `hs`, `tp`, `direction` and optionally
  `spreading` and `heading` (names case-insensitive; a unit in brackets, `hs [m]`, is ignored);
- `read_scatter`: an Hs × Tp occurrence table (CSV), wide (first column `hs`, one column per
  Tp value) or long (`hs`, `tp`, optional `direction`, `occurrence`);
- `read_forecast`: a time series, as `read_timeseries`, marked as a forecast.

Every row needs Hs and Tp; the direction and the vessel heading only where the caller says so
(`require`: the heading strategy `record` uses them, `fixed` and `best` do not). A row missing a
required value is skipped and counted by reason (`SiteRecord.skipped`); an optional column that
is missing on some kept rows is left out of the record, with a note (`SiteRecord.notes`). A
value that is not a number, a negative Hs or period, a direction outside 0-360°, a short or long
line, an unreadable time, two rows at one time (unless `duplicates` is "mean" or "first") or
rows closer than `MIN_STEP` raises `TwinError` naming the file, the line (or row) and the column
and saying what is allowed. Nothing NaN leaves this module.

NDBC files with several rows per hour (real-time files: 10-minute rows, newest first, WVHT + DPD
on one row and WVHT + MWD on another) are read one sea state per clock hour (`_merge_hours`).

Conventions: times are UTC (a time without a zone is read as UTC), stored as naive
`datetime64[ns]`; directions are compass degrees, clockwise from true north, waves coming *from*
(as NDBC's MWD); the vessel heading is the compass direction the bow points to (`twin.site.heading`
converts both to `Scenario.heading`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from twin.errors import TwinError

Kind = Literal["timeseries", "scatter", "forecast"]
#: what to do with rows sharing a time: refuse them, average them, or keep the first in the file
Duplicates = Literal["error", "mean", "first"]
DUPLICATES = ("error", "mean", "first")
#: columns a caller may require on every row besides time, Hs and Tp
REQUIRABLE = ("direction", "heading")
#: the finest time step a record may have: rows closer than this are refused (a record is
#: evaluated row by row, and its windows are measured on its rows, never on a denser grid)
MIN_STEP = np.timedelta64(60, "s")
#: what `read_record` accepts as `kind`
READ_KINDS = ("ndbc", "timeseries", "scatter", "forecast")
#: NDBC's missing-value markers per column (as text; `MM` in real-time files)
NDBC_MISSING = {"WVHT": {"99.00", "99.0", "99"}, "DPD": {"99.00", "99.0", "99"},
                "MWD": {"999", "999.0"}}  # fmt: skip
#: [bytes] largest record file read (a 10-year hourly CSV is ~4 MB)
MAX_FILE = 64 * 1024 * 1024
#: the columns of a time series (required first)
TIMESERIES_REQUIRED = ("time", "hs", "tp")
TIMESERIES_OPTIONAL = ("direction", "spreading", "heading")
#: the column that makes a CSV time series a forecast when sniffed: when it was issued
FORECAST_MARKER = "issued"
#: names of a long scatter table's weight column
WEIGHT_NAMES = ("occurrence", "count", "probability", "weight")


@dataclass
class SiteRecord:
    """A site's sea states, one per row.

    Attributes:
        hs: (n,) [m] significant wave height, ≥ 0.
        tp: (n,) [s] peak period, > 0.
        time: (n,) `datetime64[ns]`, UTC; None for a scatter diagram.
        direction: (n,) [deg] mean direction the waves come *from*, compass (clockwise from
            true north), in [0, 360); None when the record has no direction.
        spreading: (n,) [-] cos-2s spreading exponent s, or None.
        heading: (n,) [deg] the vessel's heading (where its bow points), compass, or None.
        weight: (n,) [-] occurrence of each row (scatter diagram), or None (every row once).
        kind: "timeseries", "scatter" or "forecast".
        source: where it came from (file name and format).
        skipped: rows skipped, by reason (e.g. {"WVHT missing": 12}); for an NDBC file,
            hours.
        notes: what the reader did that a user should know (rows merged per hour, duplicates
            resolved, a column left out).
    """

    hs: np.ndarray
    tp: np.ndarray
    time: np.ndarray | None = None
    direction: np.ndarray | None = None
    spreading: np.ndarray | None = None
    heading: np.ndarray | None = None
    weight: np.ndarray | None = None
    kind: Kind = "timeseries"
    source: str = ""
    skipped: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.hs = np.asarray(self.hs, dtype=float)
        self.tp = np.asarray(self.tp, dtype=float)
        n = self.hs.size
        if self.kind not in ("timeseries", "scatter", "forecast"):
            raise TwinError(f"kind: got {self.kind!r}; allowed timeseries, scatter, forecast")
        for name in ("time", "direction", "spreading", "heading", "weight"):
            value = getattr(self, name)
            if value is None:
                continue
            value = np.asarray(value, dtype="datetime64[ns]" if name == "time" else float)
            if value.shape != (n,):
                raise TwinError(f"{name}: {value.shape} values for {n} rows")
            setattr(self, name, value)
        for name in ("hs", "tp", "direction", "spreading", "heading", "weight"):
            value = getattr(self, name)
            if value is not None and not np.all(np.isfinite(value)):
                raise TwinError(f"{name}: not finite; a missing value is a skipped row")
        if self.kind != "scatter" and self.time is None:
            raise TwinError(f"a {self.kind} record needs times")

    @property
    def n(self) -> int:
        """Rows (sea states) kept."""
        return int(self.hs.size)

    @property
    def weights(self) -> np.ndarray:
        """(n,) [-] each row's share of the record, summing to 1."""
        w = np.ones(self.n) if self.weight is None else self.weight
        return w / w.sum()

    def warnings(self, share: float = 0.05) -> list[str]:
        """One warning per reason when the rows skipped are more than `share` of those read:
        the reason, its count and the share of all rows it took."""
        lost = sum(self.skipped.values())
        read = self.n + lost
        if read == 0 or lost <= share * read:
            return []
        ranked = sorted(self.skipped.items(), key=lambda kv: -kv[1])
        return [f"{count} of {read} rows ({100 * count / read:.1f} %) skipped: {reason}"
                for reason, count in ranked]  # fmt: skip

    def frame(self) -> pd.DataFrame:
        """The rows as a DataFrame (columns that are None left out)."""
        columns = {name: getattr(self, name) for name in
                   ("time", "hs", "tp", "direction", "spreading", "heading", "weight")}  # fmt: skip
        return pd.DataFrame({k: v for k, v in columns.items() if v is not None})

    def summary(self) -> dict[str, Any]:
        """JSON-ready description: kind, source, rows, skipped, span and ranges."""
        out: dict[str, Any] = {
            "kind": self.kind, "source": self.source, "rows": self.n,
            "skipped": dict(self.skipped), "skipped_total": int(sum(self.skipped.values())),
            "hs_range": [float(self.hs.min()), float(self.hs.max())] if self.n else None,
            "tp_range": [float(self.tp.min()), float(self.tp.max())] if self.n else None,
            "has_direction": self.direction is not None, "has_heading": self.heading is not None,
            "has_spreading": self.spreading is not None, "notes": list(self.notes),
            "warnings": self.warnings(),
        }  # fmt: skip
        if self.time is not None and self.n:
            out["start"] = utc_text(self.time.min())
            out["end"] = utc_text(self.time.max())
        return out


def utc_text(time: Any) -> str:
    """A time (naive UTC, as a record stores it) as ISO 8601 with its zone: `2019-08-01T00:10Z`."""
    return pd.Timestamp(time).strftime("%Y-%m-%dT%H:%MZ")


def utc_column(times: np.ndarray) -> pd.Series:
    """Times (naive UTC) as ISO 8601 text with their zone, seconds kept where there are some."""
    index = pd.DatetimeIndex(np.asarray(times, dtype="datetime64[ns]"))
    whole = bool(np.all(index.second == 0))
    return pd.Series(index.strftime("%Y-%m-%dT%H:%MZ" if whole else "%Y-%m-%dT%H:%M:%SZ"))


# -- readers --------------------------------------------------------------------------------------


def read_record(
    path: str | Path, kind: str | None = None, *, require: Iterable[str] = (),
    duplicates: Duplicates = "error",
) -> SiteRecord:  # fmt: skip
    """Read any record: by `kind` ("ndbc", "timeseries", "scatter", "forecast"), else sniffed
    (`.parquet`: a time series; a first line starting `#YY`, `YY` or `YYYY`: NDBC; a CSV with an
    `issued` column (when the forecast was issued): a forecast; a CSV with an `occurrence`-like
    column or numeric column names after `hs`: a scatter table; any other CSV: a time series).
    `require` ("direction", "heading") and `duplicates` ("error", "mean", "first") go to the
    time-series readers (`_build`, `_resolve_duplicates`); a scatter table has no times.

    Raises:
        TwinError: an unknown kind, a missing file or malformed content (naming it).
    """
    path = _check_file(path)
    if kind is not None and kind not in READ_KINDS:
        raise TwinError(f"kind: got {kind!r}; allowed {', '.join(READ_KINDS)} or None (sniff)")
    if kind is None:
        kind = _sniff(path)
    if kind == "scatter":
        return read_scatter(path)
    reader = {"ndbc": read_ndbc, "timeseries": read_timeseries, "forecast": read_forecast}[kind]
    return reader(path, require=require, duplicates=duplicates)


def read_ndbc(
    path: str | Path, *, require: Iterable[str] = (), duplicates: Duplicates = "error"
) -> SiteRecord:
    """An NDBC standard meteorological file: WVHT → hs [m], DPD → tp [s], MWD → direction [deg
    true, from]; `99.00`, `999` and `MM` mark a missing value. Two-digit years are 19YY (NDBC
    wrote them until 1998); no minute column: minute 0. One sea state per clock hour
    (`_merge_hours`: real-time files split WVHT + DPD and MWD over 10-minute rows); an hour
    without a row holding both WVHT and DPD is skipped and counted, as is one without MWD when
    `require` holds "direction". A buoy that reports no MWD at all gives a record without
    direction.
    """
    path = _check_file(path)
    require = _required(require)
    table, lines, names, skipped = _ndbc_table(path)
    stamp = {}
    for column, unit in (("YY", "year"), ("YYYY", "year"), ("MM", "month"), ("DD", "day"),
                         ("hh", "hour"), ("mm", "minute")):  # fmt: skip
        if column in table:
            stamp[unit] = _numbers(table[column], path, lines, column, integer=True)
    if "year" in stamp and names[0] == "YY":
        stamp["year"] = np.where(stamp["year"] < 100, stamp["year"] + 1900, stamp["year"])
    stamp.setdefault("minute", np.zeros(len(table)))
    frame = pd.DataFrame({"time": _times_from_parts(stamp, path, lines), "line": lines})
    for column, name in (("WVHT", "hs"), ("DPD", "tp"), ("MWD", "direction")):
        text = table[column].str.strip()
        absent = text.isin(NDBC_MISSING[column] | {"MM"}).to_numpy()
        values = _numbers(text.where(~absent, "0"), path, lines, column)
        _check_ranges({name: values}, path, lines, ~absent, {name: column})
        frame[name] = np.where(absent, np.nan, values)
    # a buoy without a directional sensor writes 999 on every row (44005 in 2012): the record
    # has no direction (fixed or chosen headings still apply) rather than no rows
    no_direction = bool(frame["direction"].isna().all())
    if no_direction and "direction" in require:
        raise TwinError(f"{path.name}: MWD is missing on every row; the heading strategy needs "
                        "the wave direction (allowed: fixed:DEG or best:DEG,DEG,…)")  # fmt: skip
    notes: list[str] = []
    frame = _resolve_duplicates(frame, path, "line", duplicates, notes)
    frame = _merge_hours(frame, skipped, notes)
    source = f"{path.name} (NDBC standard meteorological{'; no MWD' if no_direction else ''})"
    return _build(frame, "timeseries", source, skipped, notes, require, path, {"direction": "MWD"})


def _ndbc_table(path: Path) -> tuple[pd.DataFrame, np.ndarray, list[str], dict[str, int]]:
    """(the data lines as text, their 1-based file lines, the column names, skipped blanks)."""
    with path.open(encoding="utf-8", errors="replace") as handle:
        first, second = handle.readline(), handle.readline()
    names = first.lstrip("#").split()
    if not names or names[0] not in ("YY", "YYYY"):
        raise TwinError(
            f"{path.name}, line 1: not an NDBC standard meteorological header; allowed a first "
            f"line starting '#YY  MM DD hh', 'YYYY MM DD hh' or 'YY MM DD hh', got {first[:40]!r}"
        )
    missing = [c for c in ("MM", "DD", "hh", "WVHT", "DPD", "MWD") if c not in names]
    if missing:
        raise TwinError(
            f"{path.name}, line 1: columns {missing} missing; an NDBC standard meteorological "
            f"file has YY MM DD hh [mm] ... WVHT DPD ... MWD, got {names}"
        )
    header_lines = 2 if second.startswith("#") else 1
    try:
        table = pd.read_csv(
            path, sep=r"\s+", header=None, names=names, skiprows=header_lines, dtype=str,
            skip_blank_lines=False, engine="python",
        )  # fmt: skip
    except pd.errors.ParserError as exc:
        raise TwinError(
            f"{path.name}: malformed line ({exc}); allowed {len(names)} fields per line"
        ) from None
    lines = np.arange(len(table)) + header_lines + 1  # 1-based file lines
    blank = table.isna().all(axis=1).to_numpy()
    short = table.isna().any(axis=1).to_numpy() & ~blank
    if short.any():
        i = int(np.flatnonzero(short)[0])
        fields = int(table.iloc[i].notna().sum())
        raise TwinError(
            f"{path.name}, line {lines[i]}: {fields} fields; allowed {len(names)} "
            f"({' '.join(names)})"
        )
    skipped = {"blank line": int(blank.sum())} if blank.any() else {}
    return table[~blank], lines[~blank], names, skipped


def _merge_hours(frame: pd.DataFrame, skipped: dict[str, int], notes: list[str]) -> pd.DataFrame:
    """One sea state per clock hour of an NDBC file: WVHT and DPD (and the time) from the hour's
    earliest row holding both, MWD from the row holding one nearest that row in time within the
    same hour (the earlier of two as near; the wave row itself when it has MWD). Hours with no
    row holding both WVHT and DPD are counted in `skipped` by what they lack: "WVHT missing" (no
    row of the hour has it) or "DPD missing" (no row has it beside WVHT)."""
    frame = frame.sort_values("time", kind="stable").assign(hour=lambda f: f["time"].dt.floor("h"))
    wave = frame.dropna(subset=["hs", "tp"]).drop_duplicates("hour", keep="first")
    hours = frame.groupby("hour", sort=True)["hs"].count()
    lost = hours.index.difference(pd.DatetimeIndex(wave["hour"]))
    if len(lost):
        no_wvht = int((hours.loc[lost] == 0).sum())
        for reason, count in (("WVHT missing", no_wvht), ("DPD missing", len(lost) - no_wvht)):
            if count:
                skipped[reason] = skipped.get(reason, 0) + count
    directions = frame.dropna(subset=["direction"])[["time", "hour", "direction"]]
    # merge_asof takes the earlier row on a tie when searching backward first: search both
    # ways and keep the nearer, earlier on a tie
    both = [pd.merge_asof(wave.drop(columns="direction"),
                          directions.rename(columns={"time": "mwd_time"}), left_on="time",
                          right_on="mwd_time", by="hour", direction=way)
            for way in ("backward", "forward")]  # fmt: skip
    gap = [(b["mwd_time"] - b["time"]).abs() for b in both]
    later = gap[1] < gap[0].fillna(pd.Timedelta.max)
    merged = both[0].copy()
    merged.loc[later, "direction"] = both[1].loc[later, "direction"]
    if frame["hour"].duplicated().any():
        notes.append(
            f"{len(frame)} rows read as {len(merged)} hourly sea states (several rows per hour; "
            "WVHT and DPD from the hour's first row holding both, MWD from the row nearest it "
            "within the hour)"
        )
    return merged.drop(columns=["hour", "mwd_time"])


def read_timeseries(
    path: str | Path, kind: Kind = "timeseries", *, require: Iterable[str] = (),
    duplicates: Duplicates = "error",
) -> SiteRecord:  # fmt: skip
    """A CSV or Parquet time series: `time` (ISO 8601; UTC unless it carries a zone), `hs` [m],
    `tp` [s], optional `direction` [deg true, from], `spreading` [-] (cos-2s s) and `heading`
    [deg true, the bow's]. Empty cells are missing: a row missing Hs, Tp or a `require`d column
    is skipped and counted."""
    path = _check_file(path)
    require = _required(require)
    table, lines, where = _table(path)
    table.columns = [_column_name(c) for c in table.columns]
    absent = [c for c in ("time", "hs", "tp", *require) if c not in table.columns]
    if absent:
        raise TwinError(
            f"{path.name}: columns {absent} missing; a time series has columns "
            f"{', '.join(TIMESERIES_REQUIRED)}, optionally {', '.join(TIMESERIES_OPTIONAL)} (the "
            f"heading strategy 'record' needs direction, and heading without a vessel heading), "
            f"got {list(table.columns)}"
        )
    columns = [c for c in (*TIMESERIES_REQUIRED, *TIMESERIES_OPTIONAL) if c in table.columns]
    skipped: dict[str, int] = {}
    keep = np.ones(len(table), dtype=bool)
    empty = {c: _empty(table[c]) for c in columns}
    for column in ("time", "hs", "tp", *require):
        if (empty[column] & keep).any():
            skipped[f"{column} missing"] = int((empty[column] & keep).sum())
        keep &= ~empty[column]
    frame = pd.DataFrame({"line": lines[keep]})
    for column in columns[1:]:
        present = keep & ~empty[column]
        values = _numbers(table[column].where(present, "0"), path, lines, column, where)
        _check_ranges({column: values}, path, lines, present, {column: column}, where)
        frame[column] = np.where(empty[column], np.nan, values)[keep]
    time = _parse_times(table["time"].where(keep, "1970-01-01"), path, lines, where)
    frame.insert(0, "time", time[keep])
    notes: list[str] = []
    frame = _resolve_duplicates(frame, path, where, duplicates, notes)
    return _build(frame, kind, f"{path.name} ({kind})", skipped, notes, require, path)


def read_forecast(
    path: str | Path, *, require: Iterable[str] = (), duplicates: Duplicates = "error"
) -> SiteRecord:
    """A forecast: a time series (`read_timeseries`'s columns, and optionally `issued`, when it
    was issued, which read_record's sniffing recognises; not otherwise read), kind "forecast"."""
    return read_timeseries(path, kind="forecast", require=require, duplicates=duplicates)


def read_scatter(path: str | Path) -> SiteRecord:
    """An Hs × Tp occurrence table (CSV), one row per non-zero cell, `weight` its occurrence.

    Wide: a first column `hs` [m] (optionally after a `direction` [deg true, from] column), then
    one column per Tp [s] whose name is the number, cells the occurrences (counts, parts per
    thousand or probabilities: only their ratios matter). Long: columns `hs`, `tp`, optional
    `direction`, and one of `occurrence`, `count`, `probability`, `weight`. Empty cells are
    zero occurrences; negative occurrences and non-numbers are errors.
    """
    path = _check_file(path)
    table, lines, where = _table(path)
    table.columns = [_column_name(c) for c in table.columns]
    weight_column = next((c for c in WEIGHT_NAMES if c in table.columns), None)
    if weight_column is not None:
        needed = [c for c in ("hs", "tp") if c not in table.columns]
        if needed:
            raise TwinError(f"{path.name}: columns {needed} missing; a long scatter table has "
                            f"hs, tp, optional direction and {weight_column}")  # fmt: skip
        long = table
        cell_lines = lines
    else:
        keys = [c for c in ("direction", "hs") if c in table.columns]
        if "hs" not in keys or list(table.columns[: len(keys)]) != keys:
            raise TwinError(
                f"{path.name}: a wide scatter table starts with a column 'hs' (optionally after "
                f"'direction') followed by one column per Tp [s]; got columns "
                f"{list(table.columns)[:6]}"
            )
        tp_names = list(table.columns[len(keys) :])
        tp_values = []
        for name in tp_names:
            try:
                tp_values.append(float(name))
            except ValueError:
                raise TwinError(
                    f"{path.name}, header: column {name!r} is not a Tp value; allowed a number "
                    "[s] per column after 'hs'"
                ) from None
        long = table.melt(id_vars=keys, value_vars=tp_names, var_name="tp",
                          value_name="occurrence", ignore_index=False)  # fmt: skip
        cell_lines = lines[long.index.to_numpy()]
        long["tp"] = long["tp"].map(dict(zip(tp_names, map(str, tp_values), strict=True)))
        weight_column = "occurrence"
    long = long.reset_index(drop=True)
    occurrence = _numbers(long[weight_column].where(~_empty(long[weight_column]), "0"), path,
                          cell_lines, weight_column, where)  # fmt: skip
    if (occurrence < 0).any():
        i = int(np.flatnonzero(occurrence < 0)[0])
        raise TwinError(f"{path.name}, {where} {cell_lines[i]}: occurrence {occurrence[i]:g}; "
                        "allowed ≥ 0")  # fmt: skip
    keep = occurrence > 0
    if not keep.any():
        raise TwinError(f"{path.name}: every occurrence is zero; a scatter table needs one > 0")
    values = {c: _numbers(long[c].where(keep, "0"), path, cell_lines, c, where)
              for c in ("hs", "tp", "direction") if c in long.columns}  # fmt: skip
    _check_ranges(values, path, cell_lines, keep, {c: c for c in values}, where)
    return SiteRecord(
        hs=values["hs"][keep], tp=values["tp"][keep], weight=occurrence[keep],
        direction=np.mod(values["direction"][keep], 360.0) if "direction" in values else None,
        kind="scatter", source=f"{path.name} (scatter diagram)", skipped={},
    )  # fmt: skip


# -- helpers --------------------------------------------------------------------------------------


def _required(require: Iterable[str]) -> tuple[str, ...]:
    require = tuple(require)
    unknown = [c for c in require if c not in REQUIRABLE]
    if unknown:
        raise TwinError(f"require: {unknown}; allowed {', '.join(REQUIRABLE)}")
    return require


def _resolve_duplicates(
    frame: pd.DataFrame, path: Path, where: str, how: Duplicates, notes: list[str]
) -> pd.DataFrame:
    """Rows sharing a time: an error naming their lines ("error"), their mean ("mean": missing
    values left out, directions and headings averaged on the circle) or the first in the file
    ("first"). `frame` is in file order with columns time, line and values (NaN: missing)."""
    if how not in DUPLICATES:
        raise TwinError(f"duplicates: got {how!r}; allowed {', '.join(DUPLICATES)}")
    repeated = frame["time"].duplicated(keep=False).to_numpy()
    if not repeated.any():
        return frame
    groups = frame[repeated].groupby("time", sort=True)["line"].apply(list)
    if how == "error":
        named = "; ".join(f"{where}s {', '.join(map(str, v))} at {utc_text(t)}"
                          for t, v in groups.head(5).items())  # fmt: skip
        raise TwinError(
            f"{path.name}: {len(groups)} times appear on more than one row ({named}"
            f"{'; …' if len(groups) > 5 else ''}); allowed one row per time, or duplicates "
            "'mean' or 'first' (--duplicates)"
        )
    notes.append(f"{int(repeated.sum())} rows share {len(groups)} times: "
                 f"{'averaged' if how == 'mean' else 'the first in the file kept'}")  # fmt: skip
    if how == "first":
        return frame.drop_duplicates("time", keep="first")
    circular = [c for c in ("direction", "heading") if c in frame]
    radians = np.deg2rad(frame[circular])
    parts = frame.drop(columns=circular).assign(
        **{f"{c}_x": np.cos(radians[c]) for c in circular},
        **{f"{c}_y": np.sin(radians[c]) for c in circular},
    )  # fmt: skip
    mean = parts.groupby("time", sort=False).agg(
        {c: "first" if c == "line" else "mean" for c in parts.columns if c != "time"}
    ).reset_index()  # fmt: skip
    for c in circular:
        mean[c] = np.mod(np.rad2deg(np.arctan2(mean.pop(f"{c}_y"), mean.pop(f"{c}_x"))), 360.0)
    return mean


def _build(
    frame: pd.DataFrame, kind: Kind, source: str, skipped: dict[str, int], notes: list[str],
    require: tuple[str, ...], path: Path, names: dict[str, str] | None = None,
) -> SiteRecord:  # fmt: skip
    """The record of a time-series frame (time, line, hs, tp, optional columns; NaN missing):
    rows missing a required column skipped and counted (under the file's column `names`), an
    optional column missing on some kept row left out (noted), sorted by time, rows closer than
    MIN_STEP refused."""
    for column in require:
        absent = frame[column].isna()
        if absent.any():
            reason = f"{(names or {}).get(column, column)} missing"
            skipped[reason] = skipped.get(reason, 0) + int(absent.sum())
            frame = frame[~absent.to_numpy()]
    optional = {}
    for column in ("direction", "spreading", "heading"):
        if column not in frame:
            continue
        absent = frame[column].isna()
        if absent.all():
            continue
        if absent.any():
            notes.append(f"{column} missing on {int(absent.sum())} of {len(frame)} rows: left out "
                         "of the record (the heading strategy does not need it)")  # fmt: skip
            continue
        optional[column] = frame[column].to_numpy(float)
    order = np.argsort(frame["time"].to_numpy(), kind="stable")
    time = frame["time"].to_numpy(dtype="datetime64[ns]")[order]
    close = np.flatnonzero(np.diff(time) < MIN_STEP)
    if close.size:
        i = int(close[0])
        lines = frame["line"].to_numpy()[order]
        raise TwinError(
            f"{path.name}: lines {lines[i]} and {lines[i + 1]} are "
            f"{(time[i + 1] - time[i]) / np.timedelta64(1, 's'):g} s apart ({close.size} such "
            f"pairs); allowed at least {MIN_STEP / np.timedelta64(1, 's'):g} s between rows "
            "(average them to one row per minute or coarser)"
        )
    for name in ("direction", "heading"):
        if name in optional:
            optional[name] = np.mod(optional[name], 360.0)
    return SiteRecord(
        hs=frame["hs"].to_numpy(float)[order], tp=frame["tp"].to_numpy(float)[order], time=time,
        **{k: v[order] for k, v in optional.items()}, kind=kind, source=source, skipped=skipped,
        notes=notes,
    )  # fmt: skip


def _check_file(path: str | Path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise TwinError(f"{path}: no such file")
    size = path.stat().st_size
    if size > MAX_FILE:
        raise TwinError(f"{path.name}: {size} bytes; a record file is at most {MAX_FILE}")
    return path


def _sniff(path: Path) -> str:
    if path.suffix.lower() == ".parquet":
        return "timeseries"
    with path.open(encoding="utf-8", errors="replace") as handle:
        first = handle.readline()
    words = first.lstrip("#").split()
    if words and words[0] in ("YY", "YYYY") and "," not in first:
        return "ndbc"
    header = [_column_name(c) for c in first.strip().split(",")]
    if FORECAST_MARKER in header:
        return "forecast"
    if any(c in WEIGHT_NAMES for c in header):
        return "scatter"
    rest = [c for c in header if c not in ("hs", "direction")]
    if "hs" in header and "time" not in header and rest and all(_is_number(c) for c in rest):
        return "scatter"
    return "timeseries"


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _column_name(name: Any) -> str:
    """`' Hs [m] '` → `'hs'`: lower case, a bracketed unit dropped."""
    return str(name).split("[")[0].split("(")[0].strip().lower()


def _table(path: Path) -> tuple[pd.DataFrame, np.ndarray, str]:
    """(table as text, each row's line or row number, "line" or "row")."""
    if path.suffix.lower() == ".parquet":
        try:
            table = pd.read_parquet(path)
        except Exception as exc:  # pyarrow's errors have no common base
            raise TwinError(f"{path.name}: not a readable Parquet file ({exc})") from None
        table = table.astype(object).mask(table.isna(), "").astype(str)
        table = table.replace({"None": "", "NaT": "", "nan": ""})
        return table, np.arange(len(table)) + 1, "row"
    try:
        with warnings.catch_warnings():
            # a line longer than the header: pandas would drop its extra values with a warning
            warnings.simplefilter("error", pd.errors.ParserWarning)
            table = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True,
                                index_col=False)  # fmt: skip
    except (pd.errors.ParserError, pd.errors.ParserWarning) as exc:
        detail = str(exc).strip().replace("Error tokenizing data. C error: ", "")
        raise TwinError(
            f"{path.name}: a line has more values than the header has names ({detail}); "
            "allowed one value per header column"
        ) from None
    except (UnicodeDecodeError, pd.errors.EmptyDataError) as exc:
        raise TwinError(f"{path.name}: not a CSV text file ({exc})") from None
    return table, np.arange(len(table)) + 2, "line"  # line 1 is the header


def _empty(column: pd.Series) -> np.ndarray:
    text = column.astype(str).str.strip().str.lower()
    return text.isin({"", "nan", "na", "none", "null", "mm"}).to_numpy()


def _float(text: str) -> float:
    """A decimal number's float, or NaN for anything else (Python's `1_000` included, which no
    record writes)."""
    if "_" in text:
        return math.nan
    try:
        return float(text)
    except ValueError:
        return math.nan


def _numbers(
    column: pd.Series, path: Path, lines: np.ndarray, name: str, where: str = "line",
    integer: bool = False,
) -> np.ndarray:  # fmt: skip
    """Floats of a text column; TwinError at the first value that is not a finite number."""
    # Python's float, correctly rounded (pandas' own parser is off by up to tens of ulps on
    # values such as 0.011403: a record read back must give the numbers written)
    values = np.fromiter((_float(text) for text in column.astype(str).str.strip()), float,
                         count=len(column))  # fmt: skip
    bad = ~np.isfinite(values)
    if integer:
        bad |= np.isfinite(values) & (values != np.round(values))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        what = "a whole number" if integer else "a finite number"
        raise TwinError(
            f"{path.name}, {where} {lines[i]}, column {name}: {column.iloc[i]!r} is not "
            f"{what}; allowed {what} or a missing marker (empty, MM, NDBC's 99.00 / 999)"
        )
    return values


def _check_ranges(
    values: dict[str, np.ndarray], path: Path, lines: np.ndarray, keep: np.ndarray,
    columns: dict[str, str], where: str = "line",
) -> None:  # fmt: skip
    """Hs ≥ 0, Tp > 0, directions and headings within [0, 360], spreading ≥ 0 (kept rows)."""
    rules = {
        "hs": (lambda v: v >= 0.0, "hs ≥ 0 m"),
        "tp": (lambda v: v > 0.0, "tp > 0 s"),
        "direction": (lambda v: (v >= 0.0) & (v <= 360.0), "0 ≤ direction ≤ 360 deg"),
        "heading": (lambda v: (v >= 0.0) & (v <= 360.0), "0 ≤ heading ≤ 360 deg"),
        "spreading": (lambda v: v >= 0.0, "spreading ≥ 0"),
    }
    for name, v in values.items():
        if name not in rules:
            continue
        ok, allowed = rules[name]
        bad = keep & ~ok(v)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise TwinError(
                f"{path.name}, {where} {lines[i]}, column {columns[name]}: {v[i]:g}; allowed "
                f"{allowed}"
            )


def _times_from_parts(stamp: dict[str, np.ndarray], path: Path, lines: np.ndarray) -> np.ndarray:
    frame = pd.DataFrame({k: stamp[k].astype(int) for k in
                          ("year", "month", "day", "hour", "minute")})  # fmt: skip
    time = pd.to_datetime(frame, errors="coerce")
    bad = time.isna().to_numpy()
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        row = frame.iloc[i].tolist()
        raise TwinError(f"{path.name}, line {lines[i]}: {row} is not a date and time; allowed "
                        "YY(YY) MM DD hh [mm] of a real date")  # fmt: skip
    return time.to_numpy(dtype="datetime64[ns]")


def _parse_times(column: pd.Series, path: Path, lines: np.ndarray, where: str) -> np.ndarray:
    time = pd.to_datetime(column.astype(str).str.strip(), errors="coerce", utc=True,
                          format="ISO8601")  # fmt: skip
    bad = time.isna().to_numpy()
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise TwinError(
            f"{path.name}, {where} {lines[i]}, column time: {column.iloc[i]!r} is not a time; "
            "allowed ISO 8601, e.g. 2019-08-01T00:10:00Z or 2019-08-01 00:10 (UTC)"
        )
    return time.dt.tz_convert("UTC").dt.tz_localize(None).to_numpy(dtype="datetime64[ns]")

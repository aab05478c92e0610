"""Uploaded site records: priced before pandas sees them, parsed in a bounded child, stored as
the columns read (issue 43).

Three steps, each cheaper than the next and each able to refuse:

1. `prescan` (the request's thread, one pass over the text, no parser): a NUL character, more
   than `MAX_LINES` lines or a header of more than `MAX_COLUMNS` columns is refused before
   anything else (a 50,000-column scatter table cost pandas 158 s of CPU in its column
   de-duplication, quadratic in the columns).
2. `parse_record` (in a `twin.web.upload_worker.BoundedWorker` child, within its CPU, memory and
   wall budget): the CLI's reading of a record for a spec (`twin.runs.workability.
   read_site_record`: the columns its heading strategy needs, its duplicates rule, at least one
   usable row, else the reasons the rows were skipped), then a time grid of at most
   `MAX_GRID_STEPS` steps (`check_grid`: span / median step; 101 rows 1 ns apart and one a
   minute later asked for a 6e10-step grid).
3. `pack_record` / `unpack_record`: what is stored for the job is the record's columns (float64
   and datetime64 arrays, compressed), never the text: a column the reader ignored, padding
   included, costs nothing on disk.

This module is imported by the children too, so it imports no other part of `twin.web`.
"""

from __future__ import annotations

import dataclasses
import io
import json
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twin.assets import asset_path
from twin.errors import TwinError
from twin.runs.workability import read_site_record
from twin.site import SiteRecord

#: most lines an uploaded record may have: 5 years of hourly rows, or a year of 10-minute ones,
#: with room to spare (the readers keep at most `twin.runs.workability.MAX_ROWS` = 200,000 rows)
MAX_LINES = 300_000
#: most columns on an uploaded record's first line: a scatter table's `hs`, `direction` and up to
#: 200 Tp columns (pandas' cost grows with the square of the columns)
MAX_COLUMNS = 202
#: most steps of a time series' regular grid (span / median step + 1): twice the rows a record
#: may keep (`twin.runs.workability.MAX_ROWS`), 45 years hourly; it bounds the memory of any
#: per-step series built from the rows
MAX_GRID_STEPS = 400_000
#: the name an upload's file gets when the request names none
DEFAULT_NAME = "upload.csv"
#: files of assets/site that are not records
_NOT_RECORDS = {"README.md"}
#: the record's fields that are arrays (the others are stored as JSON)
_ARRAYS = ("hs", "tp", "time", "direction", "spreading", "heading", "weight")


class UploadRefused(TwinError):
    """An upload over a limit (a 422 naming the limit).

    Attributes:
        limit: the limit's name ("MAX_LINES", …), or "text" for a NUL character.
    """

    def __init__(self, message: str, limit: str) -> None:
        super().__init__(message)
        self.limit = limit


@dataclass(frozen=True)
class Scan:
    """What `prescan` counted.

    Attributes:
        bytes: [bytes] the text, UTF-8.
        lines: lines, a last one without a newline included.
        columns: fields on the first line (by commas, or by white space for NDBC).
    """

    bytes: int
    lines: int
    columns: int


def prescan(text: str, field: str = "record_csv") -> Scan:
    """Count the text's lines and first-line columns without parsing it; refuse what is over.

    Raises:
        UploadRefused: a NUL character (naming its line), over `MAX_LINES` lines or over
            `MAX_COLUMNS` columns, naming the limit and what is allowed.
    """
    nul = text.find("\x00")
    if nul >= 0:
        line = text.count("\n", 0, nul) + 1
        raise UploadRefused(f"{field}: a NUL character on line {line}; a record is text "
                            "(CSV, NDBC)", "text")  # fmt: skip
    lines = text.count("\n") + (0 if not text or text.endswith("\n") else 1)
    end = text.find("\n")
    first = text if end < 0 else text[:end]
    columns = max(first.count(",") + 1, len(first.split()))
    if lines > MAX_LINES:
        raise UploadRefused(f"{field}: {lines} lines; allowed at most {MAX_LINES} (MAX_LINES): "
                            "split the record, or run it with `twin workability`",
                            "MAX_LINES")  # fmt: skip
    if columns > MAX_COLUMNS:
        raise UploadRefused(
            f"{field}: {columns} columns on line 1; allowed at most {MAX_COLUMNS} (MAX_COLUMNS: "
            "a scatter table's hs, direction and up to 200 Tp columns)", "MAX_COLUMNS",
        )  # fmt: skip
    return Scan(len(text.encode()), lines, columns)


def parse_record(text: str, kind: str | None, name: str, spec: dict[str, Any]) -> dict[str, Any]:
    """Read an uploaded record's text as the CLI reads a file named `name` for the
    `WorkabilitySpec` fields `spec` (a task for a bounded child): `{"blob":
    pack_record(record), "summary": record.summary()}`.

    Raises:
        TwinError: the reader's message (naming the line and column), no usable row (with the
            reasons rows were skipped), or `UploadRefused`: a grid over `MAX_GRID_STEPS`.
    """
    with tempfile.TemporaryDirectory(prefix="twin-upload-") as folder:
        path = Path(folder) / name
        path.write_text(text, encoding="utf-8")
        record = read_site_record(path, spec, kind)
    check_grid(record)
    return {"blob": pack_record(record), "summary": record.summary()}


def check_grid(record: SiteRecord) -> None:
    """A record whose regular grid of times (span / median step + 1) has at most
    `MAX_GRID_STEPS` steps: whatever builds a per-step series from it stays proportional to a
    bound, not to how close two rows can be.

    Raises:
        UploadRefused: naming the grid's steps and the limit.
    """
    if record.time is None or record.n < 2:
        return
    ns = np.sort(record.time.astype(np.int64))
    gaps = np.diff(ns)
    gaps = gaps[gaps > 0]
    if gaps.size == 0:
        return
    steps = (ns[-1] - ns[0]) / float(np.median(gaps)) + 1.0
    if steps > MAX_GRID_STEPS:
        raise UploadRefused(
            f"record: its span over its median time step is {steps:.3g} steps; allowed at most "
            f"{MAX_GRID_STEPS} (MAX_GRID_STEPS, 45 years hourly): a record whose rows are far "
            "closer together than its span is long", "MAX_GRID_STEPS",
        )  # fmt: skip


def pack_record(record: SiteRecord) -> bytes:
    """A record's columns as compressed bytes (numpy's npz: float64 and datetime64 arrays,
    the other fields as JSON); `unpack_record` reads them back equal."""
    arrays = {k: getattr(record, k) for k in _ARRAYS if getattr(record, k) is not None}
    if "time" in arrays:
        arrays["time"] = arrays["time"].astype(np.int64)  # npz stores no datetime without pickle
    meta = {f.name: getattr(record, f.name) for f in dataclasses.fields(record)
            if f.name not in _ARRAYS}  # fmt: skip
    buffer = io.BytesIO()
    np.savez_compressed(buffer, _meta=np.frombuffer(json.dumps(meta).encode(), np.uint8),
                        **arrays)  # fmt: skip
    return buffer.getvalue()


def unpack_record(blob: bytes) -> SiteRecord:
    """The record `pack_record` packed."""
    with np.load(io.BytesIO(blob), allow_pickle=False) as data:
        fields: dict[str, Any] = json.loads(data["_meta"].tobytes().decode())
        for name in _ARRAYS:
            if name in data:
                fields[name] = data[name]
    if "time" in fields:
        fields["time"] = fields["time"].astype("datetime64[ns]")
    return SiteRecord(**fields)


def shipped_records() -> list[str]:
    """Names of the records shipped under `assets/site/`, sorted."""
    folder = asset_path("site")
    return sorted(p.name for p in folder.iterdir() if p.is_file() and p.name not in _NOT_RECORDS)


def read_shipped(name: str, spec: dict[str, Any]) -> dict[str, Any]:
    """A shipped record read as an upload is (`twin.web.upload_records.parse_record`'s
    answer), by its name (a task for a bounded child).

    Raises:
        TwinError: an unknown name, naming the shipped ones.
    """
    names = shipped_records()
    if name not in names:
        raise TwinError(
            f"record: {name!r} is not a shipped record; allowed {names} "
            "(GET /api/workability/records), or upload one as record_csv"
        )
    record = read_site_record(asset_path("site", name), spec)
    return {"blob": pack_record(record), "summary": record.summary()}

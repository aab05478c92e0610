"""Series exports that stream (issue 30): CSV, Parquet and JSON written chunk by chunk.

The JSON series of a 200,000-step run was one 145 MB body built in memory (RSS 566 → 1,330
MB, and three at once 2 GB). Here a done run's packed series (`pack_series`: Parquet, row
groups of `PACK_ROWS` samples) are read a row group at a time, only the columns asked for,
selected (`t0`, `t1`, `every`) and written `CHUNK_ROWS` samples at a time. What one export
holds is the stored blob (compressed: ≤ 55 MB for the longest run, 200,000 steps of the hybrid
system), its `t` column (8 bytes a sample) and one chunk of the columns asked for and its
text: `memory_bound` bytes, whatever the answer's size (185 MB of JSON for that run). A store
written before issue 30 (npz blobs) is read whole and then chunked alike. The output without
a selection means the same as `SimulationResult.to_dict` / `to_csv` / `to_parquet` of the run.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterator
from typing import Any

import numpy as np

from twin.errors import TwinError
from twin.runs.executor import PACK_ROWS, PARQUET_MAGIC, unpack_series
from twin.sim.result import flat_columns

#: samples read per chunk (a chunk of every column of the widest run is ~ 2 MB of CSV)
CHUNK_ROWS = PACK_ROWS
#: samples encoded as text per call: the encoders are C code that holds the GIL for a whole
#: call, so a short one lets the server's event loop in between (issue 30's soak: /api/health
#: p99 went from 4.3 s to under 1 s beside three 177 MB exports)
TEXT_ROWS = 512


def memory_bound(blob_bytes: int, samples: int, columns: int) -> int:
    """[bytes] an upper bound of what one export holds beyond the app: the blob, its time
    column, one chunk of `columns` float64 columns as arrays and as text (≤ 32 characters
    a number)."""
    return blob_bytes + 8 * samples + CHUNK_ROWS * columns * (8 + 8 + 32)


class Series:
    """A done run's packed series, read lazily: `names` (and `t`) of them, the rows picked by
    `select`, yielded `CHUNK_ROWS` at a time (`chunks`).

    Raises:
        TwinError: a name that is not one of the run's series.
    """

    def __init__(self, blob: bytes, names: list[str] | None = None) -> None:
        self._file: Any = None
        self._arrays: dict[str, np.ndarray] | None = None
        if bytes(blob[:4]) == PARQUET_MAGIC:
            import pyarrow.parquet as pq

            self._file = pq.ParquetFile(io.BytesIO(blob))
            layout = json.loads(self._file.schema_arrow.metadata[b"twin.series"])
            self._layout = {key: (tuple(tail), dtype) for key, tail, dtype in layout}
            self.t = unpack_series(blob, ["t"])["t"]
        else:  # an older store's npz: read whole (what it was built for)
            self._arrays = unpack_series(blob)
            self._layout = {k: (v.shape[1:], v.dtype.str) for k, v in self._arrays.items()}
            self.t = self._arrays["t"]
        unknown = sorted(set(names or ()) - set(self._layout))
        if unknown:
            raise TwinError(
                f"columns: {unknown} are not series of this run; allowed: {list(self._layout)}"
            )
        self.keys = [k for k in self._layout if names is None or k in names or k == "t"]
        self._rows = (0, len(self.t), 1)

    def select(self, t0: float | None, t1: float | None, every: int) -> Series:
        """Keep the samples with t0 ≤ t ≤ t1 [s], then every `every`-th of them.

        Raises:
            TwinError: t1 < t0, or every < 1.
        """
        if every < 1:
            raise TwinError(f"every: got {every}; allowed ≥ 1")
        if t0 is not None and t1 is not None and t1 < t0:
            raise TwinError(f"t1: {t1:g} s is before t0 = {t0:g} s; allowed t1 ≥ t0")
        start = 0 if t0 is None else int(np.searchsorted(self.t, t0, side="left"))
        stop = len(self.t) if t1 is None else int(np.searchsorted(self.t, t1, side="right"))
        self._rows = (start, max(start, stop), every)
        return self

    def columns(self, keys: list[str] | None = None) -> int:
        """Scalar columns of `keys` (default all kept)."""
        return sum(int(np.prod(self._layout[k][0])) for k in keys or self.keys)

    def header(self) -> list[tuple[str, str]]:
        """(column, dtype) of every scalar column kept, named as `flat_columns` names them."""
        out = []
        for key in self.keys:
            tail, dtype = self._layout[key]
            names = [key] if not tail else [f"{key}_{j}" for j in range(int(np.prod(tail)))]
            out += [(name, dtype) for name in names]
        return out

    def _flat(self, key: str) -> list[str]:
        tail = self._layout[key][0]
        return [key] if not tail else [f"{key}/{j}" for j in range(int(np.prod(tail)))]

    def chunks(self, keys: list[str] | None = None) -> Iterator[dict[str, np.ndarray]]:
        """The selected rows of `keys` (default all kept), `CHUNK_ROWS` at a time at most."""
        keys = keys or self.keys
        start, stop, every = self._rows
        if self._arrays is not None:
            picked = {k: self._arrays[k][start:stop:every] for k in keys}
            n = len(next(iter(picked.values())))
            for s in range(0, n, CHUNK_ROWS):
                yield {k: v[s : s + CHUNK_ROWS] for k, v in picked.items()}
            return
        columns = [name for key in keys for name in self._flat(key)]
        offset = 0
        for group in range(self._file.num_row_groups):
            # one row group at a time (`iter_batches` read ahead: 64 MB for a long run)
            rows = self._file.metadata.row_group(group).num_rows
            if offset + rows <= start:
                offset += rows
                continue
            batch = self._file.read_row_group(group, columns=columns, use_threads=False)
            first = max(start, offset)
            first += (-(first - start)) % every  # the next row on the stride
            last = min(stop, offset + rows)
            if first < last:
                local = np.arange(first - offset, last - offset, every)
                chunk = {}
                for key in keys:
                    tail, dtype = self._layout[key]
                    parts = [batch.column(name).to_numpy()[local] for name in self._flat(key)]
                    values = parts[0] if not tail else np.stack(parts, axis=1)
                    chunk[key] = values.astype(dtype, copy=False).reshape(-1, *tail)
                yield chunk
            offset += rows
            if offset >= stop:
                return


def csv_chunks(series: Series) -> Iterator[bytes]:
    """One row per sample, one column per scalar (`flat_columns`), as `to_csv` writes it."""
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    header = False
    for chunk in series.chunks():
        columns = flat_columns(chunk)
        if not header:
            writer.writerow(columns)
            header = True
        for s in range(0, len(chunk["t"]), TEXT_ROWS):
            part = slice(s, s + TEXT_ROWS)
            writer.writerows(zip(*(c[part].tolist() for c in columns.values()), strict=True))
            yield buffer.getvalue().encode()
            buffer.seek(0)
            buffer.truncate()
    if not header:  # nothing selected: the header alone
        writer.writerow([name for name, _ in series.header()])
        yield buffer.getvalue().encode()


def json_chunks(scenario: dict[str, Any], metrics: dict[str, Any], series: Series) -> Iterator[
    bytes
]:
    """`{scenario, metrics, series: {name: nested lists}}`, as `to_dict` makes it."""
    head = json.dumps({"scenario": scenario, "metrics": metrics}, allow_nan=False)
    yield (head[:-1] + ', "series": {').encode()
    for i, key in enumerate(series.keys):
        yield ((", " if i else "") + json.dumps(key) + ": [").encode()
        first = True
        for chunk in series.chunks([key]):
            values = chunk[key]
            for s in range(0, len(values), TEXT_ROWS):
                text = json.dumps(values[s : s + TEXT_ROWS].tolist(), allow_nan=False)[1:-1]
                if text:
                    yield (("" if first else ", ") + text).encode()
                    first = False
        yield b"]"
    yield b"}}"


class _Sink:
    """A write-only file that hands what was written to a generator (Parquet's writer)."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []
        self.position = 0
        self.closed = False

    def write(self, data: Any) -> int:
        data = bytes(data)
        self.parts.append(data)
        self.position += len(data)
        return len(data)

    def tell(self) -> int:
        return self.position

    def flush(self) -> None:
        pass

    def close(self) -> None:
        self.closed = True

    def drain(self) -> bytes:
        out, self.parts = b"".join(self.parts), []
        return out


def parquet_chunks(
    scenario_json: str, metrics: dict[str, Any], series: Series
) -> Iterator[bytes]:
    """Flat columns as Parquet, one row group per chunk, scenario and metrics in its metadata
    (as `to_parquet`)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = pa.schema([(k, pa.from_numpy_dtype(np.dtype(d))) for k, d in series.header()])
    schema = schema.with_metadata({"scenario": scenario_json, "metrics": json.dumps(metrics)})
    sink = _Sink()
    with pq.ParquetWriter(sink, schema) as writer:
        for chunk in series.chunks():
            writer.write_table(pa.table(flat_columns(chunk), schema=schema))
            yield sink.drain()
    yield sink.drain()

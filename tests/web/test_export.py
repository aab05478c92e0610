"""Streaming series exports (issue 30): chunked, selectable, and the same bytes' meaning as the
exporters of `SimulationResult`; `--private` puts stored data behind the token."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from fastapi.testclient import TestClient

from tests.figures import record
from tests.web.support import TOKEN, access
from tests.web.test_limits import QueueOnly
from twin.runs.executor import pack_series
from twin.sim import Scenario
from twin.sim.live import LiveSession
from twin.web import RunStore, create_app, export

N = 3 * export.CHUNK_ROWS + 17  # more than one chunk, not a whole number of them
DT = 0.05


@pytest.fixture
def stored(tmp_path: Path) -> tuple[RunStore, str, dict[str, np.ndarray]]:
    store = RunStore(tmp_path / "runs.sqlite")
    run = store.create(Scenario(mechanism="hybrid", duration=N * DT))
    rng = np.random.default_rng(0)
    series = {
        "t": np.arange(N) * DT, "xi": rng.normal(size=(N, 9)), "legs": rng.normal(size=(N, 6))
    }
    store.mark_running(run.id)
    store.finish_packed(run.id, {"rms": 1.0}, pack_series(series))
    return store, run.id, series


def _client(store: RunStore, **options: object) -> TestClient:
    app = create_app(LiveSession(), store, jobs=QueueOnly(store), access=access(**options))
    return TestClient(app)


def test_csv_streams_in_chunks_and_holds_every_sample(stored) -> None:
    """The CSV export streams in small chunks and holds every sample's values exactly."""
    store, run_id, series = stored
    response = _client(store).get(f"/api/runs/{run_id}/series", params={"format": "csv"})
    assert response.status_code == 200
    assert "content-length" not in response.headers  # streamed, not built whole
    rows = list(csv.reader(io.StringIO(response.text)))
    assert rows[0][:2] == ["t", "xi_0"] and len(rows) == N + 1
    np.testing.assert_array_equal(np.array(rows[1:], dtype=float)[:, 1:10], series["xi"])
    chunks = list(export.csv_chunks(export.Series(pack_series(series))))
    total = sum(map(len, chunks))
    assert len(chunks) > 10 and max(map(len, chunks)) < total / 10  # never the whole at once
    record("attack30_export", samples=N, chunks=len(chunks), largest_chunk=max(map(len, chunks)))


def test_json_streams_valid_json_with_every_series(stored) -> None:
    """The JSON export is valid JSON with the run's metrics, scenario and every series exactly."""
    store, run_id, series = stored
    body = json.loads(_client(store).get(f"/api/runs/{run_id}/series").content)
    assert body["metrics"] == {"rms": 1.0} and body["scenario"]["mechanism"] == "hybrid"
    np.testing.assert_array_equal(body["series"]["legs"], series["legs"])


def test_columns_every_t0_t1_select_part_of_a_run(stored) -> None:
    """columns, every, t0 and t1 select exactly those columns (t always) and samples of the run."""
    store, run_id, series = stored
    params = {"format": "json", "columns": "xi", "every": 10, "t0": 10.0, "t1": 20.0}
    body = _client(store).get(f"/api/runs/{run_id}/series", params=params).json()
    assert set(body["series"]) == {"t", "xi"}  # t always
    t = np.asarray(body["series"]["t"])
    assert t[0] == pytest.approx(10.0) and t[-1] <= 20.0 and np.allclose(np.diff(t), 10 * DT)
    picked = (series["t"] >= 10.0) & (series["t"] <= 20.0)
    np.testing.assert_array_equal(body["series"]["xi"], series["xi"][picked][::10])


def test_parquet_streams_row_groups_of_the_selection(stored) -> None:
    """The Parquet export holds the selected columns exactly and the metrics in its metadata."""
    store, run_id, series = stored
    response = _client(store).get(
        f"/api/runs/{run_id}/series", params={"format": "parquet", "columns": "legs"}
    )
    table = pq.read_table(io.BytesIO(response.content))
    assert table.column_names == ["t", *(f"legs_{j}" for j in range(6))]
    np.testing.assert_array_equal(table.column("legs_5").to_numpy(), series["legs"][:, 5])
    assert json.loads(table.schema.metadata[b"metrics"]) == {"rms": 1.0}


def test_a_bad_selection_is_422_naming_it(stored) -> None:
    """An unknown column, t0 after t1 or every 0 is answered 422, the unknown column named."""
    store, run_id, _ = stored
    client = _client(store)
    url = f"/api/runs/{run_id}/series"
    unknown = client.get(url, params={"columns": "nope"})
    assert unknown.status_code == 422 and "nope" in unknown.json()["message"]
    assert client.get(url, params={"t0": 5, "t1": 1}).status_code == 422
    assert client.get(url, params={"every": 0}).status_code == 422


def test_private_puts_stored_data_behind_the_token(stored) -> None:
    """With private set, stored runs and series need the token (401 without), health does not."""
    store, run_id, _ = stored
    open_client = _client(store, token=TOKEN)
    assert open_client.get(f"/api/runs/{run_id}").status_code == 200  # the default: open
    private = _client(store, token=TOKEN, private=True)
    assert private.get(f"/api/runs/{run_id}").status_code == 401
    assert private.get(f"/api/runs/{run_id}/series").status_code == 401
    auth = {"Authorization": f"Bearer {TOKEN}"}
    assert private.get(f"/api/runs/{run_id}", headers=auth).status_code == 200
    assert private.get("/api/health").status_code == 200  # not stored data


def test_a_stride_across_row_groups_and_an_older_npz_store_read_the_same(stored) -> None:
    """A stride across row groups selects the same samples from the current and the older npz
    series, chunks bounded."""
    _, _, series = stored
    buffer = io.BytesIO()
    np.savez(buffer, **series)  # how a store before issue 30 held series
    for blob in (pack_series(series), buffer.getvalue()):
        source = export.Series(blob, ["legs"]).select(1.0, None, 7)
        chunks = list(source.chunks())
        legs = np.concatenate([c["legs"] for c in chunks])
        np.testing.assert_array_equal(legs, series["legs"][series["t"] >= 1.0][::7])
        assert all(len(c["t"]) <= export.CHUNK_ROWS for c in chunks)


def test_exports_beyond_the_slots_are_429_and_slots_come_back(stored) -> None:
    """An export past the slots is 429 with Retry-After; finished or abandoned exports give their
    slot back."""
    from twin.web.routers import runs

    store, run_id, _ = stored
    client = _client(store)
    url = f"/api/runs/{run_id}/series"
    for _ in range(runs.EXPORT_SLOTS):
        assert runs._exports.acquire(blocking=False)  # as many exports streaming as allowed
    try:
        busy = client.get(url)
        assert busy.status_code == 429 and "retry-after" in busy.headers
    finally:
        for _ in range(runs.EXPORT_SLOTS):
            runs._exports.release()
    for _ in range(3 * runs.EXPORT_SLOTS):  # finished exports give their slot back
        assert client.get(url, params={"format": "csv", "every": 100}).status_code == 200
    assert runs._exports.acquire(blocking=False)  # the slot of an export …
    dropped = runs._slot(iter([b"x"]))  # … whose client went away before the first byte
    del dropped
    import gc

    gc.collect()
    taken = [runs._exports.acquire(blocking=False) for _ in range(runs.EXPORT_SLOTS)]
    for took in taken:
        if took:
            runs._exports.release()
    assert all(taken)  # every slot is free again

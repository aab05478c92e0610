"""Site workability over REST (issue 28): a job with progress, its result equal to the library's,
its PNG plots, validation (422 naming the field or the record's line), pricing, cancel, delete,
the token, and a restart that queues an interrupted job again."""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from tests.web.support import TOKEN, access, wait_for
from twin.assets import asset_path
from twin.db import session
from twin.runs.executor import IN_PROCESS, Executor
from twin.runs.workability import WorkabilitySpec, run_workability
from twin.sim.live import LiveSession
from twin.site import read_record
from twin.web import RunStore, create_app
from twin.web.limits import MAX_BODY
from twin.web.routers.workability import MAX_RUNS
from twin.web.warmup import Warmup
from twin.web.workability_jobs import MAX_RECORD_BYTES, UPLOAD_BODY
from twin.web.workability_store import WorkabilityStore

SHIPPED = "46097h2019_08.txt"
#: a tiny evaluation of the shipped record: 4 Hs × 2 Tp cells, 1 seed, 2 s runs (8 runs)
TINY = {"record": SHIPPED, "planners": ["mtmp"], "seeds": 1, "duration": 2.0,
        "hs_grid": [1.0, 2.0, 3.0, 4.0], "tp_grid": [8.0, 12.0], "window_hours": [6.0]}  # fmt: skip
#: a hand-made 24 h forecast at 3 h steps, calm then rough
FORECAST = "time,hs,tp,direction\n" + "".join(
    f"2026-01-01T{3 * i:02d}:00,{hs},8.0,270\n"
    for i, hs in enumerate([0.5, 0.5, 1.0, 1.5, 2.5, 3.5, 3.5, 1.0])
)


@pytest.fixture(autouse=True)
def read_before_answering(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every request here waits for its record's reading (60 s, not the server's 0.7 s), so
    what is checked at submission is, however loaded the machine; the test of the late
    reading sets its own."""
    from twin.web.routers import workability as route

    monkeypatch.setattr(route, "ANSWER_WAIT", 60.0)


@pytest.fixture(scope="module")
def executor() -> Iterator[Executor]:
    with Executor.start(IN_PROCESS) as executor:
        yield executor


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory, executor: Executor) -> Iterator[TestClient]:
    store = RunStore(tmp_path_factory.mktemp("data") / "runs.sqlite")
    app = create_app(LiveSession(), store, access=access(), executor=executor)
    with TestClient(app) as client:
        yield client
    store.close()


def wait_finished(
    client: TestClient, path: str, timeout: float = 120.0, headers: dict[str, str] | None = None
) -> dict[str, Any]:
    """GET `path` until the job is done or failed; its last answer."""
    answer: dict[str, Any] = {}

    def finished() -> bool:
        nonlocal answer
        answer = client.get(path, headers=headers).json()
        return answer["status"] in ("done", "failed")

    assert wait_for(finished, timeout, poll=0.1), f"{path} not done after {timeout} s: {answer}"
    return answer


def test_records_lists_the_shipped_ones(client: TestClient) -> None:
    """The shipped records by name, sorted, without the folder's README."""
    names = client.get("/api/workability/records").json()
    assert names == sorted(names) and "README.md" not in names
    assert {SHIPPED, "44005h2012.txt", "north_sea_coastdat2_2014_scatter.csv",
            "forecast_example_46097_2019_08_20.csv"} <= set(names)  # fmt: skip


def test_a_job_has_progress_the_librarys_result_and_png_plots(
    client: TestClient, tmp_path: Path
) -> None:
    """A workability job is priced at submission, runs to done with full progress, and gives the
    library's own result and its PNG plots."""
    response = client.post("/api/workability", json=TINY)
    assert response.status_code == 202, response.text
    queued = response.json()
    assert response.headers["location"] == f"/api/workability/{queued['id']}"
    assert queued["record"] == {"name": SHIPPED} and queued["spec"]["seeds"] == 1
    # priced: 4 × 2 cells refined up to L times, on the grid halved L times: (2^L·3 + 1) ×
    # (2^L·1 + 1) points × 1 seed × 1 planner (an upper bound)
    levels = WorkabilitySpec().refine_levels
    assert queued["total"] == (2**levels * 3 + 1) * (2**levels + 1)
    job = wait_finished(client, response.headers["location"])
    assert job["status"] == "done", job["error"]
    assert job["progress"] == 1.0 and job["done"] == job["total"]
    # the same evaluation through the library (the job's cells are cached: same summaries)
    spec = WorkabilitySpec(**{k: v for k, v in TINY.items() if k != "record"})
    expected = run_workability(spec, read_record(asset_path("site", SHIPPED)), data_dir=tmp_path,
                               scheduler=IN_PROCESS).to_dict()  # fmt: skip
    assert job["result"]["workability"] == expected["workability"]
    assert job["result"]["planners"]["mtmp"]["monthly"] == expected["planners"]["mtmp"]["monthly"]
    assert job["result"]["record"]["rows"] == 744
    assert set(job["plots"]) >= {"monthly.png", "windows.png", "strip.png"}
    for name in job["plots"]:
        png = client.get(f"/api/workability/{job['id']}/{name}")
        assert png.status_code == 200 and png.headers["content-type"] == "image/png"
        assert png.content[:8] == b"\x89PNG\r\n\x1a\n"
    assert client.get(f"/api/workability/{job['id']}/forecast.png").status_code == 404
    assert client.get(f"/api/workability/{job['id']}/nope.png").status_code == 404


def test_an_uploaded_forecast_lists_each_step_with_its_limiting_constraint(
    client: TestClient,
) -> None:
    """An uploaded forecast runs step by step, each with its Hs and limiting constraint, and
    the result names the uploaded file."""
    body = {**TINY, "record": None, "record_csv": FORECAST, "record_kind": "forecast",
            "record_name": "gulf forecast.csv"}  # fmt: skip
    response = client.post("/api/workability", json=body)
    assert response.status_code == 202, response.text
    assert response.json()["record"] == {"upload": "gulf forecast.csv", "kind": "forecast",
                                         "bytes": len(FORECAST.encode())}  # fmt: skip
    job = wait_finished(client, response.headers["location"])
    assert job["status"] == "done", job["error"]
    # the plots' titles name the record's source: the user's file, not a temporary name
    assert job["result"]["record"]["source"].startswith("gulf forecast.csv")
    steps = job["result"]["steps"]
    assert [s["hs"] for s in steps] == [0.5, 0.5, 1.0, 1.5, 2.5, 3.5, 3.5, 1.0]
    for s in steps:  # a non-operable step names what limited it; an operable one need not
        assert 0.0 <= s["probability"] <= 1.0
        assert s["operable"] == (s["probability"] >= 0.5)
        if not s["operable"]:
            assert s["limiting"]
    assert "forecast.png" in job["plots"]
    assert client.get(f"/api/workability/{job['id']}/forecast.png").status_code == 200


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"seeds": 0}, "seeds"),
        ({"planners": ["nope"]}, "planners"),
        ({"hs_grid": [2.0, 1.0]}, "hs_grid"),
        ({"unknown": 1}, "unknown"),
        ({"record": "nope.txt"}, "record"),
        ({"record": None}, "record"),
        ({"scenario": {"vessel": "/etc/passwd"}}, "vessel"),
    ],
)
def test_bad_requests_are_422_naming_the_field(
    client: TestClient, change: dict[str, Any], field: str
) -> None:
    """A bad workability request is 422 naming the field."""
    response = client.post("/api/workability", json={**TINY, **change})
    assert response.status_code == 422, response.text
    assert field in response.json()["message"]


def test_a_malformed_record_is_422_naming_its_line(client: TestClient) -> None:
    """A malformed uploaded record is 422 at submission naming record_csv, the line and the
    column."""
    bad = FORECAST.replace("2026-01-01T06:00,1.0", "2026-01-01T06:00,abc")
    response = client.post("/api/workability", json={**TINY, "record": None, "record_csv": bad})
    assert response.status_code == 422, response.text
    message = response.json()["message"]
    assert "record_csv" in message and "line 4" in message and "hs" in message


def hourly_record(rows: int) -> str:
    """A time-series record of `rows` hours from 2020-01-01, Hs and Tp varying by the hour."""
    start = np.datetime64("2020-01-01T00:00")
    times = start + np.arange(rows).astype("timedelta64[h]")
    hs = 0.5 + 2.5 * (np.arange(rows) % 24) / 24
    return "time,hs,tp,direction\n" + "".join(
        f"{t},{h:.2f},{8.0 + h:.2f},270\n" for t, h in zip(times.astype(str), hs, strict=True)
    )


def test_a_megabyte_record_uploads_beyond_the_global_body_cap(client: TestClient) -> None:
    """A megabyte record uploads to this route alone (its larger cap) and runs all its rows; a
    run body that size is still 413."""
    text = hourly_record(40_000)  # 4.6 years hourly
    assert len(text.encode()) > 1_000_000 > 15 * MAX_BODY
    response = client.post("/api/workability", json={**TINY, "record": None, "record_csv": text})
    assert response.status_code == 202, response.text
    job = wait_finished(client, response.headers["location"])
    assert job["status"] == "done", job["error"]
    assert job["result"]["record"]["rows"] == 40_000
    # the larger cap is that route's alone: a run body of the same size is still a 413
    big = client.post("/api/runs", json={"mechanism": "hybrid", "planner": "x" * 1_000_000})
    assert big.status_code == 413 and f"at most {MAX_BODY} bytes" in big.json()["message"]


def test_an_upload_over_the_caps_is_refused_naming_each(client: TestClient) -> None:
    """A record over its cap is 422 and a body over the route's cap 413, each naming the cap."""
    over_record = "x" * (MAX_RECORD_BYTES + 1)  # within the body cap, over the record's
    response = client.post(
        "/api/workability", json={**TINY, "record": None, "record_csv": over_record}
    )
    assert response.status_code == 422 and str(MAX_RECORD_BYTES) in response.json()["message"]
    over_body = "x" * (UPLOAD_BODY + 1)
    response = client.post(
        "/api/workability", json={**TINY, "record": None, "record_csv": over_body}
    )
    assert response.status_code == 413
    assert f"at most {UPLOAD_BODY} bytes allowed for POST /api/workability" in (
        response.json()["message"]
    )


@pytest.mark.parametrize("lookup", ["linear", "conservative"])
@pytest.mark.parametrize("levels", [0, 1, 2])
def test_the_price_bounds_the_runs_a_job_makes(
    executor: Executor, tmp_path: Path, lookup: str, levels: int
) -> None:
    """A cells job's price is at least the runs its evaluation makes, refinement included, and
    at most the grid's runs or max_runs; a direct job's is exactly its rows' runs."""
    from twin.web.routers.workability import price

    record = read_record(asset_path("site", SHIPPED))
    fields = {k: v for k, v in TINY.items() if k != "record"}
    spec = WorkabilitySpec(**fields, cell_lookup=lookup, refine_levels=levels)
    made = run_workability(spec, record, executor=executor, data_dir=tmp_path).runs
    priced = price(spec, record.n)[0]
    assert made <= priced <= max(8, spec.max_runs), (made, priced)
    if levels == 0:
        assert priced == 8  # 4 × 2 cells × 1 seed × 1 planner
    direct = WorkabilitySpec(**fields, method="direct")
    assert price(direct, 10)[0] == 10


def test_a_job_over_the_run_cap_is_refused_naming_the_limit(client: TestClient) -> None:
    """A job priced over MAX_RUNS is refused with 422 naming it."""
    body = {**TINY, "method": "direct", "seeds": 30}  # 744 rows × 30 seeds > MAX_RUNS
    assert 744 * 30 > MAX_RUNS
    response = client.post("/api/workability", json=body)
    assert response.status_code == 422, response.text
    assert "MAX_RUNS" in response.json()["message"]


def test_cancel_stops_a_job_and_delete_forgets_it(client: TestClient) -> None:
    """Cancel leaves a job failed "cancelled" with no late result or plot; delete forgets it."""
    body = {**TINY, "method": "direct", "seeds": 3, "duration": 10.0, "chunk_size": 8}
    location = client.post("/api/workability", json=body).headers["location"]
    cancelled = client.post(location + "/cancel")
    assert cancelled.status_code == 200
    assert cancelled.json()["status"] == "failed"
    assert cancelled.json()["error"].startswith("cancelled")
    job = wait_finished(client, location)  # it stays cancelled: no late result over it
    assert job["status"] == "failed" and job["result"] is None
    assert client.get(location + "/strip.png").status_code == 409
    assert client.delete(location).status_code == 204
    assert client.get(location).status_code == 404
    assert client.post(location + "/cancel").status_code == 404


def test_with_a_token_a_post_needs_it(tmp_path: Path, executor: Executor) -> None:
    """With a token, submitting and deleting need it while reading stays open."""
    store = RunStore(tmp_path / "runs.sqlite")
    app = create_app(LiveSession(), store, access=access(TOKEN), executor=executor)
    with TestClient(app) as client:
        assert client.post("/api/workability", json=TINY).status_code == 401
        response = client.post("/api/workability", json=TINY,
                               headers={"Authorization": f"Bearer {TOKEN}"})  # fmt: skip
        assert response.status_code == 202, response.text
        location = response.headers["location"]
        assert client.delete(location).status_code == 401
        assert client.get(location).status_code == 200  # reading is open (not --private)
        auth = {"Authorization": f"Bearer {TOKEN}"}
        assert client.delete(location, headers=auth).status_code == 204
    store.close()


def test_an_interrupted_job_is_queued_again_at_the_next_start(
    tmp_path: Path, executor: Executor
) -> None:
    """A job left running by a dead server is run again to done at the next start."""
    path = tmp_path / "runs.sqlite"
    jobs = WorkabilityStore(path)
    spec = WorkabilitySpec(**{k: v for k, v in TINY.items() if k != "record"})
    interrupted = jobs.create(spec.model_dump(mode="json"), {"name": SHIPPED}, 8).id
    jobs.running(interrupted)  # as if the server died mid-job
    jobs.close()
    store = RunStore(path)
    with TestClient(create_app(LiveSession(), store, access=access(), executor=executor)) as c:
        job = wait_finished(c, f"/api/workability/{interrupted}")
    store.close()
    assert job["status"] == "done", job["error"]
    assert job["result"]["record"]["rows"] == 744


def test_a_private_server_wants_the_token_to_read_jobs_and_plots(
    tmp_path: Path, executor: Executor
) -> None:
    """A private server wants the token to read jobs, records and plots too."""
    store = RunStore(tmp_path / "runs.sqlite")
    app = create_app(LiveSession(), store, access=access(TOKEN, private=True), executor=executor)
    auth = {"Authorization": f"Bearer {TOKEN}"}
    with TestClient(app) as client:
        location = client.post("/api/workability", json=TINY, headers=auth).headers["location"]
        assert client.get(location).status_code == 401
        assert client.get("/api/workability/records").status_code == 401
        job = wait_finished(client, location, headers=auth)
        assert job["status"] == "done", job["error"]
        assert client.get(f"{location}/strip.png").status_code == 401
        assert client.get(f"{location}/strip.png", headers=auth).status_code == 200
    store.close()


def test_a_job_posted_while_the_server_warms_up_runs_once_attached(tmp_path: Path) -> None:
    """`Services.attach` (what `twin serve` calls after its warm-up) starts the workability
    runner too: a job stored while warming runs then."""
    warmup = Warmup(out=io.StringIO())
    with RunStore(tmp_path / "runs.sqlite") as store:
        app = create_app(None, store, access=access(), warmup=warmup)
        with TestClient(app) as client, Executor.start(IN_PROCESS) as executor:
            response = client.post("/api/workability", json=TINY)
            assert response.status_code == 202, response.text
            location = response.headers["location"]
            assert client.get(location).json()["status"] == "queued"
            session = LiveSession()
            try:
                app.state.services.attach(session, executor)
                warmup.ready()
                job = wait_finished(client, location)
            finally:
                session.stop()
    assert job["status"] == "done", job["error"]


# -- issue 43: uploads priced before they are parsed, read within bounds, stored as columns ----


def upload(record_csv: str, **fields: Any) -> dict[str, Any]:
    """TINY's request on an uploaded record."""
    return {**TINY, "record": None, "record_csv": record_csv, **fields}


def stored_jobs(client: TestClient) -> int:
    """Workability jobs in the app's store."""
    with session(client.app.state.services.store.path, write=False) as db:  # type: ignore[attr-defined]
        return int(db.execute("SELECT COUNT(*) FROM workability").fetchone()[0])


def wide_scatter(columns: int) -> str:
    """A wide scatter table of `columns` Tp columns and one Hs row (issue 43: 20,000 columns,
    91 KB, took 20 s to parse; 50,000 took 158 s)."""
    tps = [f"{4 + 16 * i / columns:.5f}" for i in range(columns)]
    return "hs," + ",".join(tps) + "\n1.0," + ",".join("1" for _ in tps) + "\n"


def test_a_wide_scatter_table_is_refused_before_it_is_parsed(client: TestClient) -> None:
    """Finding 1: a 20,000-column scatter upload is a 422 naming `MAX_COLUMNS`, from the text
    scan alone (no parser, no job stored); 200 Tp columns are still read."""
    before = stored_jobs(client)
    response = client.post("/api/workability", json=upload(wide_scatter(20_000)))
    assert response.status_code == 422, response.text
    message = response.json()["message"]
    assert "MAX_COLUMNS" in message and "20001 columns" in message
    assert stored_jobs(client) == before
    ok = client.post("/api/workability", json=upload(wide_scatter(200)))
    assert ok.status_code == 202, ok.text
    assert client.delete(ok.headers["location"]).status_code == 204


def test_a_record_whose_reading_goes_over_its_budget_is_refused(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Finding 1: a reading over its wall-clock budget is a 422 naming the budget, answered
    when the budget ends (the child that read it is replaced; the next upload is read)."""
    from twin.web import workability_jobs
    from twin.web.upload_worker import Budget

    monkeypatch.setattr(workability_jobs, "READ_BUDGET", Budget(cpu=1.0, wall=0.001))
    response = client.post("/api/workability", json=upload(hourly_record(2_000)))
    assert response.status_code == 422, response.text
    assert "budget of 0.001 s" in response.json()["message"]
    monkeypatch.undo()
    again = client.post("/api/workability", json=upload(hourly_record(48)))
    assert again.status_code == 202, again.text
    assert client.delete(again.headers["location"]).status_code == 204


def test_rows_a_nanosecond_apart_are_refused_at_submission(client: TestClient) -> None:
    """Finding 2: 101 rows 1 ns apart and one a minute later asked for a 6e10-step time grid
    in the server process; now a 422 at submission (the reader's finest step, or the grid's
    `MAX_GRID_STEPS`), before any job."""
    times = [f"2020-01-01T00:00:00.{i:09d}" for i in range(101)] + ["2020-01-01T00:01:00"]
    text = "time,hs,tp\n" + "".join(f"{t},1.0,8.0\n" for t in times)
    response = client.post("/api/workability", json=upload(text))
    assert response.status_code == 422, response.text
    message = response.json()["message"]
    assert "MAX_GRID_STEPS" in message or "apart" in message


def test_a_header_only_or_nul_record_is_422_at_submission(client: TestClient) -> None:
    """Finding 5 and issue 38 item 4: a record without a usable row is a 422 with the reasons
    (not a 202 that fails later), a NUL character a 422 naming its line."""
    empty = client.post("/api/workability", json=upload("time,hs,tp,direction\n"))
    assert empty.status_code == 422, empty.text
    assert "no rows left to evaluate" in empty.json()["message"]
    skipped = "time,hs,tp,direction\n" + "".join(
        f"2020-01-01T{h:02d}:00,,8.0,270\n" for h in range(5))  # fmt: skip
    none_left = client.post("/api/workability", json=upload(skipped))
    assert none_left.status_code == 422, none_left.text
    assert "no rows left to evaluate" in none_left.json()["message"]
    assert "hs" in none_left.json()["message"] and "5" in none_left.json()["message"]
    with_nul = FORECAST.replace("0.5,8.0", "0.5\x00,8.0", 1)
    nul = client.post("/api/workability", json=upload(with_nul))
    assert nul.status_code == 422, nul.text
    assert "NUL character on line 2" in nul.json()["message"]


def test_a_job_over_its_row_headings_is_refused_naming_the_limit() -> None:
    """Finding 3: 200,000 rows judged at 36 headings (7.2M row-headings, 16 s of GIL in the
    server for its unique alone) is over `MAX_ROW_WORK`; a year hourly at 36 is not."""
    from twin.runs.workability import HeadingStrategy
    from twin.web.routers.workability import MAX_ROW_WORK, over_limits

    headings = HeadingStrategy.parse("best:" + ",".join(str(10 * i) for i in range(36)))
    best = WorkabilitySpec(planners=["mtmp"], heading=headings)
    errors = over_limits(best, 200_000)
    assert errors and "MAX_ROW_WORK" in errors[0]["msg"] and 200_000 * 36 > MAX_ROW_WORK
    assert not any("MAX_ROW_WORK" in e["msg"] for e in over_limits(best, 8_760))


def test_the_evaluation_runs_as_a_task_not_in_the_runners_thread(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Finding 3: a job's evaluation (the unique over row-headings, the per-row loop, the
    summary, the plots) runs as a task on the executor, a worker process on a server's
    cluster, never on the thread of the server's runner."""
    import threading

    from twin.runs import workability

    threads: list[str] = []
    original = workability.run_workability

    def recorded(*args: Any, **kwargs: Any) -> Any:
        threads.append(threading.current_thread().name)
        return original(*args, **kwargs)

    monkeypatch.setattr(workability, "run_workability", recorded)
    job = wait_finished(client, client.post("/api/workability", json=TINY).headers["location"])
    assert job["status"] == "done", job["error"]
    assert threads and all(not name.startswith("twin-") for name in threads), threads


def test_an_attempt_counts_when_the_job_is_picked_up_before_any_reading(
    tmp_path: Path, executor: Executor, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Finding 1: the attempt was counted only after the upload was parsed, so a server killed
    mid-parse never counted it and `MAX_ATTEMPTS` never tripped; now it counts first."""
    import threading

    from twin.web.workability_jobs import WorkabilityRunner

    jobs = WorkabilityStore(tmp_path / "runs.sqlite")
    spec = WorkabilitySpec(**{k: v for k, v in TINY.items() if k != "record"})
    job_id = jobs.create(spec.model_dump(mode="json"), {"name": SHIPPED}, 8).id
    reading, release = threading.Event(), threading.Event()
    original = WorkabilityStore.request

    def held(self: WorkabilityStore, job: str) -> Any:  # the job's input read: held here
        reading.set()
        release.wait(10)
        raise RuntimeError("the server was killed")

    monkeypatch.setattr(WorkabilityStore, "request", held)
    runner = WorkabilityRunner(jobs)
    runner.executor = executor
    worker = threading.Thread(target=runner.execute, args=(job_id,))
    worker.start()
    try:
        assert reading.wait(10)
        with session(tmp_path / "runs.sqlite", write=False) as db:
            attempts = db.execute("SELECT attempts FROM workability WHERE id = ?", (job_id,))
            assert attempts.fetchone()["attempts"] == 1
    finally:
        release.set()
        worker.join(10)
        monkeypatch.setattr(WorkabilityStore, "request", original)
    jobs.close()


def test_a_cancelled_jobs_upload_is_deleted_and_only_its_columns_are_stored(
    client: TestClient,
) -> None:
    """Finding 4: a job stored its whole upload (padding in an ignored column included) and
    kept it after a cancel; now it stores the columns read and lets them go when cancelled."""
    padded = "time,hs,tp,direction,notes\n" + "".join(
        f"2020-01-{1 + h // 24:02d}T{h % 24:02d}:00,1.0,8.0,270,{'x' * 2000}\n"
        for h in range(200))  # fmt: skip
    assert len(padded) > 400_000
    path = client.app.state.services.store.path  # type: ignore[attr-defined]
    location = client.post("/api/workability", json=upload(padded)).headers["location"]
    job_id = location.rsplit("/", 1)[1]
    with session(path, write=False) as db:
        size = db.execute("SELECT size, LENGTH(upload) AS up FROM workability WHERE id = ?",
                          (job_id,)).fetchone()  # fmt: skip
    assert size["up"] is not None and size["size"] < 20_000  # 200 rows' columns, not 400 kB
    client.post(location + "/cancel")
    with session(path, write=False) as db:
        after = db.execute(
            "SELECT size, upload FROM workability WHERE id = ?", (job_id,)
        ).fetchone()
    assert after["upload"] is None and after["size"] < size["size"]


def test_uploads_count_against_the_store_quota(tmp_path: Path, executor: Executor) -> None:
    """Finding 4: 80 submit-and-cancel cycles took a 300 MB store to 453 MB; now each job's
    size counts against --max-store and each job as a run against --max-runs (a 507)."""
    from twin.web.store import Quota


    store = RunStore(tmp_path / "runs.sqlite", Quota(max_runs=3))
    app = create_app(LiveSession(), store, access=access(), executor=executor)
    with TestClient(app) as client:
        codes = []
        for _ in range(5):
            answer = client.post("/api/workability", json=upload(hourly_record(100)))
            codes.append(answer.status_code)
            if answer.status_code == 202:
                client.post(answer.headers["location"] + "/cancel")
        assert codes == [202, 202, 202, 507, 507], codes
        assert "--max-runs" in client.post(
            "/api/workability", json=upload(hourly_record(100))).json()["detail"]  # fmt: skip
        assert store.usage()[1] == 3
    store.close()
    small = RunStore(tmp_path / "small.sqlite", Quota(max_bytes=30_000))  # 2 such uploads
    with TestClient(create_app(LiveSession(), small, access=access(), executor=executor)) as c:
        codes = [c.post("/api/workability", json=upload(hourly_record(2_000))).status_code
                 for _ in range(3)]  # fmt: skip
        assert codes == [202, 202, 507] and small.usage()[0] <= 30_000, (codes, small.usage())
    small.close()


def test_rows_csv_has_a_line_per_row_and_planner(client: TestClient) -> None:
    """Issue 38 item 4: GET …/rows.csv is the per-row table: one line per record row and
    planner, with each row's probability and whether it is operable; 409 until done."""
    import csv

    response = client.post("/api/workability", json=upload(FORECAST, record_kind="forecast"))
    location = response.headers["location"]
    job = wait_finished(client, location)
    assert job["status"] == "done", job["error"]
    assert job["rows"] is True
    table = client.get(location + "/rows.csv")
    assert table.status_code == 200 and table.headers["content-type"].startswith("text/csv")
    rows = list(csv.DictReader(io.StringIO(table.text)))
    assert len(rows) == 8 * len(TINY["planners"])  # type: ignore[arg-type]
    assert [float(r["hs"]) for r in rows] == [s["hs"] for s in job["result"]["steps"]]
    assert all(r["operable"] in ("True", "False") for r in rows)
    plain = client.get(location + "/rows.csv", headers={"Accept-Encoding": "identity"})
    assert plain.text == table.text
    queued = client.post("/api/workability", json={**TINY, "method": "direct", "seeds": 3,
                                                   "duration": 10.0})  # fmt: skip
    assert client.get(queued.headers["location"] + "/rows.csv").status_code == 409
    client.delete(queued.headers["location"])


def test_a_record_read_after_the_answer_runs_or_fails_with_the_readers_message(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Finding 1: a request answers by `ANSWER_WAIT` whatever its body; a record still being
    read then is a 202 whose job runs once read, or fails with the reader's message."""
    from twin.web.routers import workability as route

    monkeypatch.setattr(route, "ANSWER_WAIT", 0.0)
    late = client.post("/api/workability", json=upload(hourly_record(48)))
    assert late.status_code == 202, late.text
    job = wait_finished(client, late.headers["location"])
    assert job["status"] == "done", job["error"]
    assert job["result"]["record"]["rows"] == 48 and job["done"] == job["total"]
    bad = client.post("/api/workability", json=upload("time,hs,tp,direction\n"))
    assert bad.status_code == 202, bad.text
    failed = wait_finished(client, bad.headers["location"])
    assert failed["status"] == "failed" and "no rows left to evaluate" in failed["error"]

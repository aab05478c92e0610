"""Issue 43's findings 1-5, reproduced black-box: each test starts `twin serve` as a process and
talks to it over HTTP only, with request shapes and flags that 5ff4588 (the vulnerable code)
has too, so the same file fails there on the finding itself and passes after the fix
(docs/reliability.md lists what each test saw on each commit).

A refusal may come at submission (a 422) or, when the record's reading outlasts the answer's
wait (a loaded machine, a first upload starting the reading children), as the job failing with
the same message before it runs; `settle` follows a 202 until either shows. Finding 1's SIGTERM
has its own serial test (test_upload_shutdown.py); its attempt count is not visible over REST
(see docs/reliability.md)."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.timing import scaled
from tests.web.support import TOKEN
from tests.web.test_cli import start_server

pytestmark = pytest.mark.serial

#: a tiny evaluation: 4 Hs × 2 Tp cells, 1 seed, 2 s runs (8 runs)
TINY = {"planners": ["mtmp"], "seeds": 1, "duration": 2.0, "hs_grid": [1.0, 2.0, 3.0, 4.0],
        "tp_grid": [8.0, 12.0], "window_hours": [6.0]}  # fmt: skip
#: [s] an idle machine's bound on an answer the fixed server gives in under 1 s
ANSWER = 10.0
#: a job's states from which `settle` reports
ENDED = ("done", "failed")


def upload(text: str, **fields: Any) -> dict[str, Any]:
    """TINY's request on an uploaded record's text."""
    return {**TINY, "record_csv": text, **fields}


def hourly_record(rows: int, pad: int = 0) -> str:
    """A time series of `rows` hours from 2020-01-01 (and a `notes` column of `pad` x's)."""
    start, notes = 1577836800, ("," + "x" * pad if pad else "")
    lines = [
        time.strftime("%Y-%m-%dT%H:%M", time.gmtime(start + 3600 * i))
        + f",{0.5 + 2.5 * (i % 24) / 24:.2f},{9.0 + (i % 24) / 24:.2f},270{notes}\n"
        for i in range(rows)
    ]
    return "time,hs,tp,direction" + (",notes" if pad else "") + "\n" + "".join(lines)


@pytest.fixture
def serve(tmp_path: Path) -> Iterator[Callable[..., str]]:
    """`serve(*flags, token=None)`: `twin serve --no-viewer` on a free port with its data in
    `tmp_path/data`, the process killed at teardown; its base URL."""
    processes = []

    def start(*flags: str, token: str | None = None) -> str:
        process, port = start_server(tmp_path, *flags, env={"TWIN_TOKEN": token} if token else {})
        processes.append(process)
        return f"http://127.0.0.1:{port}"

    yield start
    for process in processes:
        if process.poll() is None:
            process.kill()
        process.communicate(timeout=10)


def settle(base: str, answer: httpx.Response, ends: tuple[str, ...] = (*ENDED, "running"),
           timeout: float = 60.0) -> tuple[str, str]:  # fmt: skip
    """What became of a submission, as (how, message): the status code and text of an answer
    other than 202; for a 202, its job's status once it is one of `ends` (a job refused after
    the answer fails before it runs) and its error, or the progress of one still running."""
    if answer.status_code != 202:
        return str(answer.status_code), answer.text
    location, end = base + answer.headers["location"], time.monotonic() + scaled(timeout)
    while True:
        job = httpx.get(location, timeout=ANSWER).json()
        if job["status"] in ends or time.monotonic() > end:
            return job["status"], job["error"] or f"{job['done']} of {job['total']} runs done"
        time.sleep(0.1)


def test_finding_1_a_20000_column_scatter_is_refused_naming_max_columns_within_10_s(
    serve: Callable[..., str],
) -> None:
    """A 20,000-column scatter upload is a 422 naming MAX_COLUMNS within 10 s (the old server
    parsed it in the request for 20 s)."""
    base = serve()
    tps = [f"{4 + 16 * i / 20_000:.5f}" for i in range(20_000)]
    wide = "hs," + ",".join(tps) + "\n1.0," + ",".join("1" for _ in tps) + "\n"
    start = time.monotonic()
    try:
        answer = httpx.post(f"{base}/api/workability", json=upload(wide), timeout=scaled(ANSWER))
    except httpx.TimeoutException:
        pytest.fail(f"no answer to the wide upload within {time.monotonic() - start:.1f} s")
    took = time.monotonic() - start
    assert answer.status_code == 422, f"{answer.status_code} after {took:.1f} s: {answer.text}"
    assert "MAX_COLUMNS" in answer.text and "20001 columns" in answer.text, answer.text


def test_finding_2_rows_a_nanosecond_apart_are_refused_before_any_evaluation(
    serve: Callable[..., str],
) -> None:
    """101 rows 1 ns apart and one 1 ms later (a grid of 10^6 steps) are refused by the finest
    step or MAX_GRID_STEPS, never accepted for evaluation."""
    base = serve()
    times = [f"2020-01-01T00:00:00.{i:09d}" for i in range(101)] + ["2020-01-01T00:00:00.001"]
    text = "time,hs,tp\n" + "".join(f"{t},1.0,8.0\n" for t in times)
    how, message = settle(base, httpx.post(f"{base}/api/workability", json=upload(text),
                                           timeout=scaled(ANSWER)))  # fmt: skip
    assert how in ("422", "failed"), f"{how}: {message}"
    assert "MAX_GRID_STEPS" in message or "apart" in message, f"{how}: {message}"


def test_finding_3_a_record_over_max_row_work_at_36_headings_is_refused_not_evaluated(
    serve: Callable[..., str],
) -> None:
    """120,000 hourly rows at the best of 36 headings (4.3M row-headings) are refused naming
    MAX_ROW_WORK, never evaluated (the old server ran np.unique over them in its own process)."""
    base = serve()
    body = upload(hourly_record(120_000), heading={"kind": "best",
                  "headings": [10.0 * i for i in range(36)]})  # fmt: skip
    how, message = settle(base, httpx.post(f"{base}/api/workability", json=body,
                                           timeout=scaled(ANSWER)))  # fmt: skip
    assert how in ("422", "failed") and "MAX_ROW_WORK" in message, f"{how}: {message}"


def test_finding_4_cancelled_uploads_count_against_the_quota_and_leave_no_text(
    serve: Callable[..., str], tmp_path: Path
) -> None:
    """With --max-store 1M --max-runs 8, eight submit-and-cancel cycles of a 400 KB padded
    upload are accepted and leave the store under 1 MiB on disk; a ninth job is a 507."""
    base = serve("--max-store", "1M", "--max-runs", "8")
    padded = hourly_record(200, pad=2000)
    assert len(padded) > 400_000
    codes = []
    for _ in range(9):
        answer = httpx.post(f"{base}/api/workability", json=upload(padded), timeout=scaled(ANSWER))
        codes.append(answer.status_code)
        if answer.status_code == 202:
            cancel = httpx.post(base + answer.headers["location"] + "/cancel", timeout=ANSWER)
            assert cancel.status_code == 200, cancel.text
    on_disk = sum(f.stat().st_size for f in (tmp_path / "data").glob("runs.sqlite*"))
    assert codes == [202] * 8 + [507] and on_disk < 2**20, (codes, f"{on_disk} bytes on disk")
    assert "--max-runs" in answer.text, answer.text


def test_finding_5_wrong_tokens_sharing_the_holders_prefix_never_lock_it_out(
    serve: Callable[..., str],
) -> None:
    """15 wrong tokens sharing the holder's first 8 characters are each a 401, and the
    holder's own token is then accepted (the old limit, keyed on 4 characters, made it 429)."""
    base = serve(token=TOKEN)

    def patch(token: str) -> int:
        return httpx.patch(f"{base}/api/live", json={"beta": 0.5}, timeout=ANSWER,
                           headers={"Authorization": f"Bearer {token}"}).status_code  # fmt: skip

    wrong = [patch(TOKEN[:8] + f"{i:02d}" + "x" * (len(TOKEN) - 10)) for i in range(15)]
    holder = patch(TOKEN)
    assert holder == 200 and wrong == [401] * 15, (holder, wrong)


def test_finding_5_header_only_nul_and_two_row_records_are_refused_or_evaluated(
    serve: Callable[..., str],
) -> None:
    """A header-only record is refused with the reason, a NUL character is a 422 naming its
    line, and a 2-row record is evaluated to done (the old server answered 202, then failed
    with numpy's "bins must increase monotonically")."""
    base = serve()

    def submit(text: str, ends: tuple[str, ...] = (*ENDED, "running")) -> tuple[str, str]:
        answer = httpx.post(f"{base}/api/workability", json=upload(text), timeout=scaled(ANSWER))
        return settle(base, answer, ends, timeout=120.0)

    header = "time,hs,tp,direction\n"
    how, message = submit(header)
    assert how in ("422", "failed") and "no rows left to evaluate" in message, f"{how}: {message}"
    rows = "2020-01-01T00:00,1.0,8.0,270\n2020-01-01T01:00,1.5,9.0,270\n"
    how, message = submit(header + rows.replace("1.0,8.0", "1.0\x00,8.0"))
    assert how == "422" and "NUL character on line 2" in message, f"{how}: {message}"
    how, message = submit(header + rows, ENDED)
    assert how == "done", f"{how}: {message}"

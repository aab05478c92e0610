"""The `twin` command: help, one-off runs to a file, `serve` answering and stopping (Ctrl-C,
SIGTERM with a long run open), one server per data directory, Dockerfile."""

from __future__ import annotations

import csv
import http.client
import json
import os
import re
import shlex
import signal
import socket
import sqlite3
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import httpx
import pyarrow.parquet as pq
import pytest

from tests.figures import record
from tests.timing import scaled
from tests.web.support import TOKEN
from twin.cli import build_parser, main
from twin.sim import PAPER_PRESETS, simulate
from twin.sim.engine import WARM_TOTAL

ROOT = Path(__file__).resolve().parents[2]


def twin(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """`twin ARGS` as a user runs it (the module the `twin` entry point calls)."""
    return subprocess.run(
        [sys.executable, "-m", "twin.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
    )


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_help_lists_the_commands_and_serve_defaults() -> None:
    """`twin --help` lists the commands and `twin serve --help` its defaults, as the parser has
    them."""
    result = twin("--help")
    assert result.returncode == 0 and "serve" in result.stdout and "run" in result.stdout
    result = twin("serve", "--help")
    assert result.returncode == 0
    for default in ("127.0.0.1", "8000", "8080", "data", "TWIN_TOKEN", "--graphics"):
        assert default in result.stdout
    args = build_parser().parse_args(["serve"])
    assert (args.host, args.port, args.viser_port, str(args.data_dir)) == (
        "127.0.0.1", 8000, 8080, "data",
    )  # fmt: skip


def test_run_writes_csv_and_prints_simulates_metrics(tmp_path: Path) -> None:
    """`twin run` prints simulate()'s metrics, shows a progress bar to its end and writes a CSV
    row per sample."""
    scenario = {"mechanism": "upr4", "sea_state": 3, "duration": 2.0}
    (tmp_path / "scenario.json").write_text(json.dumps(scenario))
    result = twin("run", "scenario.json", "--out", "run.csv", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout) == simulate(scenario).metrics
    assert "100%" in result.stderr  # the tqdm bar ran to the end
    lines = (tmp_path / "run.csv").read_text().splitlines()
    assert lines[0].startswith("t,") and len(lines) == 1 + 41


def test_run_accepts_a_preset_and_writes_parquet(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`twin run PRESET` writes Parquet with a row per step and the printed metrics in its
    metadata."""
    assert main(["run", "seed002_state1", "--out", str(tmp_path / "run.parquet")]) == 0
    table = pq.read_table(tmp_path / "run.parquet")
    preset = PAPER_PRESETS["seed002_state1"]
    assert table.num_rows == round(preset.duration / preset.dt) + 1
    assert json.loads(capsys.readouterr().out) == json.loads(table.schema.metadata[b"metrics"])


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("run", "bad.json"), "less than or equal to 1"),
        (("run", "missing.json"), "presets: ['seed000'"),
        (("run", "seed000", "--out", "run.xlsx"), "suffix must be one of"),
        (("serve", "--port", "70000"), "a port is 1-65535"),
        (("serve", "--host", "0.0.0.0; rm"), "not an IP address or host name"),
        (("serve", "--host", "0.0.0.0", "--no-viewer"), "refusing to bind 0.0.0.0 without a"),
    ],
)
def test_bad_arguments_exit_2_saying_what_is_allowed(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    args: tuple[str, ...],
    message: str,
) -> None:
    """A bad argument exits 2 under the sub-command's own usage line, saying what is allowed,
    and writes nothing."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("TWIN_TOKEN", raising=False)
    (tmp_path / "bad.json").write_text('{"beta": 2}')
    with pytest.raises(SystemExit) as exit_:
        main(list(args))
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and message in err
    assert err.startswith(f"usage: twin {args[0]} "), err  # the sub-command's own usage line
    assert not (tmp_path / "run.xlsx").exists() and not (tmp_path / "data").exists()


def start_server(cwd: Path, *args: str, env: dict[str, str] | None = None) -> tuple[Any, int]:
    """`twin serve --no-viewer` on a free port, once /api/health answers: (process, port).
    Its executor is in process unless `args` say otherwise (the test is not about it).

    A port free when picked can be taken by another process (a Dask worker of another test,
    say) before the server binds it, so a server that exits, or a port that answers with
    anything but the twin's health, means another port (up to 3)."""
    if "--scheduler" not in args and "--default-executor" not in args:
        args = ("--scheduler", "in-process", *args)
    args = tuple(a for a in args if a != "--default-executor")
    for _ in range(3):
        port = free_port()
        process = subprocess.Popen(
            [sys.executable, "-m", "twin.cli", "serve", "--port", str(port), "--no-viewer", *args],
            cwd=cwd,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, **(env or {})},
        )
        deadline, health, foreign = time.monotonic() + scaled(30), {"status": None}, False
        while health["status"] != "ok" and not foreign and time.monotonic() < deadline:
            if process.poll() is not None:
                break
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health") as r:
                    health = json.load(r)  # `warming` until its kernels are loaded
            except http.client.HTTPException:  # not an HTTP server: someone else's port
                foreign = True
            except OSError:
                pass
            time.sleep(0.2)
        if health["status"] == "ok":
            return process, port
        if process.poll() is None:
            process.kill()
        process.communicate(timeout=10)
    raise AssertionError(f"twin serve did not answer on 3 free ports (last exit {process.poll()})")


def test_serve_answers_prints_its_urls_and_stops_cleanly(tmp_path: Path) -> None:
    """`twin serve` answers REST, prints its address before compiling, reports each kernel set
    and "ready", creates its store and exits 0 on Ctrl-C."""
    process, port = start_server(tmp_path)
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/live") as r:
            assert json.load(r)["mechanism"] == "hybrid"
    finally:
        process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=20)
    assert process.returncode == 0, stderr
    assert f"http://127.0.0.1:{port}/" in stdout
    # the start-up talks: each compiled (or loaded) lane set, then ready
    total = WARM_TOTAL
    assert re.search(rf"kernels {total} of {total} ready \(.+\), [\d.]+ s", stdout), stdout
    assert "twin: ready in" in stdout
    assert stdout.index(f"http://127.0.0.1:{port}/") < stdout.index(f"kernels 1 of {total}")
    assert (tmp_path / "data" / "runs.sqlite").is_file()


def test_serve_on_all_interfaces_enforces_its_token(tmp_path: Path) -> None:
    """Bound to 0.0.0.0 (as in Docker) with TWIN_TOKEN: reads are open, a mutation without
    the token is 401, with it 200."""
    process, port = start_server(tmp_path, "--host", "0.0.0.0", env={"TWIN_TOKEN": TOKEN})
    url = f"http://127.0.0.1:{port}/api/live/pause"
    try:
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(urllib.request.Request(url, method="POST"))
        assert refused.value.code == 401
        request = urllib.request.Request(
            url, method="POST", headers={"Authorization": f"Bearer {TOKEN}"}
        )
        with urllib.request.urlopen(request) as r:
            assert json.load(r)["playing"] is False
    finally:
        process.send_signal(signal.SIGINT)
        process.communicate(timeout=20)


def test_a_short_token_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A token under 16 characters exits 2 saying so, before anything (not even the data
    directory) is created."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("TWIN_TOKEN", "tok-123")
    with pytest.raises(SystemExit) as exit_:
        main(["serve", "--no-viewer"])
    assert exit_.value.code == 2 and "at least 16" in capsys.readouterr().err
    assert not (tmp_path / "data").exists()  # nothing started


def test_a_second_server_on_the_same_data_dir_exits_2_naming_the_first(tmp_path: Path) -> None:
    """A second server on a held data directory exits 2 naming the first's pid, which keeps
    serving."""
    first, port = start_server(tmp_path)
    try:
        start = time.monotonic()
        second = twin("serve", "--no-viewer", "--port", str(free_port()), cwd=tmp_path)
        took = time.monotonic() - start
        assert second.returncode == 2, second.stderr
        assert f"in use by the server with pid {first.pid}" in second.stderr
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health") as r:
            assert json.load(r)["status"] == "ok"  # the first is untouched
    finally:
        first.send_signal(signal.SIGINT)
        first.communicate(timeout=20)
    assert first.returncode == 0
    record("attack_two_servers", exit_code=second.returncode, refused_in_s=round(took, 1),
           names_pid=True)  # fmt: skip


def test_a_port_in_use_exits_2_naming_it_before_starting(tmp_path: Path) -> None:
    """The REST port is bound first: one already taken fails at once (no kernels warmed, no
    executor started), naming the port and how to choose another, and leaves the data
    directory unlocked."""
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = twin("serve", "--no-viewer", "--port", str(port), cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    assert f"127.0.0.1:{port}" in result.stderr and "--port" in result.stderr
    assert "compiled kernels ready" not in result.stdout  # it stopped before warming
    second, _ = start_server(tmp_path)  # the data directory was released
    second.send_signal(signal.SIGINT)
    second.communicate(timeout=20)
    assert second.returncode == 0


def test_unknown_graphics_exit_2_naming_the_choices_before_starting(tmp_path: Path) -> None:
    """An unknown --graphics exits 2 naming the choices before compiling or taking the data
    directory."""
    result = twin("serve", "--graphics", "fancy", "--data-dir", "data", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    assert "graphics 'fancy' unknown; one of: full, light" in result.stderr
    assert "compiled kernels ready" not in result.stdout
    assert not (tmp_path / "data").exists()  # not even the data directory was taken


#: the longest run a scenario may be (200 000 steps on the finest sea): seconds on a worker
LONG = {"mechanism": "hybrid", "n_components": 2048, "dt": 0.005, "duration": 1000.0}


def test_sigterm_stops_the_server_within_10_s_with_a_run_open(tmp_path: Path) -> None:
    """`docker stop`: SIGTERM while both workers of the default executor (a LocalCluster) are
    busy with long runs and a synchronous request waits behind them. The waiting request is
    answered (503: its run stays queued), the server exits 0 within 10 s, and every unfinished
    run is left queued for the next start."""
    process, port = start_server(tmp_path, "--default-executor", "--workers", "2")
    url = f"http://127.0.0.1:{port}"
    answers: list[httpx.Response] = []
    database = tmp_path / "data" / "runs.sqlite"
    try:
        with httpx.Client(base_url=url, timeout=30.0) as client:
            health = client.get("/api/health").json()
            assert health["executor"]["scheduler"] == "local cluster"
            long_ids = [client.post("/api/runs", json=LONG).json()["id"] for _ in range(4)]
        waiting = threading.Thread(
            target=lambda: answers.append(
                httpx.post(f"{url}/api/runs", json={"duration": 2.0}, timeout=30.0)
            )
        )
        waiting.start()

        def running() -> int:
            with sqlite3.connect(database, timeout=5.0) as db:
                sql = "SELECT COUNT(*) FROM runs WHERE status = 'running'"
                return db.execute(sql).fetchone()[0]

        deadline = time.monotonic() + scaled(20)
        while running() == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert running() > 0
        time.sleep(0.3)
        start = time.monotonic()
        process.send_signal(signal.SIGTERM)
        _, log = process.communicate(timeout=30)
        stopped = time.monotonic() - start
        waiting.join(10)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait(5)
    assert process.returncode == 0 and stopped < scaled(10.0), (process.returncode, stopped)
    assert answers and answers[0].status_code in (201, 503), answers
    with sqlite3.connect(database) as db:
        statuses = dict(db.execute("SELECT id, status FROM runs").fetchall())
    # the server's log says why, should a run be left running (its shutdown's warnings)
    assert "running" not in statuses.values() and "failed" not in statuses.values(), (
        statuses,
        log[-4000:],
    )
    requeued = [i for i in long_ids if statuses[i] == "queued"]
    assert requeued, statuses
    record("attack_sigterm_with_run_open", stopped_s=round(stopped, 1),
           waiting_request=answers[0].status_code, runs_left_queued=len(requeued),
           exit_code=process.returncode)  # fmt: skip


def test_dockerfile_runs_twin_serve_as_a_user_on_both_ports() -> None:
    """No Docker engine here: check the image's instructions against the CLI and the API."""
    lines = (ROOT / "Dockerfile").read_text().replace("\\\n", " ").splitlines()
    instructions = [line.split(None, 1) for line in lines if line and not line.startswith("#")]
    by_name: dict[str, list[str]] = {}
    for name, rest in instructions:
        by_name.setdefault(name, []).append(rest)
    (base,) = by_name["FROM"]  # pinned by digest, with the date the digest was read
    assert re.fullmatch(r"python:3\.11-slim-bookworm@sha256:[0-9a-f]{64}", base), base
    assert re.search(r"on \d{4}-\d{2}-\d{2}", (ROOT / "Dockerfile").read_text())
    assert any("--require-hashes -r requirements/serve.txt" in run for run in by_name["RUN"])
    assert by_name["USER"] and by_name["USER"][-1] not in ("root", "0")
    assert set(by_name["EXPOSE"][0].split()) == {"8000", "8080"}
    assert "/api/health" in by_name["HEALTHCHECK"][0]
    command = json.loads(by_name["CMD"][-1])
    assert command[:2] == ["twin", "serve"]
    args = build_parser().parse_args(command[1:])
    assert (args.host, args.port, args.viser_port) == ("0.0.0.0", 8000, 8080)
    copied = {shlex.split(c)[0] for c in by_name["COPY"]}
    assert {"twin", "assets", "static", "pyproject.toml", "requirements/serve.txt"} <= copied


# -- twin sweep ---------------------------------------------------------------------------------

#: a 2-cell sweep of 2 s runs: seconds, in this process
TINY_SWEEP = {"hs": [0.5, 2.0], "tp": [8.0], "planner": ["mtmp"], "seeds": 2, "duration": 2.0}


def test_sweep_writes_table_json_and_heatmap(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`twin sweep` prints the table and threshold, and writes the operability CSV, JSON and a
    PNG heatmap with a cell per Hs."""
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps(TINY_SWEEP))
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--scheduler", "in-process", "--out", str(out)]) == 0
    printed = capsys.readouterr()
    assert "operability" in printed.out and "tip position error ≤ 0.05 m" in printed.err
    rows = list(csv.DictReader((out / "operability.csv").open()))
    assert [float(r["hs"]) for r in rows] == [0.5, 2.0]
    assert all(r["runs"] == "2" and 0.0 <= float(r["operability"]) <= 1.0 for r in rows)
    document = json.loads((out / "operability.json").read_text())
    assert document["tip_error_threshold"] == 0.05 and len(document["cells"]) == 2
    assert (out / "heatmap.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("change", "field"),
    [({"hs": []}, "hs"), ({"seeds": 0}, "seeds"), ({"hs": [0.1 * i for i in range(1, 60)],
      "tp": [4.0 + 0.1 * i for i in range(100)]}, "cells")],
)  # fmt: skip
def test_a_bad_sweep_spec_exits_2_naming_the_field(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: dict[str, Any], field: str
) -> None:
    """A bad sweep spec exits 2 naming the field, writing nothing."""
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({**TINY_SWEEP, **change}))
    with pytest.raises(SystemExit) as exit_:
        main(["sweep", str(spec), "--scheduler", "in-process", "--out", str(tmp_path / "out")])
    assert exit_.value.code == 2
    assert field in capsys.readouterr().err
    assert not (tmp_path / "out").exists()  # nothing written for a refused spec


def test_ctrl_c_on_a_busy_server_stops_it_quietly(tmp_path: Path) -> None:
    """Ctrl-C in a terminal signals the whole process group (the server and its Dask worker
    processes) while runs are on the workers: the server stops, exit 0, with no traceback from
    a worker and no resource-tracker warning of leaked semaphores."""
    port = free_port()
    process = subprocess.Popen(
        [sys.executable, "-m", "twin.cli", "serve", "--no-viewer", "--port", str(port),
         "--workers", "2"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True,  # its own group, as a terminal's foreground job
    )  # fmt: skip
    try:
        url = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + scaled(120)
        while time.monotonic() < deadline:
            assert process.poll() is None, process.communicate()
            try:
                if httpx.get(f"{url}/api/health", timeout=2).json()["status"] == "ok":
                    break
            except httpx.TransportError:
                pass
            time.sleep(0.5)
        else:
            raise AssertionError("the server did not get ready")
        long = {"mechanism": "upr4", "n_components": 2048, "dt": 0.005, "duration": 1000.0}
        for _ in range(3):
            assert httpx.post(f"{url}/api/runs", json=long, timeout=30).status_code == 202
        time.sleep(2.0)  # on the workers
        os.killpg(process.pid, signal.SIGINT)
        _, stderr = process.communicate(timeout=scaled(30))
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait(10)
    assert process.returncode == 0, stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    assert "leaked semaphore" not in stderr, stderr


def test_the_resource_tracker_warning_is_silenced_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """The resource tracker's warning filter is added to PYTHONWARNINGS once, however often."""
    from twin.web.server import TRACKER_WARNING, quiet_resource_tracker

    monkeypatch.setenv("PYTHONWARNINGS", "default")
    quiet_resource_tracker()
    quiet_resource_tracker()
    assert os.environ["PYTHONWARNINGS"] == f"default,{TRACKER_WARNING}"


def test_serve_takes_a_worker_niceness_and_refuses_one_out_of_range(
    capsys: pytest.CaptureFixture,
) -> None:
    """`--worker-nice` defaults to 0 (a niced worker yields to a shared machine's every other
    process) and takes 0-19; anything else exits 2 naming the range, before starting."""
    parser = build_parser()
    assert parser.parse_args(["serve"]).worker_nice == 0
    assert parser.parse_args(["serve", "--worker-nice", "10"]).worker_nice == 10
    with pytest.raises(SystemExit) as exited:
        parser.parse_args(["serve", "--worker-nice", "20"])
    assert exited.value.code == 2
    assert "20: niceness is 0-19" in capsys.readouterr().err

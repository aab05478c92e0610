"""A server that talks while it warms (issue 27): health reports `warming` with progress, the
live routes answer 503 with Retry-After, runs are stored queued (202) and run once the server
attaches its session and executor; the viewer's port shows a page that reloads itself."""

from __future__ import annotations

import io
import socket
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from tests.web.support import access, wait_for
from twin.errors import TwinError
from twin.runs.executor import IN_PROCESS, Executor
from twin.sim.live import LiveSession
from twin.web.api import create_app
from twin.web.store import RunStore
from twin.web.warmup import WarmingPage, Warmup

SHORT = {"mechanism": "upr4", "planner": "pid", "n_components": 16, "duration": 1.0}


def test_a_warming_app_answers_queues_runs_and_runs_them_once_attached(tmp_path: Path) -> None:
    """While warming, health reports progress, live is 503 with Retry-After, runs queue, and they
    run once attached."""
    warmup = Warmup(out=io.StringIO())
    warmup.kernel_done("hybrid mtmp")
    with RunStore(tmp_path / "runs.sqlite") as store:
        app = create_app(None, store, access=access(), warmup=warmup)
        with TestClient(app) as client, Executor.start(IN_PROCESS) as executor:
            health = client.get("/api/health").json()
            assert health["status"] == "warming" and health["executor"] is None
            assert health["warming"]["kernels_done"] == 1
            assert health["warming"]["kernels_total"] == warmup.kernels_total
            assert health["warming"]["last_kernel"] == "hybrid mtmp"
            live = client.get("/api/live")
            assert live.status_code == 503 and live.headers["retry-after"] == "2"
            assert "warming up" in live.json()["detail"] and "1 of" in live.json()["detail"]
            assert client.patch("/api/live", json={"beta": 0.5}).status_code == 503
            queued = client.post("/api/runs", json=SHORT)
            assert queued.status_code == 202 and queued.json()["status"] == "queued"
            run_id = queued.json()["id"]
            assert client.get(f"/api/runs/{run_id}").json()["status"] == "queued"

            session = LiveSession({"mechanism": "upr4"})
            try:
                app.state.services.attach(session, executor)
                warmup.ready()
                assert client.get("/api/health").json()["status"] == "ok"
                assert client.get("/api/live").json()["mechanism"] == "upr4"
                assert wait_for(
                    lambda: client.get(f"/api/runs/{run_id}").json()["status"] == "done",
                    timeout=30.0,
                )
            finally:
                session.stop()


def test_a_failed_start_up_says_why() -> None:
    """A failed start-up's snapshot and message carry the error."""
    warmup = Warmup(out=io.StringIO())
    warmup.fail("OSError: no space left on device")
    assert warmup.snapshot()["error"] == "OSError: no space left on device"
    assert "failed to start: OSError" in warmup.message()


def test_progress_lines_name_the_kernel_and_count() -> None:
    """The progress lines name what is compiling, each kernel with its count, and when ready."""
    out = io.StringIO()
    warmup = Warmup(out=out)
    warmup.begin("compiling kernels on 2 cores")
    for label in ("hybrid mtmp", "hybrid qp"):
        warmup.kernel_done(label)
    warmup.ready()
    lines = out.getvalue().splitlines()
    assert lines[0] == "twin: compiling kernels on 2 cores …"
    assert lines[1].startswith(f"twin: kernels 1 of {warmup.kernels_total} ready (hybrid mtmp), ")
    assert lines[-1].startswith("twin: ready in ")


def test_the_warming_page_holds_the_viewer_port_and_moves_on_from_a_taken_one() -> None:
    """The warming page moves past a taken port, answers 503 with a refreshing page, and frees its
    port on close."""
    warmup = Warmup(out=io.StringIO())
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        page = WarmingPage(warmup, "127.0.0.1", port)
        try:
            assert page.port != port
            with pytest.raises(urllib.error.HTTPError) as answer:
                urllib.request.urlopen(f"http://127.0.0.1:{page.port}/", timeout=10)
            assert answer.value.code == 503 and answer.value.headers["Retry-After"] == "2"
            body = answer.value.read().decode()
            assert "http-equiv=refresh" in body and "warming up" in body
        finally:
            page.close()
    with socket.socket() as free:  # closed: the viewer (binding as servers do) can take it
        free.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        free.bind(("127.0.0.1", page.port))


def test_the_warming_page_gives_up_naming_the_ports(monkeypatch: pytest.MonkeyPatch) -> None:
    """With every port tried taken, the warming page raises TwinError naming the ports and --viser-
    port."""
    import twin.web.warmup as module

    monkeypatch.setattr(module, "PORT_TRIES", 1)
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(TwinError, match=rf"{port}-{port}.*--viser-port"):
            WarmingPage(Warmup(out=io.StringIO()), "127.0.0.1", port)

"""The landing page (static/index.html) in a real headless browser while the twin warms: it
polls /api/health (200 while warming), not the live routes (503 until ready), so the browser's
console stays free of errors; once ready it shows the live session."""

from __future__ import annotations

import io
import threading
from pathlib import Path

import pytest
from playwright.sync_api import ConsoleMessage, Request, Response, sync_playwright

from tests.web.support import free_port, wait_for
from tests.web.viewer.test_browser import ARGS, CHROMIUM
from twin.runs.executor import IN_PROCESS, Executor
from twin.sim.live import LiveSession
from twin.web.access import Access
from twin.web.api import create_app
from twin.web.store import RunStore
from twin.web.warmup import Warmup

pytestmark = [
    pytest.mark.serial,
    pytest.mark.skipif(not CHROMIUM.exists(), reason="needs Debian's chromium"),
]


def test_the_landing_page_warms_quietly_then_shows_the_live_session(tmp_path: Path) -> None:
    """While warming: the banner names the progress, the page polls /api/health again and again
    and no response is an error status, nor any console message an error; once ready the
    banner goes and the live session's cells appear."""
    import uvicorn

    warmup = Warmup(out=io.StringIO())
    warmup.kernel_done("hybrid mtmp")
    with RunStore(tmp_path / "runs.sqlite") as store, Executor.start(IN_PROCESS) as executor:
        port = free_port()
        app = create_app(None, store, access=Access.for_server("127.0.0.1", (port,)),
                         warmup=warmup)  # fmt: skip
        server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port,
                                               log_level="warning"))  # fmt: skip
        thread = threading.Thread(target=server.run, daemon=True)
        thread.start()
        assert wait_for(lambda: server.started, timeout=20.0)
        session = LiveSession({"mechanism": "upr4"})
        errors: list[str] = []
        health_polls: list[str] = []
        try:
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
                page = browser.new_page()

                def console(message: ConsoleMessage) -> None:
                    if message.type == "error":
                        errors.append(message.text)

                def answered(response: Response) -> None:
                    if response.status >= 400:
                        errors.append(f"{response.status} {response.url}")

                def requested(request: Request) -> None:
                    if request.url.endswith("/api/health"):
                        health_polls.append(request.url)

                page.on("console", console)
                page.on("pageerror", lambda exc: errors.append(str(exc)))
                page.on("response", answered)
                page.on("request", requested)
                page.goto(f"http://127.0.0.1:{port}/", timeout=30_000)
                page.get_by_text("Warming up").wait_for(timeout=30_000)
                # three more polls while warming: each would have been a 503 from /api/live
                for _ in range(3):
                    with page.expect_request(lambda r: r.url.endswith("/api/health"),
                                             timeout=30_000):  # fmt: skip
                        pass
                assert len(health_polls) >= 4, health_polls
                app.state.services.attach(session, executor)
                warmup.ready()
                page.locator("#warming").wait_for(state="hidden", timeout=30_000)
                page.locator("#live", has_text="upr4").wait_for(timeout=30_000)
                browser.close()
        finally:
            session.stop()
            server.should_exit = True
            thread.join(timeout=10)
    assert errors == [], errors

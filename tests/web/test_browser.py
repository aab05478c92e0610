"""The live twin in a real headless browser: Debian's Chromium driven by Playwright.

Never a downloaded browser: the test uses /usr/bin/chromium (`.ci/run` installs Debian's
`chromium` package when it is missing) and is skipped where it is absent.
"""

from __future__ import annotations

import functools
import http.server
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient
from PIL import Image
from playwright.sync_api import sync_playwright

from tests.figures import record
from tests.web.support import TOKEN, access, free_port, wait_for
from tests.web.viser_client import PROTOCOL
from twin.sim.live import LiveSession
from twin.web.access import Access
from twin.web.api import create_app
from twin.web.scene import Viewer, start_viewer
from twin.web.store import RunStore

CHROMIUM = Path("/usr/bin/chromium")
ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


@pytest.fixture
def live() -> Iterator[tuple[LiveSession, Viewer]]:
    session = LiveSession({"sea_state": 4})
    session.start()
    viewer = start_viewer(session, port=free_port())
    yield session, viewer
    viewer.stop()
    session.stop()


def test_browser_shows_the_twin_and_controls_the_session(
    live: tuple[LiveSession, Viewer], tmp_path: Path
) -> None:
    """The page renders the 3D canvas and the GUI (planner dropdown, β slider); Pause and the
    β number box act on the live session; the screenshot is not blank."""
    session, viewer = live
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        try:
            # Software WebGL (SwiftShader) renders on the CPU: a modest viewport keeps the
            # page responsive on a 2-core machine.
            page = browser.new_page(viewport={"width": 1200, "height": 760})
            page.goto(f"http://127.0.0.1:{viewer.port}", timeout=30_000)
            page.wait_for_selector("canvas", timeout=30_000)
            page.get_by_text("Planner", exact=True).wait_for(timeout=30_000)
            page.get_by_text("β", exact=True).wait_for()
            assert wait_for(lambda: len(viewer.server.get_clients()) == 1, timeout=10.0)

            # force: skip Playwright's wait for a "stable" element, which a page redrawing
            # its canvas every frame reaches slowly
            page.get_by_role("button", name="Pause").click(force=True)
            assert wait_for(lambda: not session.controls.playing, timeout=10.0)

            # The β row: its label, then the slider's number box; typing sends a GUI update.
            row = page.locator("div", has=page.get_by_text("β", exact=True)).filter(
                has=page.locator("input")
            )
            box = row.last.locator("input").last
            box.fill("0.35", force=True)
            box.press("Enter")
            assert wait_for(lambda: session.scenario.beta == pytest.approx(0.35), timeout=10.0)
            # …and the REST view of the same live session reports it
            with RunStore(tmp_path / "runs.sqlite") as store:
                client = TestClient(create_app(session, store, access=access()))
                assert client.get("/api/live").json()["beta"] == pytest.approx(0.35)

            time.sleep(1.0)  # a few rendered frames of the scene
            shot = tmp_path / "twin.png"
            page.screenshot(path=str(shot))
        finally:
            browser.close()
    pixels = np.asarray(Image.open(shot).convert("RGB"), dtype=float)
    assert pixels.std() > 20.0  # sea, hull, panel: far from one flat colour
    scene = pixels[200:700, 50:700]  # the 3D view, clear of the GUI panel and toasts
    assert scene.std(axis=(0, 1)).max() > 5.0


def _serve_folder(folder: Path) -> tuple[http.server.ThreadingHTTPServer, int]:
    """A static web server on another port: another origin, as any site the operator opens."""
    port = free_port()
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", port), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, port


#: what a page of another origin runs: open the viewer's websocket, report how it went
OPEN_WEBSOCKET = """([url, protocol]) => new Promise((resolve) => {
  const ws = new WebSocket(url, [protocol]);
  ws.onopen = () => { ws.close(); resolve("open"); };
  ws.onerror = () => resolve("error");
  setTimeout(() => resolve("timeout"), 5000);
})"""


def test_a_browser_unlocks_the_viewer_with_the_token(tmp_path: Path) -> None:
    """With a token, a browser sees its own Access panel and read-only controls: Pause does
    nothing until it enters the token and unlocks; then Pause pauses the session. A page of
    another origin in the same browser cannot even open the viewer's websocket."""
    session = LiveSession({"sea_state": 3})
    session.start()
    viewer = start_viewer(session, port=free_port(), access=Access(token=TOKEN))
    (tmp_path / "index.html").write_text("<!doctype html><title>another site</title>")
    site, site_port = _serve_folder(tmp_path)
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
            try:
                other = browser.new_page()
                other.goto(f"http://127.0.0.1:{site_port}/index.html", timeout=30_000)
                ws_url = f"ws://127.0.0.1:{viewer.port}/"
                cross = other.evaluate(OPEN_WEBSOCKET, [ws_url, PROTOCOL])
                assert cross == "error", cross
                assert session.controls.playing and not viewer.gui.panels

                page = browser.new_page(viewport={"width": 1200, "height": 760})
                page.goto(f"http://127.0.0.1:{viewer.port}", timeout=30_000)
                page.get_by_role("button", name="Unlock controls").wait_for(timeout=30_000)
                pause = page.get_by_role("button", name="Pause")
                assert wait_for(pause.is_disabled, timeout=10.0)  # read-only until unlocked
                pause.click(force=True)
                time.sleep(1.0)
                assert session.controls.playing  # locked: the click changed nothing

                row = page.locator("div", has=page.get_by_text("Token", exact=True)).filter(
                    has=page.locator("input")
                )
                field = row.last.locator("input").last
                field.fill(TOKEN, force=True)
                field.press("Enter")
                time.sleep(0.5)  # the text reaches the server before the click
                page.get_by_role("button", name="Unlock controls").click(force=True)
                assert wait_for(lambda: len(viewer.gui._unlocked) == 1, timeout=10.0)
                assert wait_for(lambda: not pause.is_disabled(), timeout=10.0)
                pause.click(force=True)
                assert wait_for(lambda: not session.controls.playing, timeout=10.0)
            finally:
                browser.close()
    finally:
        site.shutdown()
        viewer.stop()
        session.stop()
    record("attack_cross_origin_websocket_browser", page_origin=f"http://127.0.0.1:{site_port}",
           websocket=cross, locked_click="changed nothing")  # fmt: skip

"""The live twin in a real headless browser: Debian's Chromium driven by Playwright.

Never a downloaded browser: the test uses /usr/bin/chromium (`.ci/run` installs Debian's
`chromium` package when it is missing) and is skipped where it is absent.

Software WebGL keeps a rendering page busy on a small machine: each Playwright action on
it takes a second or more, so the tests act through the session where REST would, and use
the page for what only a browser shows (its scene tree, its camera, its panel, its console).
Every page is drawn at half the resolution per side (viser's `fixedDpr` address parameter).
The first test renders the twin as served by default; the others, which look at the panel
and the scene tree rather than at pixels, use the viewer's "light" graphics (no environment
map: measured, the page then answers a Playwright call in 0.5 s instead of 5-8 s while the
session runs).
"""

from __future__ import annotations

import functools
import http.server
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import urlsplit

import numpy as np
import pytest
from fastapi.testclient import TestClient
from PIL import Image
from playwright.sync_api import sync_playwright

from tests.figures import record
from tests.timing import scaled
from tests.web.support import TOKEN, access, free_port, wait_for
from tests.web.viser_client import PROTOCOL
from twin.runs.executor import IN_PROCESS, Executor
from twin.sim import Scenario, simulate
from twin.sim.live import LiveSession
from twin.web.access import Access
from twin.web.api import create_app
from twin.web.jobs import SweepRunner
from twin.web.store import RunStore
from twin.web.viewer import FRAMING, Viewer, start_viewer
from twin.web.viewer.frame_state import read_frame

CHROMIUM = Path("/usr/bin/chromium")
#: the page drawn at half the resolution per side (viser's development parameter): a paused
#: session's page then idles between frames instead of drawing the environment map again
HALF_RESOLUTION = "/?fixedDpr=0.5"
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
    viewer = start_viewer(session, access=Access(), port=free_port())
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
            page.goto(f"http://127.0.0.1:{viewer.port}{HALF_RESOLUTION}", timeout=30_000)
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
    viewer = start_viewer(session, port=free_port(), access=Access(token=TOKEN), graphics="light")
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
                page.goto(f"http://127.0.0.1:{viewer.port}{HALF_RESOLUTION}", timeout=30_000)
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


#: the browser's scene tree (viser's client exposes it for end-to-end tests): node names
SCENE_NODES = "() => Object.keys(window.__viserSceneTree.getState())"
#: an image of the panel that has loaded (the heatmap: viser hands images over as blobs)
HEATMAP_LOADED = """() => [...document.images].some(
    (img) => img.src.startsWith("blob:") && img.complete && img.naturalWidth > 200)"""


def _nodes(page: object) -> list[str]:
    return page.evaluate(SCENE_NODES)  # type: ignore[attr-defined]


def test_browser_ghost_replay_heatmap_and_a_clean_console_through_switches(
    tmp_path: Path,
) -> None:
    """Issue 16 in a real browser, with the console watched throughout:

    - switching through all three mechanisms rebuilds the browser's scene and points its
      camera at each (the camera the browser reports is the framing view);
    - a second planner appears as the ghost nodes in the browser's scene, and in its readout;
    - a stored run replays, and the panel's time box seeks it;
    - the Operability folder's button runs a sweep and its heatmap image loads in the panel;
    - and the console logged no error ("Tried to update non-existent component" included).
    """
    store = RunStore(tmp_path / "runs.sqlite")
    scenario = Scenario(duration=6.0, sea_state=3)
    run = store.create(scenario)
    store.finish(run.id, simulate(scenario))
    executor = Executor.start(IN_PROCESS)
    sweeps = SweepRunner(store)
    sweeps.start(executor)
    session = LiveSession({"sea_state": 3})
    session.start()
    viewer = start_viewer(session, access=Access(), port=free_port(), store=store, sweeps=sweeps,
                          api_url="http://127.0.0.1:8000", graphics="light")  # fmt: skip
    errors: list[str] = []
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
            try:
                page = browser.new_page(viewport={"width": 1000, "height": 640})
                page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
                page.on("pageerror", lambda e: errors.append(str(e)))
                page.goto(f"http://127.0.0.1:{viewer.port}{HALF_RESOLUTION}", timeout=30_000)
                page.get_by_text("Compare with", exact=True).wait_for(timeout=30_000)
                (client,) = viewer.server.get_clients().values()

                # every mechanism: the browser's scene has its nodes, its camera frames it
                for mechanism, node in (("upu3up", "/target/container"),
                                        ("upr4", "/base/top/pad"), ("hybrid", "/target/tower")):
                    session.patch({"mechanism": mechanism, "planner": None})
                    page.wait_for_function(f"() => ({SCENE_NODES})().includes('{node}')",
                                           timeout=30_000)  # fmt: skip
                    fs = read_frame(session)
                    assert fs is not None and fs.scenario.mechanism == mechanism
                    # the browser itself reported the framing (its hold ended on its message,
                    # not on the server's write)...
                    assert wait_for(lambda: client.client_id not in viewer.scene.unframed,
                                    timeout=scaled(15.0)), (mechanism, viewer.scene.unframed)
                    # ...and it is the view from the target: the camera was framed at the
                    # build's frame, and the base has moved with the sea since (by more than
                    # the tolerance when the machine is slow), carrying camera and look-at alike
                    framing, look_at = viewer.scene.camera_pose(FRAMING, viewer.scene.last or fs)
                    near = 0.05 * np.linalg.norm(framing - look_at)
                    assert wait_for(
                        lambda view=framing - look_at, tol=near: np.linalg.norm(
                            client.camera.position - client.camera.look_at - view) < tol,
                        timeout=scaled(15.0),
                    ), (mechanism, client.camera.position, client.camera.look_at, framing, look_at)

                # a second planner: the ghost in the browser's scene and in the readout
                session.patch({"compare_planner": "pi"})
                page.wait_for_function(
                    f"() => ({SCENE_NODES})().some((n) => n.startsWith('/base/ghost/'))",
                    timeout=30_000,
                )
                page.get_by_text("ghost pi:", exact=False).first.wait_for(timeout=15_000)

                # a stored run replayed (as POST /api/live/replay), then sought from the panel
                session.replay(store.result(run.id), run.id, t=1.0, playing=False)
                (panel,) = viewer.gui.panels.values()
                assert wait_for(lambda: panel.settings["replay_t"].max == 6.0, timeout=10.0)
                page.get_by_text(f"Replaying run {run.id[:8]}", exact=False).wait_for(
                    timeout=15_000
                )
                row = page.locator(
                    "div", has=page.get_by_text("Replay time [s]", exact=True)
                ).filter(has=page.locator("input"))
                box = row.last.locator("input").last
                box.fill("3.5", force=True)
                box.press("Enter")
                assert wait_for(lambda: (session.replaying or {}).get("t") == 3.5, timeout=15.0)
                page.get_by_text("t = 3.50 s", exact=False).first.wait_for(timeout=15_000)

                # back to live, then a sweep from the panel: its heatmap loads in the browser
                session.reset()
                page.get_by_text(f"Replaying run {run.id[:8]}", exact=False).first.wait_for(
                    state="detached", timeout=15_000
                )  # the panel is back to live before its button is pressed
                # the smallest sweep the sliders allow: the heatmap is what is tested here
                for name, value in (("sweep_hs_points", 3), ("sweep_seeds", 1),
                                    ("sweep_duration", 10.0)):  # fmt: skip
                    panel.settings[name].value = value
                button = page.get_by_role("button", name="Run sweep")
                for _ in range(3):
                    # the click event on the button itself: a notification toast over it or a
                    # re-layout under the pointer cannot take it
                    button.dispatch_event("click")
                    if wait_for(lambda: viewer.gui.sweep_id is not None, timeout=15.0):
                        break
                if viewer.gui.sweep_id is None:
                    page.screenshot(path=str(tmp_path / "no-sweep.png"), full_page=True)
                assert viewer.gui.sweep_id is not None, (
                    viewer.gui.last_error, button.count(), tmp_path / "no-sweep.png",
                    page.locator("body").inner_text()[-2000:],
                )  # fmt: skip
                # its runs take what a loaded machine gives them: the panel follows the sweep
                # to its end (done or failed), then the browser loads its image
                assert wait_for(lambda: viewer.gui.sweep_id is None, timeout=scaled(120.0)), (
                    viewer.gui.sweep_status.content
                )
                assert viewer.gui.heatmap is not None, viewer.gui.sweep_status.content
                page.wait_for_function(HEATMAP_LOADED, timeout=1000 * scaled(30.0))
                page.get_by_text("the ring marks the current sea", exact=False).wait_for(
                    timeout=15_000
                )
                page.wait_for_timeout(1000)  # late messages of the last changes
            finally:
                browser.close()
    finally:
        viewer.stop()
        session.stop()
        sweeps.shutdown()
        executor.close()
        store.close()
    assert errors == [], errors[:5]


def test_api_docs_render_with_the_network_blocked(tmp_path: Path) -> None:
    """/docs (Swagger UI) and /redoc render their operations with every request to any host
    but the server aborted: their scripts and styles come from the server itself."""
    with RunStore(tmp_path / "runs.sqlite") as store:
        port = free_port()
        app = create_app(LiveSession(), store, access=Access.for_server("127.0.0.1", (port,)))
        import uvicorn

        server = uvicorn.Server(
            uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning")
        )
        thread = threading.Thread(target=server.run, daemon=True)
        thread.start()
        assert wait_for(lambda: server.started, timeout=20.0)
        blocked: list[str] = []

        def only_local(route: object) -> None:
            url = route.request.url  # type: ignore[attr-defined]
            if urlsplit(url).hostname in ("127.0.0.1", "localhost") or url.startswith("data:"):
                route.continue_()  # type: ignore[attr-defined]
            else:
                blocked.append(url)
                route.abort()  # type: ignore[attr-defined]

        try:
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
                try:
                    page = browser.new_page()
                    page.route("**/*", only_local)
                    page.goto(f"http://127.0.0.1:{port}/docs", timeout=30_000)
                    page.get_by_text("/api/live/replay", exact=True).first.wait_for(
                        timeout=30_000
                    )
                    page.goto(f"http://127.0.0.1:{port}/redoc", timeout=30_000)
                    page.locator("h2", has_text="Replay Live").first.wait_for(timeout=30_000)
                finally:
                    browser.close()
        finally:
            server.should_exit = True
            thread.join(timeout=10)
    assert blocked == []

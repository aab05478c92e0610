"""The live demo at first sight, in a real headless browser (Debian's Chromium, as
test_browser_scene.py): each mechanism at its demo defaults (`twin.sim.live.LIVE_DEMO`, what
`twin serve` and the viewer's mechanism switch start) works within its limits, fills at least
a third of the view it starts in, draws no line longer than the scene, and its readout shows a
tip error of millimetres. A screenshot of each is kept under the test's tmp_path."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from playwright.sync_api import sync_playwright

from tests.web.support import free_port, wait_for
from tests.web.viewer.test_browser import ARGS, CHROMIUM, HALF_RESOLUTION
from tests.web.viewer.test_browser_scene import HEIGHT, WIDTH, project
from twin.sim.live import LiveSession, live_demo
from twin.web.access import Access
from twin.web.viewer import FRAMING, mechanism_points, start_viewer
from twin.web.viewer.frame_state import read_frame

pytestmark = [
    pytest.mark.serial,
    pytest.mark.skipif(not CHROMIUM.exists(), reason="no /usr/bin/chromium"),
]

#: [mm] the largest tip error the readout may show at the demo defaults
TIP_MM = 10.0
#: the readout's tip error, as the browser shows it
TIP_NOW = re.compile(r"tip error now: ([0-9.]+) mm")


@pytest.mark.parametrize("mechanism", ["hybrid", "upu3up", "upr4"])
def test_each_mechanism_at_its_demo_defaults_looks_right(mechanism: str, tmp_path: Path) -> None:
    """After 20 s of its demo: no sample beyond a limit and nothing at one; projected through
    the browser's own camera the mechanism spans at least a third of the canvas's height; every
    trail segment stays within the mechanism's size of its held point (no line across the
    scene); the browser's readout shows a tip error under 10 mm."""
    session = LiveSession(live_demo(mechanism))
    session.pause()
    session.step(400)  # 20 s at dt = 0.05 s
    viewer = start_viewer(session, access=Access(), port=free_port(), graphics="light")
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
            try:
                page = browser.new_page(viewport={"width": WIDTH, "height": HEIGHT})
                page.goto(f"http://127.0.0.1:{viewer.port}{HALF_RESOLUTION}", timeout=60_000)
                page.get_by_text("tip error now", exact=False).first.wait_for(timeout=60_000)
                assert wait_for(lambda: len(viewer.server.get_clients()) == 1, 10.0)
                (client,) = viewer.server.get_clients().values()
                fs = read_frame(session)
                assert fs is not None and viewer.scene.last is not None
                position, look_at = viewer.scene.camera_pose(FRAMING, viewer.scene.last)
                view = position - look_at
                assert wait_for(lambda: np.linalg.norm(client.camera.position
                                                       - client.camera.look_at - view)
                                < 0.05 * np.linalg.norm(view), 30.0)  # fmt: skip
                canvas = page.evaluate(
                    "() => { const c = document.querySelector('canvas').getBoundingClientRect();"
                    " return [c.width, c.height]; }"
                )
                shown = project(mechanism_points(fs), client.camera, *canvas)
                assert np.all(np.isfinite(shown))
                assert np.ptp(shown, axis=0).max() >= canvas[1] / 3, (mechanism, shown)

                trail = np.asarray(viewer.scene.trail.handle.points).reshape(-1, 3)
                reach = np.linalg.norm(trail - fs.held[:3, 3], axis=1).max()
                assert reach <= viewer.scene.size, (mechanism, reach, viewer.scene.trail_scale)
                label = viewer.scene.trail_label.text
                assert f"×{viewer.scene.trail_scale:,.0f}".replace(",", " ") in label

                text = page.get_by_text("tip error now", exact=False).first.inner_text()
                match = TIP_NOW.search(text)
                assert match and float(match.group(1)) < TIP_MM, text
                readout = viewer.gui.readout.content
                assert "at a limit: nothing" in readout and " nm" not in readout, readout
                assert session.snapshot()["metrics"]["violations"] == 0
                page.screenshot(path=str(tmp_path / f"{mechanism}.png"))
            finally:
                browser.close()
    finally:
        viewer.stop()
        session.stop()

"""What the scene shows in a real headless browser (issue 27 item 5): Debian's Chromium,
whose WebGL is SwiftShader (software, on the CPU), driven by Playwright.

- A browser that reports a software renderer is switched to light graphics by itself (and
  back to full on request), whatever the server's `--graphics`.
- Every mechanism's views draw it large enough: the close-up (the view each mechanism
  starts in) keeps the mechanism and its target inside the window, and no view draws the
  mechanism smaller than 80 px. The size is measured by projecting the mechanism's points
  through the camera the browser itself reports (position, look-at, field of view,
  aspect) onto the browser's canvas.
- The frame time in light graphics is measured (requestAnimationFrame intervals) and
  recorded beside full graphics' in the same run; it is held to no wall-clock budget, only
  to being below full graphics' (measured: 167 vs 567 ms at half resolution, 1200 × 760,
  on a 2-core machine).

The fixtures and Chromium flags are test_browser.py's.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import numpy as np
import pytest
from playwright.sync_api import Page, sync_playwright

from tests.figures import record
from tests.web.support import free_port, wait_for
from tests.web.viewer.support import CameraReports
from tests.web.viewer.test_browser import ARGS, CHROMIUM, HALF_RESOLUTION
from twin.sim.live import LiveSession
from twin.web.access import Access
from twin.web.viewer import FRAMING, Viewer, framed_points, mechanism_points, start_viewer
from twin.web.viewer.cameras import VIEWS
from twin.web.viewer.frame_state import read_frame

pytestmark = [
    pytest.mark.serial,
    pytest.mark.skipif(not CHROMIUM.exists(), reason="no /usr/bin/chromium"),
]

#: the window of the tests: a laptop browser's
WIDTH, HEIGHT = 1200, 760
#: [px] the issue's smallest mechanism in any view
MIN_PX = 80.0
#: the browser's environment map and shadow-casting lights (three.js scene, viser's test hook)
LIGHTING = """() => {
  const scene = window.__viserMutable.scene;
  let shadows = 0;
  scene.traverse((o) => { if (o.isLight && o.castShadow) shadows += 1; });
  return { environment: scene.environment !== null, shadows: shadows };
}"""
#: [ms] intervals between `n` animation frames (each one a render of the scene by viser)
FRAME_TIMES = """(n) => new Promise((resolve) => {
  const stamps = [];
  const tick = (now) => {
    stamps.push(now);
    if (stamps.length > n) resolve(stamps.slice(1).map((t, i) => t - stamps[i]));
    else requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
})"""


@pytest.fixture
def full_viewer() -> Iterator[tuple[LiveSession, Viewer]]:
    """A playing session served with the default ("full") graphics."""
    session = LiveSession({"sea_state": 4})
    session.start()
    viewer = start_viewer(session, access=Access(), port=free_port(), graphics="full")
    yield session, viewer
    viewer.stop()
    session.stop()


def project(points: np.ndarray, camera: object, width: float, height: float) -> np.ndarray:
    """(n, 2) [px] pinhole projection of (n, 3) [m] points through a browser's camera (viser's
    `CameraHandle`: position, look_at, up_direction, fov (vertical) [rad], aspect) onto a
    canvas of `width` × `height`; x right, y down. Points behind the camera give NaN."""
    position = np.asarray(camera.position, float)  # type: ignore[attr-defined]
    forward = np.asarray(camera.look_at, float) - position  # type: ignore[attr-defined]
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.asarray(camera.up_direction, float))  # type: ignore[attr-defined]
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    v = points - position
    depth = v @ forward
    half_h = np.tan(camera.fov / 2)  # type: ignore[attr-defined]
    half_w = half_h * camera.aspect  # type: ignore[attr-defined]
    x = (v @ right) / (depth * half_w)
    y = (v @ up) / (depth * half_h)
    out = np.stack([(x + 1) / 2 * width, (1 - y) / 2 * height], -1)
    out[depth <= 0] = np.nan
    return out


def lighting(page: Page) -> dict:
    return page.evaluate(LIGHTING)


def test_a_software_renderer_gets_light_graphics_and_every_view_shows_the_mechanism(
    full_viewer: tuple[LiveSession, Viewer],
) -> None:
    """Served with full graphics, headless Chromium (SwiftShader) reports its renderer and is
    switched to light graphics: its panel says "light", its scene has no environment map and
    no shadow-casting light, and it was told why. Switched back to full, the environment map
    and the sun's shadows return to it. Then, for each mechanism and view, the mechanism
    projected through the browser's own camera spans ≥ 80 px (but from the hybrid
    system's walkway, a person's eye on the gangway), and the close-up (each
    mechanism's starting view) has the mechanism and its target inside the window. The
    light and full frame times are recorded."""
    session, viewer = full_viewer
    sizes: dict[str, float] = {}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        try:
            page = browser.new_page(viewport={"width": WIDTH, "height": HEIGHT})
            page.goto(f"http://127.0.0.1:{viewer.port}{HALF_RESOLUTION}", timeout=60_000)
            page.get_by_text("Graphics", exact=True).wait_for(timeout=60_000)
            assert wait_for(lambda: len(viewer.gui.panels) == 1, timeout=10.0)
            ((client_id, panel),) = viewer.gui.panels.items()

            # the page reported SwiftShader: this browser alone went light
            assert wait_for(lambda: panel.graphics.value == "light", timeout=60.0), (
                viewer.renderers
            )
            assert "swiftshader" in viewer.renderers[client_id].lower()
            assert viewer.gui.graphics == "full"  # the server's setting is unchanged
            page.get_by_text("Light graphics", exact=True).wait_for(timeout=15_000)
            page.wait_for_function(f"() => !({LIGHTING})().environment", timeout=60_000)
            assert lighting(page) == {"environment": False, "shadows": 0}
            light = np.median(page.evaluate(FRAME_TIMES, 30))

            # the way back (the panel's Graphics dropdown calls this)
            viewer.gui.set_graphics(panel, "full")
            page.wait_for_function(f"() => ({LIGHTING})().environment", timeout=120_000)
            assert lighting(page)["shadows"] > 0
            full = np.median(page.evaluate(FRAME_TIMES, 5))
            viewer.gui.set_graphics(panel, "light")
            page.wait_for_function(f"() => !({LIGHTING})().environment", timeout=120_000)

            (client,) = viewer.server.get_clients().values()
            reports = CameraReports(client)
            canvas = page.evaluate(
                "() => { const c = document.querySelector('canvas').getBoundingClientRect();"
                " return [c.width, c.height]; }"
            )
            for mechanism in ("hybrid", "upu3up", "upr4"):
                if session.scenario.mechanism != mechanism:
                    session.patch({"mechanism": mechanism, "planner": None})
                    assert wait_for(
                        lambda m=mechanism: viewer.scene.mechanism_name == m, timeout=30.0
                    )
                for view in VIEWS:
                    # the browser's own report of the view it was given, not viser's record
                    # of what was sent (`CameraReports`); sent again if a report the browser
                    # sent before it came after it
                    for _ in range(3):
                        since = reports.mark()
                        viewer.scene.set_camera(view, [client])
                        position, look_at = viewer.scene.camera_pose(view, viewer.scene.last)
                        camera = reports.wait_view(since, position, look_at, timeout=10.0)
                        if camera is not None:
                            break
                    else:
                        raise AssertionError((mechanism, view, reports.reports[-3:], position))
                    fs = read_frame(session)
                    assert fs is not None and fs.scenario.mechanism == mechanism
                    if view == "walkway" and mechanism == "hybrid":
                        continue  # a person's eye on the gangway: the mechanism is underfoot
                    shown = project(mechanism_points(fs), camera, *canvas)
                    assert np.all(np.isfinite(shown)), (mechanism, view)
                    size = float(np.ptp(shown, axis=0).max())
                    sizes[f"{mechanism}/{view}"] = round(size, 1)
                    assert size >= MIN_PX, (mechanism, view, size)
                    if view == FRAMING:
                        # the mechanism and its target, inside the window
                        whole = project(framed_points(fs), camera, *canvas)
                        assert np.all(np.isfinite(whole))
                        assert np.all(whole >= 0) and np.all(whole <= canvas), (mechanism, whole)
            time.sleep(0.5)
        finally:
            browser.close()
    record("browser_scene_views", projected_px=sizes, frame_ms_light=round(float(light), 1),
           frame_ms_full=round(float(full), 1))  # fmt: skip
    print(f"mechanism sizes [px]: {sizes}; frame [ms]: light {light:.0f}, full {full:.0f}")
    assert 0.0 < light < full  # relative: the light graphics are the cheaper, in one run

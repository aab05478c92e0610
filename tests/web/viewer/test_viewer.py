"""The render loop: it draws at the frame rate while a browser watches, and rests without one."""

from __future__ import annotations

import time

from tests.web.support import wait_for
from tests.web.viewer.support import caught_up, connect
from tests.web.viser_client import ViserClient
from twin.sim.live import LiveSession
from twin.web.viewer import (
    ClientPanel,
    Viewer,
)


def test_render_loop_runs_at_30_fps(
    viewer: Viewer, session: LiveSession, browser: tuple[ViserClient, ClientPanel]
) -> None:
    """With a browser connected, the loop counts its own frames: ≥ 25 in 1 s.

    It is paced to FPS = 40 and measured 39-40 frames/s on an idle 2-core machine with the
    session playing; 25 leaves room for a loaded test machine while still failing a loop
    that renders far below the 30 fps the issue asks for (e.g. one blocked on a client).
    """
    session.play()
    frames = viewer.frames
    time.sleep(1.0)
    assert viewer.frames - frames >= 25


def test_no_render_work_without_a_browser(viewer: Viewer, session: LiveSession) -> None:
    """With no browser connected the render loop draws nothing (no frame, no scene or GUI
    update), playing session or not: it sleeps until one connects. It counts its sleeps, so
    the test waits for those, not for a time."""
    session.play()
    calls: list[float] = []
    draw = viewer._draw
    viewer._draw = lambda fs: calls.append(fs.t) or draw(fs)  # type: ignore[method-assign]
    frames, idle = viewer.frames, viewer.idle_waits
    session.step(5)
    assert wait_for(lambda: viewer.idle_waits >= idle + 2, 10.0)
    assert (calls, viewer.frames) == ([], frames)
    assert not viewer.watched()


def test_a_browser_that_connects_gets_the_newest_frame(
    viewer: Viewer, session: LiveSession
) -> None:
    """A browser that connects to a resting viewer wakes it: the scene catches up with what
    the session did meanwhile (a mechanism switch included), and once it leaves the loop
    rests again."""
    session.patch({"mechanism": "upr4", "planner": None})
    session.step(7)
    assert wait_for(lambda: viewer.idle_waits >= 1, 10.0)
    assert viewer.scene.mechanism_name == "hybrid"  # nobody watched: nothing was rebuilt
    frames = viewer.frames
    client, _ = connect(viewer)
    try:
        assert wait_for(caught_up(viewer, session), 10.0)
        assert wait_for(lambda: viewer.scene.mechanism_name == "upr4")  # set last in a build
        assert wait_for(lambda: viewer.frames > frames)
    finally:
        client.close()
    assert wait_for(lambda: not viewer.watched(), 10.0)
    idle = viewer.idle_waits
    assert wait_for(lambda: viewer.idle_waits > idle, 10.0)
    frames = viewer.frames
    assert wait_for(lambda: viewer.idle_waits > idle + 1, 10.0)
    assert viewer.frames == frames

"""The framing hold after a build (`Cameras.frame`, `settle_framing`, `camera_reported`): a
browser whose camera message from before the new framing arrives after it is put back, however
late, until the browser has reported the framing; not after that, not once another view was
asked for, and not past the hold's cap."""

from __future__ import annotations

import asyncio
import contextlib
import threading
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from twin.web.viewer import cameras
from twin.web.viewer.cameras import FRAMING, Cameras

FRAMED = (np.array([10.0, 0.0, 5.0]), np.array([0.0, 0.0, 1.0]))  # position, look-at [m]


class Browser:
    """A viser client as the cameras see it: a camera viser updates from its messages (and
    from the server's own writes, before the browser has seen them)."""

    def __init__(self) -> None:
        self.client_id = 1
        self.camera = SimpleNamespace(
            position=np.zeros(3), look_at=np.array([1.0, 0.0, 0.0]), client=self
        )

    def atomic(self) -> Any:
        return contextlib.nullcontext()

    def stale(self) -> None:
        """Its old view comes back (a camera message sent before the framing arrived)."""
        self.camera.position, self.camera.look_at = np.zeros(3), np.array([1.0, 0.0, 0.0])

    def report(self, scene: Cameras) -> None:
        """It sends what it shows (viser awaits `camera_reported` with it)."""
        asyncio.run(scene.camera_reported(self.camera))  # type: ignore[arg-type]

    def framed(self) -> bool:
        return bool(np.allclose(self.camera.position, FRAMED[0]))


@pytest.fixture
def scene(monkeypatch: pytest.MonkeyPatch) -> Cameras:
    monkeypatch.setattr(cameras, "FRAMING_RESEND", 0.0)  # re-framed at every frame
    scene = Cameras()
    scene.last, scene.clip = SimpleNamespace(), (0.1, 1000.0)  # type: ignore[assignment]
    scene.camera_pose = lambda view, fs: FRAMED if view == FRAMING else (  # type: ignore[method-assign]
        np.array([0.0, 50.0, 50.0]), np.zeros(3))
    return scene


def test_a_stale_view_is_put_back_until_the_browser_reports_the_framing(
    scene: Cameras, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Stale views, however late, are framed again while the browser has not reported the
    framing; its first report of it ends the hold, and its user's own view is then kept."""
    browser = Browser()
    scene.frame([browser])
    assert browser.framed()
    clock = [cameras.time.monotonic()]
    monkeypatch.setattr(cameras.time, "monotonic", lambda: clock[0])
    for late in (0.1, 5.0, 20.0):  # a loaded machine: the stale message comes seconds late
        browser.stale()
        browser.report(scene)  # a report of another view: the hold stays
        assert scene.unframed == {browser.client_id}
        clock[0] += late
        scene.settle_framing([browser])
        assert browser.framed(), late
    browser.report(scene)  # the browser shows the framing and says so
    assert scene.unframed == frozenset()
    browser.stale()  # now a view of its user's
    scene.settle_framing([browser])
    assert not browser.framed()


def test_a_report_of_the_framing_before_a_stale_one_is_not_taken_for_the_user(
    scene: Cameras,
) -> None:
    """The hold is per build: a browser that reported the framing of an earlier build is held
    again at the next one."""
    browser = Browser()
    scene.frame([browser])
    browser.report(scene)
    assert scene.unframed == frozenset()
    scene.frame([browser])
    assert scene.unframed == {browser.client_id}
    browser.stale()
    scene.settle_framing([browser])
    assert browser.framed()


def test_no_hold_once_another_view_is_asked_or_past_its_cap(
    scene: Cameras, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The framing is not forced back once the user asked for another view, nor after the
    hold's cap for a browser that never reported it, nor for a browser that has left."""
    browser = Browser()
    scene.frame([browser])
    scene.set_camera("overview", [browser])  # the user asks for another view: it is kept
    scene.settle_framing([browser])
    assert not browser.framed()
    monkeypatch.setattr(cameras, "FRAMING_HOLD", -1.0)  # a hold whose cap has passed
    scene.frame([browser])
    browser.stale()
    scene.settle_framing([browser])
    assert not browser.framed()
    assert scene.unframed == frozenset()
    monkeypatch.setattr(cameras, "FRAMING_HOLD", 30.0)
    scene.frame([browser])
    scene.settle_framing([])  # it left
    assert scene.unframed == frozenset()


def test_a_held_browser_that_is_slow_to_answer_is_not_sent_the_view_at_every_frame(
    scene: Cameras, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Re-framings of a browser still off the framing are `FRAMING_RESEND` apart."""
    monkeypatch.setattr(cameras, "FRAMING_RESEND", 0.25)
    clock = [100.0]
    monkeypatch.setattr(cameras.time, "monotonic", lambda: clock[0])
    browser = Browser()
    scene.frame([browser])
    sent = []
    scene._send = lambda view, clients: sent.append(clock[0])  # type: ignore[method-assign]
    browser.stale()
    for _ in range(10):  # 10 frames 0.125 s apart, the browser stuck on its stale view
        scene.settle_framing([browser])
        clock[0] += 0.125
    assert sent == [100.0, 100.25, 100.5, 100.75, 101.0]


def test_a_view_asked_for_while_a_re_framing_is_decided_is_the_one_kept(scene: Cameras) -> None:
    """The render thread's re-framing and a view asked for from another thread (the panel, a
    test) are one step each: a view asked for while `settle_framing` is deciding is sent
    after its re-framing, and ends the hold. (Before, the re-framing was decided, the lock
    let go, the view sent and the hold ended, and then the re-framing sent: the browser went
    back to the close-up, seen in CI as a camera off the mechanism.)"""
    browser = Browser()
    scene.frame([browser])
    browser.stale()
    views: list[str] = []
    send = scene._send
    scene._send = lambda view, clients: (views.append(view), send(view, clients))  # type: ignore[method-assign]
    asked = threading.Event()
    other = threading.Thread(target=lambda: (asked.set(), scene.set_camera("overview", [browser])))
    camera = browser.camera

    class Deciding:
        """The browser's camera, read by `settle_framing` while it decides: the view is asked
        for from the other thread right then, which has all the time it needs to get in."""

        def __getattr__(self, name: str) -> Any:
            if not other.is_alive() and not asked.is_set():
                other.start()
                asked.wait()
                other.join(timeout=0.5)  # blocked on the hold's lock: it cannot get in
            return getattr(camera, name)

    browser.camera = Deciding()  # type: ignore[assignment]
    scene.settle_framing([browser])
    other.join()
    browser.camera = camera
    assert views == [FRAMING, "overview"]
    assert not browser.framed() and scene.unframed == frozenset()

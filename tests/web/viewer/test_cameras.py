"""The framing hold after a build (`Cameras.frame`, `settle_framing`): a browser whose camera
message from before the new framing arrives after it is put back; not after the hold, and not
once another view was asked for."""

from __future__ import annotations

import contextlib
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from twin.web.viewer import cameras
from twin.web.viewer.cameras import FRAMING, Cameras

FRAMED = (np.array([10.0, 0.0, 5.0]), np.array([0.0, 0.0, 1.0]))  # position, look-at [m]


class Browser:
    """A viser client as the cameras see it: a camera viser updates from its messages."""

    def __init__(self) -> None:
        self.client_id = 1
        self.camera = SimpleNamespace(position=np.zeros(3), look_at=np.array([1.0, 0.0, 0.0]))

    def atomic(self) -> Any:
        return contextlib.nullcontext()

    def stale(self) -> None:
        """Its old view comes back (a camera message sent before the framing arrived)."""
        self.camera.position, self.camera.look_at = np.zeros(3), np.array([1.0, 0.0, 0.0])

    def framed(self) -> bool:
        return bool(np.allclose(self.camera.position, FRAMED[0]))


@pytest.fixture
def scene() -> Cameras:
    scene = Cameras()
    scene.last, scene.clip = SimpleNamespace(), (0.1, 1000.0)  # type: ignore[assignment]
    scene.camera_pose = lambda view, fs: FRAMED if view == FRAMING else (  # type: ignore[method-assign]
        np.array([0.0, 50.0, 50.0]), np.zeros(3))
    return scene


def test_a_stale_view_is_put_back_within_the_hold(scene: Cameras) -> None:
    """A browser whose camera drifts from the framing within the hold is framed again."""
    browser = Browser()
    scene.frame([browser])
    assert browser.framed()
    browser.stale()
    scene.settle_framing([browser])
    assert browser.framed()


def test_no_hold_after_it_ends_or_once_another_view_is_asked(
    scene: Cameras, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The framing is not forced back once the user asked for another view, nor after the hold
    has ended."""
    browser = Browser()
    scene.frame([browser])
    scene.set_camera("overview", [browser])  # the user asks for another view: it is kept
    scene.settle_framing([browser])
    assert not browser.framed()
    scene.frame([browser])
    monkeypatch.setattr(cameras, "FRAMING_SETTLE", -1.0)  # a hold that has ended
    scene.frame([browser])
    browser.stale()
    scene.settle_framing([browser])
    assert not browser.framed()

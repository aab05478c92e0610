"""Helpers of the viewer tests: a raw client connected to a viewer, a wait for the scene, and
the cameras a real browser reports."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from tests.web.support import wait_for
from tests.web.viser_client import ViserClient
from twin.sim.live import LiveSession
from twin.web.viewer import ClientPanel, Viewer


def connect(viewer: Viewer, origin: str | None = None) -> tuple[ViserClient, ClientPanel]:
    """A raw client that announces itself, and the panel the viewer built for it."""
    before = set(viewer.gui.panels)
    client = ViserClient(viewer.port, origin=origin)
    client.hello()
    assert wait_for(lambda: set(viewer.gui.panels) - before, 10.0), "no panel was built"
    (client_id,) = set(viewer.gui.panels) - before
    client.wait_widget("Reset")  # the panel has reached the client
    return client, viewer.gui.panels[client_id]


def caught_up(viewer: Viewer, session: LiveSession) -> Callable[[], bool]:
    """The scene shows the session's newest sample."""
    t = float(session.latest()["t"])
    return lambda: viewer.scene.last is not None and viewer.scene.last.t == t


@dataclass(frozen=True)
class Reported:
    """A camera as one of a browser's camera messages gave it (what `project` reads)."""

    position: np.ndarray  # (3,) [m] inertial
    look_at: np.ndarray  # (3,) [m] inertial
    up_direction: np.ndarray  # (3,) [-] inertial
    fov: float  # [rad] vertical
    aspect: float  # [-] canvas width over height


class CameraReports:
    """Every camera message a browser sends from now on. viser's own `client.camera` is not
    the browser's view: the server's writes set it before the browser has them, and a message
    the browser sent before them can still replace it afterwards. A report taken here is
    what the browser said, copied on viser's event loop as the message came in."""

    def __init__(self, client: Any) -> None:
        self.reports: list[Reported] = []
        self._lock = threading.Lock()
        client.camera.on_update(self._record)

    async def _record(self, camera: Any) -> None:
        report = Reported(np.array(camera.position), np.array(camera.look_at),
                          np.array(camera.up_direction), float(camera.fov),
                          float(camera.aspect))  # fmt: skip
        with self._lock:
            self.reports.append(report)

    def mark(self) -> int:
        """Where the reports to come start (before a camera is sent)."""
        with self._lock:
            return len(self.reports)

    def wait_view(
        self, since: int, position: np.ndarray, look_at: np.ndarray, timeout: float
    ) -> Reported | None:
        """The first report after `since` of the camera at `position` [m] looking at `look_at`
        [m], both within 5 % of their distance (the vessel, and a view framed on it, moves a
        little between the camera's sending and the test's reading of the latest frame);
        None if none came within `timeout` [s]."""
        tol = 0.05 * float(np.linalg.norm(position - look_at))
        found: list[Reported] = []

        def seen() -> bool:
            with self._lock:
                new = self.reports[since:]
            found[:] = [r for r in new if np.linalg.norm(r.position - position) < tol
                        and np.linalg.norm(r.look_at - look_at) < tol]  # fmt: skip
            return bool(found)

        return found[0] if wait_for(seen, timeout) else None

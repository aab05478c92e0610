"""Helpers of the viewer tests: a raw client connected to a viewer, and a wait for the scene."""

from __future__ import annotations

from collections.abc import Callable

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

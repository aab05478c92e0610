"""Fixtures of the viewer tests: a paused live session, a viewer of it, a browser on it.

Every test here runs a real viewer (its render loop, viser's server and threads) and most hold
it to a wait: they are marked `serial`, as tests/web/conftest.py marks the other such modules.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.web.support import free_port
from tests.web.viewer.support import connect
from tests.web.viser_client import ViserClient
from twin.sim.live import LiveSession
from twin.web.access import Access
from twin.web.viewer import ClientPanel, Viewer, start_viewer

HERE = Path(__file__).parent


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if HERE in item.path.parents:
            item.add_marker(pytest.mark.serial)


@pytest.fixture
def session() -> Iterator[LiveSession]:
    """A paused session: the tests step it, the viewer's render loop only reads it."""
    live = LiveSession({"sea_state": 3})
    live.pause()
    yield live
    live.stop()


@pytest.fixture
def viewer(session: LiveSession) -> Iterator[Viewer]:
    handle = start_viewer(session, access=Access(), port=free_port())
    yield handle
    handle.stop()


@pytest.fixture
def browser(viewer: Viewer) -> Iterator[tuple[ViserClient, ClientPanel]]:
    client, panel = connect(viewer)
    yield client, panel
    client.close()

"""Graphics modes and the WebGL renderer report, over raw websocket clients."""

from __future__ import annotations

import http.client
import json
import socket
import time

import pytest

from tests.web.support import TOKEN, free_port, wait_for
from tests.web.viewer.support import connect
from tests.web.viser_client import ViserClient
from twin.errors import TwinError
from twin.sim.live import LiveSession
from twin.web.access import Access
from twin.web.viewer import (
    AMBIENT,
    GRAPHICS,
    RENDERER_PATH,
    Viewer,
    start_viewer,
)


@pytest.mark.parametrize("graphics", GRAPHICS)
def test_graphics_reach_a_browser(session: LiveSession, graphics: str) -> None:
    """A browser of a "light" viewer is told to drop the environment map and every shadow and
    gets the sky's ambient light; a "full" viewer sends viser's built-in map ("city") and
    the sun's shadows, and no ambient light. Both replace viser's overhead key light with a
    low sun (`configure_graphics`), and both ask the page for its WebGL renderer."""
    viewer = start_viewer(session, access=Access(), port=free_port(), graphics=graphics)
    try:
        with ViserClient(viewer.port) as client:
            client.hello()
            client.wait_widget("Reset")
            assert wait_for(lambda: any(m["type"] == "RunJavascriptMessage"
                                        for m in list(client.received)), 10.0)  # fmt: skip
            with client._lock:
                received = list(client.received)
    finally:
        viewer.stop()
    maps = [m for m in received if m["type"] == "EnvironmentMapMessage"]
    lights = [m for m in received if m["type"] == "EnableLightsMessage"]
    ambient = [m for m in received if m["type"] == "AmbientLightMessage"]
    sun = [m for m in received if m["type"] == "DirectionalLightMessage" and m["name"] == "/sun"]
    scripts = [m["source"] for m in received if m["type"] == "RunJavascriptMessage"]
    assert [(m["enabled"], m["cast_shadow"]) for m in lights] == [(False, False)]
    assert [m["name"] for m in ambient] == ["/sky_light"]
    (sun,) = sun
    (script,) = scripts
    assert RENDERER_PATH[1:] in script and "WEBGL_debug_renderer_info" in script
    if graphics == "light":
        assert [m["hdri_data"] for m in maps] == [None]
        assert ambient[0]["props"]["intensity"] == AMBIENT > 0
        assert sun["props"]["cast_shadow"] is False
    else:
        assert len(maps) == 1 and maps[0]["hdri_data"] is not None
        assert ambient[0]["props"]["intensity"] == 0.0
        assert sun["props"]["cast_shadow"] is True


def test_unknown_graphics_are_refused_before_anything_starts(session: LiveSession) -> None:
    """An unknown graphics mode is a TwinError naming the allowed ones, and the viewer's port
    is never bound."""
    port = free_port()
    with pytest.raises(TwinError, match="graphics 'fancy' unknown; one of: full, light"):
        start_viewer(session, access=Access(), port=port, graphics="fancy")
    with socket.socket() as probe:  # the port was never bound
        probe.bind(("127.0.0.1", port))


def _renderer_key(client: ViserClient) -> str:
    """The key the viewer gave this connection's page for its renderer report."""
    assert wait_for(lambda: any(m["type"] == "RunJavascriptMessage" for m in list(client.received)))
    with client._lock:
        (source,) = [m["source"] for m in client.received if m["type"] == "RunJavascriptMessage"]
    return json.loads(source.split('url.searchParams.set("key", ', 1)[1].split(")", 1)[0])


def _report(port: int, key: str, renderer: str) -> int:
    """GET the renderer report as the page's fetch does; the HTTP status."""
    from urllib.parse import urlencode

    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    connection.request("GET", f"{RENDERER_PATH}?{urlencode({'key': key, 'renderer': renderer})}")
    status = connection.getresponse().status
    connection.close()
    return status


def test_a_software_renderer_report_switches_that_browser_to_light_graphics(
    viewer: Viewer,
) -> None:
    """A page reporting SwiftShader with its own key is switched to light graphics (its
    dropdown, an environment map of none, a notification); a report with a made-up key, or
    another browser's GPU, changes nothing; the browser's own dropdown switches it back to
    full (viser's environment map again), and a locked browser may do that too."""
    first, first_panel = connect(viewer)
    second, second_panel = connect(viewer)
    try:
        assert first_panel.graphics.value == second_panel.graphics.value == "full"
        assert _report(viewer.port, "made-up", "SwiftShader") == 200
        assert _report(viewer.port, _renderer_key(second), "ANGLE (NVIDIA GeForce RTX)") == 200
        time.sleep(0.5)
        assert first_panel.graphics.value == second_panel.graphics.value == "full"

        maps = lambda c: [m for m in list(c.received) if m["type"] == "EnvironmentMapMessage"]  # noqa: E731
        before = len(maps(first))
        renderer = "ANGLE (Google, Vulkan 1.3.0 (SwiftShader Device (Subzero)), SwiftShader driver)"
        assert _report(viewer.port, _renderer_key(first), renderer) == 200
        assert wait_for(lambda: first_panel.graphics.value == "light", 10.0)
        assert viewer.renderers[first_panel.client.client_id] == renderer
        assert wait_for(lambda: len(maps(first)) > before)
        assert maps(first)[-1]["hdri_data"] is None
        assert wait_for(lambda: any("Light graphics" in n for n in first.notifications()))
        assert second_panel.graphics.value == "full"  # the other browser keeps its own
        assert not any("Light graphics" in n for n in second.notifications())

        # the way back, from the browser's own dropdown
        first.update(first.wait_widget("Graphics"), value="full")
        assert wait_for(lambda: maps(first)[-1]["hdri_data"] is not None)
    finally:
        first.close()
        second.close()


def test_a_locked_browser_switches_its_own_graphics(session: LiveSession) -> None:
    """Graphics change what one browser draws, nothing else: a browser locked by the token
    still switches them."""
    viewer = start_viewer(session, port=free_port(), access=Access(token=TOKEN))
    try:
        client, panel = connect(viewer)
        assert panel.locked
        client.update(client.wait_widget("Graphics"), value="light")
        assert wait_for(lambda: any(m["type"] == "EnvironmentMapMessage" and m["hdri_data"] is None
                                    for m in list(client.received)))  # fmt: skip
        assert panel.graphics.value == "light"
        client.close()
    finally:
        viewer.stop()

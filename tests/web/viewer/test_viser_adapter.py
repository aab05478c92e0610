"""The adapter to viser's private internals: everything it needs is in the installed viser,
and a viser without one fails loudly, naming its version and what is missing."""

from __future__ import annotations

import pytest
import viser
import viser.infra._infra as viser_infra

from tests.web.support import free_port
from tests.web.viewer.support import connect
from twin.errors import TwinError
from twin.web.access import Access
from twin.web.viewer import Viewer, start_viewer, viser_adapter
from twin.web.viewer.viser_adapter import ViserInternalsMissing, check_internals


def test_the_installed_viser_has_what_the_adapter_uses(viewer: Viewer) -> None:
    """Every internal the adapter reaches is there, in the modules and on a running server:
    this is the test that fails on the viser upgrade that breaks the viewer."""
    check_internals()
    check_internals(viewer.server)
    assert viser_adapter.share_handlers(viewer.server) == []  # dropped by start_viewer
    assert viser_adapter.share_tunnel(viewer.server) is None
    client, panel = connect(viewer)
    try:
        assert viser_adapter.remote_address(viewer.server, panel.client) == "127.0.0.1"
    finally:
        client.close()


def test_the_handshake_stand_in_is_seen_by_viser_alone(viewer: Viewer) -> None:
    """The websockets package keeps its own serve; viser's module gets its own back."""
    import websockets.asyncio.server as ws_server

    assert viser_infra.websockets.asyncio.server.serve is ws_server.serve
    assert viser_infra.websockets is __import__("websockets")


@pytest.mark.parametrize(
    ("owner", "name", "named"),
    [
        (viser_infra, "websockets", "viser.infra._infra.websockets.asyncio.server.serve"),
        (viser_infra, "_message_producer", "viser.infra._infra._message_producer"),
        (viser_infra, "_append_aligned_buffers", "viser.infra._infra._append_aligned_buffers"),
        (viser._messages, "ShareUrlRequest", "viser._messages.ShareUrlRequest"),
        (viser._messages, "RunJavascriptMessage", "viser._messages.RunJavascriptMessage"),
        (viser._messages, "GuiUpdateMessage", "viser._messages.GuiUpdateMessage"),
    ],
)
def test_a_viser_without_an_internal_fails_loudly(
    monkeypatch: pytest.MonkeyPatch, owner: object, name: str, named: str
) -> None:
    """As if an upgrade removed it: the error names viser's version and the internal, and
    the viewer does not start (its port is never bound)."""
    monkeypatch.delattr(owner, name)
    with pytest.raises(ViserInternalsMissing) as caught:
        check_internals()
    message = str(caught.value)
    assert f"viser {viser.__version__}" in message and named in message
    with pytest.raises(ViserInternalsMissing):
        start_viewer(None, access=Access(), port=free_port())  # type: ignore[arg-type]  # fails first


def test_a_server_without_its_websocket_internals_fails_loudly(
    viewer: Viewer, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A running server whose websocket server lacks the connection table is named too."""
    monkeypatch.delattr(viewer.server._websock_server, "_live_connections")
    with pytest.raises(ViserInternalsMissing, match=r"WebsockServer\._live_connections"):
        check_internals(viewer.server)
    monkeypatch.delattr(viewer.server._websock_server, "_broadcast_buffer")
    with pytest.raises(ViserInternalsMissing, match=r"WebsockServer\._broadcast_buffer"):
        check_internals(viewer.server)


def test_a_server_without_its_share_tunnel_slot_fails_loudly(
    viewer: Viewer, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`share_tunnel` reads the server's own slot: a viser that renamed it is named, not
    mistaken for "no tunnel" (viser's deprecation shim answers unknown attributes)."""
    monkeypatch.delitem(vars(viewer.server), "_share_tunnel")
    with pytest.raises(ViserInternalsMissing, match=r"ViserServer\._share_tunnel"):
        check_internals(viewer.server)


def test_browser_messages_are_viser_own_and_named() -> None:
    """The tests' raw client builds viser's own message classes; an unknown name is refused
    with the ones allowed."""
    update = viser_adapter.browser_message("GuiUpdateMessage", "some-uuid", {"value": 1.0})
    assert type(update) is viser._messages.GuiUpdateMessage
    assert update.as_serializable_dict()["updates"] == {"value": 1.0}
    with pytest.raises(TwinError, match="'Nope' unknown; one of: ViewerCameraMessage"):
        viser_adapter.browser_message("Nope")

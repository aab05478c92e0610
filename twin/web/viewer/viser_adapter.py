"""Every use of viser's private internals, in one place (STYLE.md: "if unavoidable, one adapter
module with a test that fails on the upgrade that breaks it").

viser (1.1) has no public hook for these, so the viewer reaches in here and nowhere else:

- the websocket handshake (`checked_handshake`): viser serves its page, assets and websocket
  through one `websockets.asyncio.server.serve` call with a `process_request` of its own (its
  static files). The Host and Origin checks (`twin.web.viewer.handshake`) are composed in
  front of it by handing viser's own module (`viser.infra._infra`, its `websockets` global)
  a stand-in whose `asyncio.server.serve` wraps the real one, for the time the server starts.
  Nothing else in the process sees the stand-in: the `websockets` package is never changed.
- the share tunnel (`drop_share_handlers`): a browser's `ShareUrlRequest` would have the
  server open a public tunnel to itself; its handlers are unregistered from viser's
  websocket server (`_websock_server`, `_incoming_handlers`, `viser._messages`); whether a
  tunnel was opened all the same (`share_tunnel`: `ViserServer._share_tunnel`).
- a browser's address (`remote_address`), for the per-address limit of wrong tokens
  (`_websock_server._live_connections`).
- a script run in one browser (`run_javascript`), viser's own `RunJavascriptMessage`, as
  viser itself sends plotly.js (`ClientHandle._websock_connection`).
- what a browser sends (`browser_message`), for the tests' raw websocket client
  (tests/web/viser_client.py), which speaks viser's wire format without a browser.

`check_internals()` names whatever a viser upgrade removed; `start_viewer` calls it before it
starts anything and tests/web/viewer/test_viser_adapter.py runs it against the installed viser.
"""

from __future__ import annotations

import contextlib
import threading
import types
from collections.abc import Callable, Iterator
from typing import Any

import viser
import viser.infra._infra as viser_infra

from twin.errors import TwinError

#: one viewer starts its websocket server at a time (the handshake check is added to it then)
_STARTING = threading.Lock()
#: messages from a browser that ask the server to open (or close) a public share tunnel
SHARE_MESSAGES = ("ShareUrlRequest", "ShareUrlDisconnect")
#: messages a browser sends: its camera (then viser counts it connected) and a widget's update
BROWSER_MESSAGES = ("ViewerCameraMessage", "GuiUpdateMessage")

#: check(connection, request) → an HTTP response that refuses, or None to go on
Handshake = Callable[[Any, Any], Any]


class ViserInternalsMissing(TwinError):
    """The installed viser lacks an internal the viewer relies on (a viser upgrade)."""


def check_internals(server: viser.ViserServer | None = None) -> None:
    """Raise `ViserInternalsMissing` naming the viser version and every internal missing: in
    viser's modules and classes, and on `server` (a running one) if given."""
    from viser.infra import WebsockServer

    missing = []
    ws = getattr(viser_infra, "websockets", None)
    serve = getattr(getattr(getattr(ws, "asyncio", None), "server", None), "serve", None)
    if serve is None:
        missing.append("`viser.infra._infra.websockets.asyncio.server.serve`")
    messages = getattr(viser, "_messages", None)
    for name in (*SHARE_MESSAGES, *BROWSER_MESSAGES, "RunJavascriptMessage"):
        if not hasattr(messages, name):
            missing.append(f"`viser._messages.{name}`")
    if not hasattr(WebsockServer, "unregister_handler"):
        missing.append("`WebsockServer.unregister_handler`")
    if server is not None:
        # vars(): a missing attribute would go to viser's deprecation shim (`__getattr__`)
        if "_share_tunnel" not in vars(server):
            missing.append("`ViserServer._share_tunnel`")
        websock = getattr(server, "_websock_server", None)
        if websock is None:
            missing.append("`ViserServer._websock_server`")
        for name in ("_incoming_handlers", "_live_connections"):
            if websock is not None and not hasattr(websock, name):
                missing.append(f"`WebsockServer.{name}`")
    if missing:
        raise ViserInternalsMissing(
            f"viser {viser.__version__}: the viewer's adapter (twin/web/viewer/viser_adapter.py) "
            f"needs {', '.join(missing)}, which this viser lacks; install the viser it was "
            "written for (1.1) or adapt the adapter"
        )


class _Namespace(types.SimpleNamespace):
    """A stand-in module: the given attributes, every other one the real module's."""

    def __init__(self, real: Any, **attributes: Any) -> None:
        super().__init__(**attributes)
        object.__setattr__(self, "_real", real)

    def __getattr__(self, name: str) -> Any:
        return getattr(object.__getattribute__(self, "_real"), name)


@contextlib.contextmanager
def checked_handshake(check: Handshake) -> Iterator[list[bool]]:
    """While viser starts its websocket server, give it `check` as the first step of every
    opening handshake: `check(connection, request)` returns a refusal (an HTTP response) or
    None to let viser's own handling go on. Yields a list that holds True once installed.

    Only viser's infra module sees the wrapped `serve` (a stand-in for its `websockets`
    global), and only while inside; one viewer starts at a time.
    """
    real = viser_infra.websockets
    original = real.asyncio.server.serve
    installed: list[bool] = []

    def serve(handler: Any, *args: Any, process_request: Any = None, **kwargs: Any) -> Any:
        viser_own = process_request

        def checked(connection: Any, request: Any) -> Any:
            refusal = check(connection, request)
            if refusal is not None:
                return refusal
            return None if viser_own is None else viser_own(connection, request)

        installed.append(True)
        return original(handler, *args, process_request=checked, **kwargs)

    server_module = _Namespace(real.asyncio.server, serve=serve)
    stand_in = _Namespace(real, asyncio=_Namespace(real.asyncio, server=server_module))
    with _STARTING:
        viser_infra.websockets = stand_in  # type: ignore[assignment]
        try:
            yield installed
        finally:
            viser_infra.websockets = real


def drop_share_handlers(server: viser.ViserServer) -> None:
    """Unregister viser's handlers of share-tunnel requests from a browser."""
    websock = server._websock_server
    for name in SHARE_MESSAGES:
        message = getattr(viser._messages, name, None)
        if message is not None and message in websock._incoming_handlers:
            websock.unregister_handler(message)


def share_handlers(server: viser.ViserServer) -> list[str]:
    """The share-tunnel messages the server still handles (for tests: none after
    `drop_share_handlers`)."""
    handlers = server._websock_server._incoming_handlers
    return [name for name in SHARE_MESSAGES if getattr(viser._messages, name) in handlers]


def share_tunnel(server: viser.ViserServer) -> Any:
    """The public share tunnel the server has open, or None (for tests: none is ever opened,
    whatever a browser asks)."""
    return vars(server)["_share_tunnel"]


def browser_message(name: str, *args: Any, **kwargs: Any) -> Any:
    """One of viser's wire messages (`name`: its class, one of `BROWSER_MESSAGES` or
    `SHARE_MESSAGES`) built from `args` and `kwargs`, as a browser would send it (for the
    tests' raw websocket client; `.as_serializable_dict()` is what goes on the wire)."""
    known = (*BROWSER_MESSAGES, *SHARE_MESSAGES)
    if name not in known:
        raise TwinError(f"browser message {name!r} unknown; one of: {', '.join(known)}")
    return getattr(viser._messages, name)(*args, **kwargs)


def remote_address(server: viser.ViserServer, client: viser.ClientHandle) -> str | None:
    """The browser's IP address as viser's connection has it, or None if unknown."""
    try:
        connection = server._websock_server._live_connections[client.client_id]
        return str(connection.remote_address[0])
    except Exception:  # gone, or a transport without an address
        return None


def run_javascript(client: viser.ClientHandle, source: str) -> None:
    """Run `source` once in one browser (viser's `RunJavascriptMessage`)."""
    client._websock_connection.queue_message(viser._messages.RunJavascriptMessage(source=source))

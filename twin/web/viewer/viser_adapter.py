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
- what a browser sends (`browser_message`, `camera_hello`), for the raw websocket clients of
  the tests (tests/web/viser_client.py), the soak and the benchmarks, which speak viser's
  wire format without a browser.
- one encoding of a broadcast window for every browser (`share_broadcast_encoding`): viser
  runs one producer per connection (`viser.infra._infra._message_producer`), and each turned
  the same window of the broadcast buffer (`WebsockServer._broadcast_buffer`) into the same
  bytes again: msgpack, zstd and a copy of every array, 100 times a frame for 100 browsers.
  The producer viser's connection handler calls is replaced by one that encodes a window of
  a registered broadcast buffer once (`SharedWindows`) and sends those bytes to every
  connection whose window holds the same messages; any other buffer (a browser's own
  messages, another viser server's) goes to viser's producer unchanged.

`check_internals()` names whatever a viser upgrade removed; `start_viewer` calls it before it
starts anything and tests/web/viewer/test_viser_adapter.py runs it against the installed viser.
"""

from __future__ import annotations

import contextlib
import threading
import time
import types
import weakref
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import msgspec
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
    for name in ("_message_producer", "_append_aligned_buffers"):
        if not callable(getattr(viser_infra, name, None)):
            missing.append(f"`viser.infra._infra.{name}`")
    if server is not None:
        # vars(): a missing attribute would go to viser's deprecation shim (`__getattr__`)
        if "_share_tunnel" not in vars(server):
            missing.append("`ViserServer._share_tunnel`")
        websock = getattr(server, "_websock_server", None)
        if websock is None:
            missing.append("`ViserServer._websock_server`")
        for name in ("_incoming_handlers", "_live_connections", "_broadcast_buffer"):
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


def camera_hello() -> bytes:
    """The bytes a browser sends once its page has drawn: its camera (`ViewerCameraMessage`),
    msgpack-encoded as on the wire. Only then does viser count the connection a browser, the
    viewer build its panel and the render loop draw for it; a raw client that never sends it
    gets the initial scene and nothing more (scripts/soak.py, the benchmarks, the tests)."""
    camera = browser_message(
        "ViewerCameraMessage", wxyz=(1.0, 0.0, 0.0, 0.0), position=(3.0, 3.0, 3.0), fov=1.3,
        near=0.01, far=1000.0, image_height=600, image_width=800, look_at=(0.0, 0.0, 0.0),
        up_direction=(0.0, 0.0, 1.0),
    )  # fmt: skip
    return msgspec.msgpack.encode(camera.as_serializable_dict())


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


# -- one encoding of a broadcast window for every browser ----------------------------------------

#: encoded broadcast windows kept per buffer: browsers in step share the newest; one that fell
#: behind (its window spans more messages) gets its own, and may share it with another
SHARED_WINDOWS = 4


def encode_window(window: Sequence[Any], zstd: Any = None) -> bytes:
    """One window of viser messages in viser's wire format, as `viser.infra._infra.
    _message_producer` (1.1) encodes it: [8 bytes] the msgpack's size, [8 bytes] its zstd
    size, the zstd-compressed msgpack (the messages, arrays replaced by placeholders, and a
    timestamp [s, perf_counter] the browser paces batches by), then the arrays' raw bytes,
    each 8-byte aligned. `zstd`: a `zstandard.ZstdCompressor` to reuse (one thread at a
    time), default a new one of viser's level."""
    import zstandard

    binary_buffers: list[memoryview] = []
    messages = tuple(message.as_serializable_dict(binary_buffers) for message in window)
    inner = msgspec.msgpack.encode({
        "messages": messages,
        "timestampSec": time.perf_counter(),
        "binaryBufferLengths": tuple(b.nbytes for b in binary_buffers),
    })  # fmt: skip
    compressed = (zstd or zstandard.ZstdCompressor(level=1)).compress(inner)
    parts: list[bytes | memoryview] = [
        len(inner).to_bytes(8, "little"), len(compressed).to_bytes(8, "little"), compressed,
    ]  # fmt: skip
    viser_infra._append_aligned_buffers(parts, binary_buffers, 16 + len(compressed))
    return b"".join(parts)


class SharedWindows:
    """The windows of one broadcast buffer, each encoded once (`encode_window`) and sent as
    the same bytes to every connection whose window holds the same message objects in the
    same order (a window skips the messages meant for everyone but its own browser, so two
    browsers' windows can differ; they then share nothing).

    Used on viser's event loop only (every producer runs there): no lock.

    Attributes:
        encoded: windows encoded.
        shared: windows sent as bytes encoded for another connection.
    """

    def __init__(self, kept: int = SHARED_WINDOWS) -> None:
        import zstandard

        self._zstd = zstandard.ZstdCompressor(level=1)
        # (the window's messages: held, so their ids cannot be reused, and its bytes)
        self._windows: deque[tuple[tuple[Any, ...], bytes]] = deque(maxlen=kept)
        self.encoded = 0
        self.shared = 0

    def bytes_of(self, window: Sequence[Any]) -> bytes:
        """The wire bytes of `window`: encoded before, or now."""
        for messages, payload in reversed(self._windows):
            if len(messages) == len(window) and all(
                a is b for a, b in zip(messages, window, strict=True)
            ):
                self.shared += 1
                return payload
        payload = encode_window(window, self._zstd)
        self._windows.append((tuple(window), payload))
        self.encoded += 1
        return payload


#: id of a registered broadcast buffer → its shared windows (dropped with the buffer)
_SHARED: dict[int, SharedWindows] = {}
#: viser's own producer, for every buffer not registered
_VISER_PRODUCER = viser_infra._message_producer


async def _producer(
    websocket: Any, buffer: Any, client_id: int, backlog_done_message: Any = None
) -> None:
    """viser's `_message_producer` (1.1), the window's bytes shared (`SharedWindows`) when
    `buffer` is a registered broadcast buffer."""
    shared = _SHARED.get(id(buffer))
    if shared is None:
        await _VISER_PRODUCER(websocket, buffer, client_id, backlog_done_message)
        return
    windows = buffer.window_generator(client_id, backlog_done_message=backlog_done_message)
    try:
        while not buffer.done:
            try:
                outgoing = await windows.__anext__()
            except StopAsyncIteration:
                break
            await websocket.send(shared.bytes_of(outgoing))
    finally:  # as viser's: the generator's own finally (its GC cursor) runs now
        await windows.aclose()


def share_broadcast_encoding(server: viser.ViserServer) -> SharedWindows:
    """Have `server`'s broadcast windows encoded once for every browser (the module's
    docstring); connections opened from now on use it. Returns its counters."""
    buffer = server._websock_server._broadcast_buffer
    shared = _SHARED.get(id(buffer))
    if shared is None:
        shared = _SHARED[id(buffer)] = SharedWindows()
        weakref.finalize(buffer, _SHARED.pop, id(buffer), None)
    viser_infra._message_producer = _producer
    return shared

"""A raw websocket client of the 3D viewer: viser's wire format, no browser.

What an attacker's script (or a page from another origin) can do: open the websocket with any
Origin, announce itself with a camera message (viser then counts it as a connected browser and
builds its panel), read every message, and send any message viser parses: GUI updates of any
widget id and property, share-URL requests, ...
"""

from __future__ import annotations

import socket
import threading
import time
from typing import Any

import msgspec
import viser
import zstandard
from websockets.sync.client import connect

from twin.web.viewer.viser_adapter import browser_message, camera_hello

PROTOCOL = f"viser-v{viser.__version__}"


def decode(frame: bytes) -> list[dict[str, Any]]:
    """The messages of one server frame: 16-byte header, zstd msgpack, raw binary buffers."""
    size = int.from_bytes(frame[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(frame[16 : 16 + size])
    return list(msgspec.msgpack.decode(inner)["messages"])


class ViserClient:
    """One raw connection to a viser server on 127.0.0.1.

    Args:
        port: the viewer's port.
        origin: the Origin header to send (None: none, as a script).
        host: the Host header to send, e.g. a DNS-rebinding page's `evil.example:PORT`
            (None: `127.0.0.1:PORT`); the connection still goes to 127.0.0.1.

    Raises:
        websockets.exceptions.InvalidStatus: the server refused the handshake.
    """

    def __init__(
        self, port: int, origin: str | list[str] | None = None, timeout: float = 10.0,
        host: str | None = None,
    ) -> None:  # fmt: skip
        # a list sends one Origin header per entry (a malformed request, for the tests)
        origins = [origin] if isinstance(origin, str) else origin or []
        headers = [("Origin", value) for value in origins] or None
        # websockets names the URI's host as Host: a socket of our own keeps it on loopback
        sock = None
        if host is not None:
            sock = socket.create_connection(("127.0.0.1", port), timeout)
            sock.settimeout(None)  # as websockets leaves its own: the handshake has its timeout
        self.ws = connect(
            f"ws://{host or f'127.0.0.1:{port}'}/", sock=sock, subprotocols=[PROTOCOL],
            additional_headers=headers, open_timeout=timeout, max_size=None,
        )  # fmt: skip
        self.received: list[dict[str, Any]] = []
        self._lock = threading.Lock()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        try:
            for frame in self.ws:
                with self._lock:
                    self.received.extend(decode(frame))
        except Exception:  # closed
            return

    def send(self, message: Any) -> None:
        """Send one of viser's messages (`browser_message`)."""
        self.ws.send(msgspec.msgpack.encode(message.as_serializable_dict()))

    def hello(self) -> None:
        """The camera message a browser sends first: viser then calls it connected."""
        self.ws.send(camera_hello())

    def widgets(self) -> dict[str, str]:
        """Label → uuid of every GUI element this connection was sent (the newest of a label)."""
        with self._lock:
            found = {}
            for message in self.received:
                props = message.get("props")
                if message["type"].startswith("Gui") and isinstance(props, dict):
                    if "label" in props and "uuid" in message:
                        found[props["label"]] = message["uuid"]
            return found

    def wait_widget(self, label: str, timeout: float = 10.0) -> str:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if label in (found := self.widgets()):
                return found[label]
            time.sleep(0.02)
        raise AssertionError(f"no widget {label!r} within {timeout} s: {sorted(self.widgets())}")

    def notifications(self) -> list[str]:
        with self._lock:
            return [
                f"{m['props'].get('title')}: {m['props'].get('body')}"
                for m in self.received
                if m["type"] == "NotificationShowMessage" and isinstance(m.get("props"), dict)
            ]

    def update(self, uuid: str, **updates: Any) -> None:
        """What a browser sends when a widget changes (any property, as a hostile one may)."""
        self.send(browser_message("GuiUpdateMessage", uuid, updates))

    def close(self) -> None:
        self.ws.close()
        self._reader.join(2.0)

    def __enter__(self) -> ViserClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

"""One encoding of a broadcast window for every browser (issue 30 item 7): viser encoded the
same frame once per connection; `viser_adapter.SharedWindows` encodes it once and sends the
same bytes to every browser whose window holds the same messages, in viser's wire format."""

from __future__ import annotations

import asyncio
from typing import Any

import msgspec
import numpy as np
import viser._messages as messages
import zstandard
from viser.infra._async_message_buffer import AsyncMessageBuffer

from tests.web.support import wait_for
from tests.web.viewer.support import connect
from tests.web.viser_client import decode
from twin.sim.live import LiveSession
from twin.web.viewer import Viewer, viser_adapter
from twin.web.viewer.viser_adapter import SharedWindows, encode_window


def _window() -> list[Any]:
    """A frame's kind of window: a node moved, and a mesh's vertices (an array: raw bytes)."""
    vertices = np.arange(36, dtype=np.float32).reshape(12, 3)
    return [
        messages.SetPositionMessage("/hull", (1.0, 2.0, 3.0)),
        messages.SceneNodeUpdateMessage("/sea", {"vertices": vertices}),
    ]


def _parts(frame: bytes) -> tuple[dict[str, Any], bytes]:
    """A frame's msgpack (without its timestamp) and its binary tail."""
    size, packed = int.from_bytes(frame[:8], "little"), int.from_bytes(frame[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(frame[16 : 16 + packed])
    assert len(inner) == size
    decoded = msgspec.msgpack.decode(inner)
    decoded.pop("timestampSec")
    return decoded, frame[16 + packed :]


class _Socket:
    """What a producer sends to; the buffer stops after the first frame."""

    def __init__(self, buffer: AsyncMessageBuffer) -> None:
        self.buffer, self.frames = buffer, []

    async def send(self, frame: bytes) -> None:
        self.frames.append(frame)
        self.buffer.set_done()


def _produce(producer: Any, window: list[Any]) -> bytes:
    async def run() -> bytes:
        buffer = AsyncMessageBuffer(asyncio.get_running_loop(), persistent_messages=True)
        for message in window:
            buffer.push(message)
        socket = _Socket(buffer)
        await asyncio.wait_for(producer(socket, buffer, 0), 10.0)
        return socket.frames[0]

    return asyncio.run(run())


def test_a_window_is_encoded_as_viser_itself_encodes_it() -> None:
    """`encode_window` is viser's wire format: viser's own producer sends the same messages
    and the same arrays' bytes (a viser whose format changed fails here)."""
    window = _window()
    theirs = _produce(viser_adapter._VISER_PRODUCER, window)
    ours = encode_window(window)
    assert _parts(ours) == _parts(theirs)
    decoded, tail = _parts(ours)
    assert decoded["binaryBufferLengths"] == [12 * 3 * 4]
    assert np.frombuffer(tail[-144:], np.float32)[-1] == 35.0


def test_the_same_window_is_encoded_once() -> None:
    """The same message objects, in the same order: the same bytes, encoded once; a window
    that differs by one message (viser leaves out a message for the browser that sent it)
    or its order is encoded again."""
    shared = SharedWindows()
    window = _window()
    first = shared.bytes_of(window)
    assert shared.bytes_of(list(window)) is first
    assert (shared.encoded, shared.shared) == (1, 1)
    other = shared.bytes_of(window[:1])
    swapped = shared.bytes_of(window[::-1])
    assert other is not first and swapped is not first
    assert (shared.encoded, shared.shared) == (3, 1)


def test_only_the_newest_windows_are_kept() -> None:
    """The shared encodings keep only the `kept` newest windows: an older one is encoded again."""
    shared = SharedWindows(kept=2)
    windows = [_window() for _ in range(3)]
    for window in windows:
        shared.bytes_of(window)
    shared.bytes_of(windows[0])  # dropped: encoded again
    assert (shared.encoded, shared.shared) == (4, 0)
    shared.bytes_of(windows[2])
    assert shared.shared == 1


def test_a_buffer_not_registered_goes_to_viser_own_producer() -> None:
    """A browser's own buffer (and another viser server's) is viser's business: its producer
    sends it, encoded per connection as before."""
    frame = _produce(viser_adapter._producer, _window())
    assert _parts(frame) == _parts(encode_window(_window()))


def test_browsers_share_the_frames_of_the_viewer(viewer: Viewer, session: LiveSession) -> None:
    """Three browsers in step: the viewer's broadcast frames are encoded fewer times than
    they are sent, and every browser decodes the newest sample's sea."""
    shared = viser_adapter.share_broadcast_encoding(viewer.server)  # the viewer's own
    browsers = [connect(viewer)[0] for _ in range(3)]
    try:
        encoded, reused = shared.encoded, shared.shared
        for _ in range(5):
            session.step()
        t = float(session.latest()["t"])
        assert wait_for(lambda: viewer.scene.last is not None and viewer.scene.last.t == t, 10.0)
        assert wait_for(lambda: shared.shared > reused, 10.0)
        assert shared.encoded > encoded  # the frames after the steps were encoded here
        for browser in browsers:  # each got the sea's vertices of some frame, decodable
            assert wait_for(lambda b=browser: any(m["type"] == "SceneNodeUpdateMessage"
                                                  for m in b.received), 10.0)  # fmt: skip
    finally:
        for browser in browsers:
            browser.close()


def test_the_frames_sent_are_what_browsers_decode() -> None:
    """`decode` (the tests' raw client) reads a shared frame as viser's."""
    assert [m["type"] for m in decode(encode_window(_window()))] == [
        "SetPositionMessage", "SceneNodeUpdateMessage",
    ]  # fmt: skip

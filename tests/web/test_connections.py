"""The served sockets (issue 30): TCP_NODELAY on every accepted connection, REST and viewer.

Without it every keep-alive answer waits on Nagle plus the client's delayed ACK (~45 ms). The
check reads the option off the server side of a live connection, found among the process's
asyncio transports, so it holds whatever socket each server made for itself.
"""

from __future__ import annotations

import asyncio
import gc
import socket
import threading
from collections.abc import Iterator
from typing import Any

import pytest
import uvicorn

from tests.figures import record
from tests.web.support import wait_for
from twin.web.access import Access
from twin.web.connections import quiet_malformed_messages
from twin.web.server import listen


async def _ok(scope: dict[str, Any], receive: Any, send: Any) -> None:
    if scope["type"] != "http":
        return
    await send({"type": "http.response.start", "status": 200, "headers": []})
    await send({"type": "http.response.body", "body": b"ok"})


def served_sockets(port: int) -> list[Any]:
    """The server side of every live connection to `port` in this process."""
    found = []
    for obj in gc.get_objects():
        try:
            transport = isinstance(obj, asyncio.BaseTransport) and not obj.is_closing()
        except ReferenceError:  # a weakref.proxy whose object is gone: not a transport
            continue
        if transport:
            sock = obj.get_extra_info("socket")
            try:
                if sock is not None and sock.getsockname()[1] == port and sock.getpeername():
                    found.append(sock)
            except OSError:
                continue
    return found


@pytest.fixture
def rest_port() -> Iterator[int]:
    sock = listen("127.0.0.1", 0)
    port = sock.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(_ok, log_level="warning"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    assert wait_for(lambda: server.started, timeout=30)
    yield port
    server.should_exit = True
    thread.join(10)
    sock.close()


def test_listen_makes_a_tcp_socket_with_nodelay() -> None:
    """listen makes a TCP socket with TCP_NODELAY set."""
    sock = listen("127.0.0.1", 0)
    try:
        assert sock.proto == socket.IPPROTO_TCP
        assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) != 0
    finally:
        sock.close()


def test_every_accepted_rest_connection_has_nodelay(rest_port: int) -> None:
    """Every connection the REST server accepts has TCP_NODELAY set."""
    with socket.create_connection(("127.0.0.1", rest_port)) as client:
        client.sendall(b"GET / HTTP/1.1\r\nHost: localhost\r\n\r\n")
        assert client.recv(100).startswith(b"HTTP/1.1 200")
        served = served_sockets(rest_port)
        assert served, "no server-side connection found"
        assert all(s.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) for s in served)
        record("attack30_nagle", rest_nodelay=True)


def test_every_accepted_viewer_connection_has_nodelay() -> None:
    """Every connection the viewer accepts has TCP_NODELAY set."""
    from tests.web.support import free_port
    from twin.sim.live import LiveSession
    from twin.web.viewer import start_viewer

    session = LiveSession({"sea_state": 3})
    viewer = start_viewer(session, access=Access(), port=free_port())
    try:
        with socket.create_connection(("127.0.0.1", viewer.port)) as client:
            client.sendall(b"GET / HTTP/1.1\r\nHost: localhost\r\n\r\n")
            assert client.recv(100).startswith(b"HTTP/1.1")
            assert wait_for(lambda: bool(served_sockets(viewer.port)), timeout=10)
            served = served_sockets(viewer.port)
            assert all(s.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) for s in served)
    finally:
        viewer.stop()


# -- slowloris, idle connections, caps (issue 30) ----------------------------------------------


def _guarded(app: Any = _ok, **options: Any) -> Iterator[int]:
    from twin.web.server import uvicorn_config

    sock = listen("127.0.0.1", 0)
    port = sock.getsockname()[1]
    config = uvicorn_config(app, "127.0.0.1", port, log_level="warning", **options)
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    assert wait_for(lambda: server.started, timeout=30)
    yield port
    server.should_exit = True
    thread.join(10)
    sock.close()


def _answer(conn: socket.socket) -> bytes:
    """Everything the server sends until it closes (a generous timeout: not a budget)."""
    conn.settimeout(60)
    data = b""
    try:
        while chunk := conn.recv(4096):
            data += chunk
    except ConnectionResetError:
        pass
    return data


def test_an_incomplete_request_is_answered_408_and_closed() -> None:
    """A request whose headers never end is answered 408 once the request timeout passes."""
    for port in _guarded(request_timeout=0.3):
        with socket.create_connection(("127.0.0.1", port)) as conn:
            conn.sendall(b"GET / HTTP/1.1\r\nHost: localhost\r\nX-Slow: ")  # and no more
            assert _answer(conn).startswith(b"HTTP/1.1 408")
            record("attack30_slowloris", incomplete_request="408, closed")


def test_a_connection_that_sends_nothing_is_closed() -> None:
    """A connection that sends nothing is answered 408 and closed after the request timeout."""
    for port in _guarded(request_timeout=0.3):
        with socket.create_connection(("127.0.0.1", port)) as conn:
            assert _answer(conn).startswith(b"HTTP/1.1 408")


async def _reads_body(scope: dict[str, Any], receive: Any, send: Any) -> None:
    if scope["type"] != "http":
        return
    while True:
        message = await receive()
        if message["type"] == "http.disconnect":
            return
        if not message.get("more_body"):
            break
    await send({"type": "http.response.start", "status": 200, "headers": []})
    await send({"type": "http.response.body", "body": b"ok"})


def test_a_slow_body_is_cut_off() -> None:
    """A body that arrives too slowly is cut off with 408."""
    for port in _guarded(app=_reads_body, request_timeout=0.3):
        with socket.create_connection(("127.0.0.1", port)) as conn:
            conn.sendall(b"POST / HTTP/1.1\r\nHost: localhost\r\nContent-Length: 99\r\n\r\nab")
            assert _answer(conn).startswith(b"HTTP/1.1 408")


def test_connections_over_the_per_client_cap_are_closed_and_others_served() -> None:
    """A client's connection past its cap is closed unread, while another address is still served
    200."""
    for port in _guarded(request_timeout=30.0, max_per_client=5, max_connections=50):
        held = [socket.create_connection(("127.0.0.1", port)) for _ in range(5)]
        try:
            extra = socket.create_connection(("127.0.0.1", port))
            assert _answer(extra) == b""  # closed before anything was read
            extra.close()
            # another address is not held up by this one's connections
            other = ("127.0.0.2", 0)
            with socket.create_connection(("127.0.0.1", port), source_address=other) as c:
                c.sendall(b"GET / HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n")
                assert _answer(c).startswith(b"HTTP/1.1 200")
        finally:
            for conn in held:
                conn.close()


def test_after_a_flood_of_idle_connections_the_server_serves_again() -> None:
    """After a flood of idle connections past every cap, the server serves a request again."""
    for port in _guarded(request_timeout=0.3, max_per_client=20, max_connections=20):
        flood = [socket.create_connection(("127.0.0.1", port)) for _ in range(60)]

        def served(port: int = port) -> bool:
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=5) as c:
                    c.sendall(b"GET / HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n")
                    return _answer(c).startswith(b"HTTP/1.1 200")
            except OSError:
                return False

        try:
            assert wait_for(served, timeout=60, poll=0.1)
        finally:
            for conn in flood:
                conn.close()


def test_accept_errors_are_logged_once_per_interval(caplog: pytest.LogCaptureFixture) -> None:
    """A thousand accept errors within one interval log one warning naming the error."""
    import errno

    from twin.web.connections import throttled_exceptions

    loop = asyncio.new_event_loop()
    try:
        throttled_exceptions(loop, interval=3600)
        with caplog.at_level("WARNING", logger="twin.web.connections"):
            for _ in range(1000):
                loop.call_exception_handler({
                    "message": "socket.accept() out of system resource",
                    "exception": OSError(errno.EMFILE, "Too many open files"),
                })  # fmt: skip
        assert len(caplog.records) == 1
        assert "Too many open files" in caplog.records[0].getMessage()
        record("attack30_accept_log", accept_errors=1000, log_lines=len(caplog.records))
    finally:
        loop.close()


# -- the viewer's port (issue 30's low findings) -----------------------------------------------


def _handshake(port: int, origin: bytes) -> bytes:
    with socket.create_connection(("127.0.0.1", port)) as conn:
        conn.sendall(
            b"GET / HTTP/1.1\r\nHost: localhost\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
            b"Origin: " + origin + b"\r\n\r\n"
        )
        conn.settimeout(60)
        return conn.recv(200)


@pytest.fixture(scope="module")
def moved_viewer() -> Iterator[tuple[Any, int]]:
    """A viewer asked for a port another process holds: it moves to the next free one. Its
    policy is the one `twin serve` gives it: the REST port's origins, and its own port's."""
    from tests.web.support import free_port
    from twin.sim.live import LiveSession
    from twin.web.viewer import start_viewer

    squatter = socket.socket()
    squatter.bind(("127.0.0.1", 0))
    squatter.listen()
    taken = squatter.getsockname()[1]
    session = LiveSession({"sea_state": 3})
    policy = Access.for_server("127.0.0.1", (free_port(),))
    viewer = start_viewer(
        session, port=taken, access=policy, quiet_logs=quiet_malformed_messages
    )
    try:
        assert viewer.port != taken
        yield viewer, taken
    finally:
        viewer.stop()
        squatter.close()


def test_the_viewer_trusts_its_own_port_not_the_one_it_moved_from(moved_viewer) -> None:
    """A viewer that moved port accepts a handshake from its own origin (101) and refuses the taken
    port's (403)."""
    viewer, taken = moved_viewer
    own = _handshake(viewer.port, f"http://127.0.0.1:{viewer.port}".encode())
    assert own.startswith(b"HTTP/1.1 101")
    squatted = _handshake(viewer.port, f"http://127.0.0.1:{taken}".encode())
    assert squatted.startswith(b"HTTP/1.1 403")
    record("attack30_viewer_origin", own_port=101, squatted_port=403)


def test_a_non_utf8_origin_on_the_viewer_is_400(moved_viewer) -> None:
    """A viewer handshake with a non-UTF-8 Origin is answered 400."""
    viewer, _ = moved_viewer
    assert _handshake(viewer.port, b"http://\xff\xfe").startswith(b"HTTP/1.1 400")


def test_malformed_viewer_messages_are_logged_once_per_client_per_interval(
    moved_viewer, caplog: pytest.LogCaptureFixture
) -> None:
    """Malformed viewer messages from one client log one warning, naming the client, with no
    traceback."""
    import viser
    import websockets

    viewer, _ = moved_viewer
    protocol = websockets.Subprotocol(f"viser-v{viser.__version__}")

    async def garbage() -> None:
        url = f"ws://127.0.0.1:{viewer.port}"
        async with websockets.connect(url, subprotocols=[protocol], max_size=None) as ws:
            await ws.send(b"\x00not msgpack\xff")
            try:
                while True:
                    await asyncio.wait_for(ws.recv(), 30)
            except Exception:
                pass  # the server closed it

    with caplog.at_level("WARNING", logger="websockets.server"):
        for _ in range(4):
            asyncio.run(garbage())
        assert wait_for(lambda: any("malformed" in r.getMessage() for r in caplog.records))
    malformed = [r for r in caplog.records if r.name == "websockets.server"]
    assert len(malformed) == 1, [r.getMessage() for r in malformed]
    record("attack30_malformed", messages=4, log_lines=1, traceback=False)
    assert "127.0.0.1" in malformed[0].getMessage() and malformed[0].exc_info is None

"""Connections of the REST port: nobody holds sockets open without sending a request.

uvicorn (0.55, h11) times out an idle keep-alive connection only once it has answered a
request, and never a request that is still arriving: 20,000 connections that sent half a
request held the server at its file-descriptor limit, and every failed `accept` logged a
traceback (issue 30, slowloris). `guarded_protocol` builds uvicorn's h11 protocol with:

- **a request deadline**: from the moment a connection opens (or a keep-alive connection
  starts its next request) the whole request, headers and body, must arrive within
  `REQUEST_TIMEOUT` s; past it the server answers 408 (nothing answered yet) or closes;
- **connection caps**: at most `max_connections` open at once, below the process's fd limit
  (`connection_cap`), and `max_per_client` from one address; one over a cap is closed at once,
  before it is read;
- **idle keep-alives** close after uvicorn's `timeout_keep_alive` (`KEEP_ALIVE`);
- **logs once per interval**: refusals and `accept` errors are counted and logged at most once
  per `LOG_INTERVAL` s (`throttled_exceptions`), never a traceback per connection.

A flood therefore costs at most the caps' sockets for at most `REQUEST_TIMEOUT` s: once it
stops, the server serves again within that time.
"""

from __future__ import annotations

import asyncio
import errno
import logging
import resource
import time
from collections import Counter
from typing import Any

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

log = logging.getLogger("twin.web.connections")

#: [s] the longest a request (headers and body) may take to arrive
REQUEST_TIMEOUT = 10.0
#: [s] an idle keep-alive connection is closed after this long (uvicorn's `timeout_keep_alive`)
KEEP_ALIVE = 5
#: most connections at once (lowered to fit the fd limit, `connection_cap`)
MAX_CONNECTIONS = 1000
#: most connections at once from one client address
MAX_PER_CLIENT = 128
#: [s] refusals and accept errors are logged at most once per interval, with their count
LOG_INTERVAL = 60.0
#: file descriptors kept for everything else: the store, the viewer, the executor's sockets
FD_RESERVE = 256

_RESOURCE_ERRORS = {errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM}
_BODY = b"request not received in time: connection closed\n"
_TIMED_OUT = (
    b"HTTP/1.1 408 Request Timeout\r\ncontent-type: text/plain; charset=utf-8\r\n"
    b"connection: close\r\ncontent-length: " + str(len(_BODY)).encode() + b"\r\n\r\n" + _BODY
)


def connection_cap(limit: int = MAX_CONNECTIONS) -> int:
    """`limit`, lowered so that the REST port's connections and the viewer's fit the process's
    soft fd limit with `FD_RESERVE` to spare (never below 16)."""
    soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft == resource.RLIM_INFINITY:
        return limit
    return max(16, min(limit, (soft - FD_RESERVE) // 2))


class Throttled:
    """Counts an event and logs it at most once per `interval` s, with how many there were."""

    def __init__(self, what: str, interval: float = LOG_INTERVAL) -> None:
        self.what, self.interval = what, interval
        self.count = 0
        self.logged = 0
        self._last = -float("inf")

    def __call__(self, detail: str = "") -> None:
        self.count += 1
        now = time.monotonic()
        if now - self._last >= self.interval:
            span = min(now - self._last, self.interval)
            suffix = f" ({detail})" if detail else ""
            log.warning("%s: %d in the last %.0f s%s", self.what, self.count - self.logged, span,
                        suffix)  # fmt: skip
            self._last, self.logged = now, self.count


def throttled_exceptions(loop: asyncio.AbstractEventLoop, interval: float = LOG_INTERVAL) -> None:
    """Make `loop` log `accept` errors (out of fds, buffers, memory) once per `interval` with
    their count instead of a traceback each; every other error goes to the handler before."""
    previous = loop.get_exception_handler()
    accept = Throttled("accept errors (out of file descriptors or memory?)", interval)

    def handler(loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
        exc = context.get("exception")
        message = str(context.get("message", ""))
        if message.startswith("socket.accept()") or (
            isinstance(exc, OSError) and exc.errno in _RESOURCE_ERRORS
        ):
            accept(f"{type(exc).__name__}: {exc}" if exc else message)
            return
        if previous is not None:
            previous(loop, context)
        else:
            loop.default_exception_handler(context)

    loop.set_exception_handler(handler)


def guarded_protocol(
    request_timeout: float = REQUEST_TIMEOUT,
    max_connections: int | None = None,
    max_per_client: int = MAX_PER_CLIENT,
) -> type[H11Protocol]:
    """uvicorn's h11 protocol with a request deadline and connection caps (module docstring);
    one class per server (its counts are the server's). Pass it as `uvicorn.Config(http=…)`.
    """
    cap = connection_cap() if max_connections is None else max_connections
    per_client: Counter[str] = Counter()
    refused = Throttled("connections refused over the caps")
    timed_out = Throttled("requests not received in time")

    class Guarded(H11Protocol):
        _deadline: asyncio.TimerHandle | None = None
        _counted: str | None = None
        _refused = False

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            peer = transport.get_extra_info("peername")
            host = str(peer[0]) if isinstance(peer, tuple) and peer else "unknown"
            if len(self.connections) >= cap or per_client[host] >= max_per_client:
                # before uvicorn counts it: a refused connection never makes the server look
                # busy (its `limit_concurrency` answers 503 past as many connections)
                refused(f"{len(self.connections)} open, {per_client[host]} from {host}")
                self.transport = transport
                self._refused = True
                transport.abort()  # before anything is read: no buffer, no task
                return
            super().connection_made(transport)
            per_client[host] += 1
            self._counted = host
            self._arm()

        def connection_lost(self, exc: Exception | None) -> None:
            if self._refused:
                return  # never became one of uvicorn's connections
            self._disarm()
            if self._counted is not None:
                per_client[self._counted] -= 1
                if per_client[self._counted] <= 0:
                    del per_client[self._counted]
                self._counted = None
            super().connection_lost(exc)

        def data_received(self, data: bytes) -> None:
            super().data_received(data)
            if self.transport.is_closing() or self.conn.their_state is h11.DONE:
                self._disarm()  # the whole request is in: the app has it
            elif self._deadline is None:
                self._arm()  # a keep-alive connection's next request began

        def handle_websocket_upgrade(self, event: Any) -> None:
            self._disarm()  # the connection is another protocol's now
            super().handle_websocket_upgrade(event)

        def _arm(self) -> None:
            self._disarm()
            self._deadline = self.loop.call_later(request_timeout, self._expired)

        def _disarm(self) -> None:
            if self._deadline is not None:
                self._deadline.cancel()
                self._deadline = None

        def _expired(self) -> None:
            self._deadline = None
            if self.transport.is_closing() or self.conn.their_state is h11.DONE:
                return
            timed_out(str(self.client[0]) if self.client else "")
            cycle = self.cycle
            answered = cycle is not None and cycle.response_started
            if cycle is not None and not cycle.response_complete:
                cycle.disconnected = True  # the app's receive() ends: the body never came
                cycle.message_event.set()
            if not answered:
                self.transport.write(_TIMED_OUT)
            self.transport.close()

    return Guarded


class MalformedMessages(logging.Filter):
    """A filter for the `websockets.server` logger: a viewer message that cannot be decoded
    (a client sending garbage) closes that connection, and websockets logged a 730-byte
    traceback each time (issue 30). Here it is one line per client address per `interval` s,
    with the count since the last; every other record passes unchanged.
    """

    #: functions of viser's message loop: an exception raised under them is the client's input
    DECODING = frozenset({"_message_consumer", "deserialize"})

    def __init__(self, interval: float = LOG_INTERVAL, clients: int = 1024) -> None:
        super().__init__()
        self.interval, self.clients = interval, clients
        self._last: dict[str, tuple[float, int]] = {}  # client → (last logged, count since)

    def _malformed(self, record: logging.LogRecord) -> str | None:
        """The client address of a failed message decode ("unknown" if not found), or None
        for any other record."""
        if record.getMessage() != "connection handler failed" or not record.exc_info:
            return None
        tb, decoding, client = record.exc_info[2], False, "unknown"
        while tb is not None:
            frame = tb.tb_frame
            decoding = decoding or frame.f_code.co_name in self.DECODING
            for name in ("websocket", "connection"):  # the handler's own locals
                address = getattr(frame.f_locals.get(name), "remote_address", None)
                if address:
                    client = str(address[0])
            tb = tb.tb_next
        return client if decoding else None

    def filter(self, record: logging.LogRecord) -> bool:
        client = self._malformed(record)
        if client is None:
            return True
        now = time.monotonic()
        last, count = self._last.get(client, (-float("inf"), 0))
        count += 1
        if now - last < self.interval:
            self._last[client] = (last, count)
            return False
        if len(self._last) >= self.clients:  # forget the quietest: memory stays bounded
            self._last = {k: v for k, v in self._last.items() if now - v[0] < self.interval}
        self._last[client] = (now, 0)
        exc = record.exc_info[1] if record.exc_info else None
        record.msg = "viewer: malformed message from %s closed its connection (%s: %s); %d in "
        record.msg += "the last %.0f s"
        record.args = (client, type(exc).__name__, exc, count, self.interval)
        record.exc_info = record.exc_text = None  # one line, no traceback
        record.levelno, record.levelname = logging.WARNING, "WARNING"
        return True


def quiet_malformed_messages(interval: float = LOG_INTERVAL) -> MalformedMessages:
    """Install `MalformedMessages` on the `websockets.server` logger, once per process."""
    logger = logging.getLogger("websockets.server")
    for existing in logger.filters:
        if isinstance(existing, MalformedMessages):
            return existing
    installed = MalformedMessages(interval)
    logger.addFilter(installed)
    return installed

"""Fair limits and header checks of the REST port (issue 30).

Wrong tokens are limited per (client, failure), so nobody else's failures refuse the token
holder; the client address is the socket's unless trusted proxies are named; Origin headers
that are not UTF-8, or more than one, are refused as the viewer refuses them.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import uvicorn
from fastapi.testclient import TestClient

from tests.figures import record
from tests.web.support import SAME_ORIGIN, TOKEN, access, wait_for
from twin.sim.live import LiveSession
from twin.web import RunStore, create_app
from twin.web.access import FAILURE_BURST
from twin.web.server import listen, uvicorn_config


@pytest.fixture
def client(tmp_path: Path) -> TestClient:
    store = RunStore(tmp_path / "runs.sqlite")
    return TestClient(create_app(LiveSession({"sea_state": 3}), store, access=access(TOKEN)))


def _patch(client: TestClient, token: str, **headers: str) -> int:
    return client.patch(
        "/api/live", json={"beta": 0.5}, headers={"Authorization": f"Bearer {token}", **headers}
    ).status_code


def test_wrong_tokens_from_an_address_never_refuse_the_right_one(client: TestClient) -> None:
    """The red team's lock-out: ten wrong PATCHes made the holder's right one a 429."""
    codes = [_patch(client, f"guess-{i % 2:02d}-0000000000") for i in range(3 * FAILURE_BURST)]
    assert 429 in codes  # the guesser is limited …
    assert _patch(client, TOKEN) == 200  # … the holder, from the same address, is not
    record("attack30_lockout", wrong=len(codes), refused_429=codes.count(429), holder=200)


def test_wrong_tokens_sharing_the_holders_prefix_never_refuse_it(client: TestClient) -> None:
    """Issue 43: 15 wrong tokens that share the holder's first 4 (or more) characters, each
    sent again past its burst, locked the holder out when the limit was keyed on a prefix."""
    wrong = [TOKEN[:8] + f"{i:02d}" + "x" * (len(TOKEN) - 10) for i in range(15)]
    codes = [_patch(client, guess) for guess in wrong for _ in range(FAILURE_BURST + 1)]
    assert codes.count(429) == len(wrong)  # each wrong token is limited on its own …
    assert _patch(client, TOKEN) == 200  # … and the holder's is never among them
    record("attack43_prefix_lockout", wrong=len(codes), refused_429=codes.count(429), holder=200)


def test_the_same_wrong_token_again_and_again_is_limited(client: TestClient) -> None:
    """One wrong token is compared `FAILURE_BURST` times, then refused before comparison."""
    codes = [_patch(client, "wrong-wrong-wrong-1") for _ in range(FAILURE_BURST + 2)]
    assert codes[:FAILURE_BURST] == [401] * FAILURE_BURST
    assert codes[-1] == 429


def test_failure_keys_separate_clients_and_whole_tokens() -> None:
    """The key is the address and a keyed hash of the whole token: tokens sharing a prefix,
    or differing in their last byte, have keys of their own; no key shows its token, and
    another policy (another server process) keys the same token differently."""
    key = access(TOKEN).failure_key
    assert key("1.2.3.4", "abcdXYZ") == key("1.2.3.4", b"abcdXYZ")
    assert key("1.2.3.4", "abcdXYZ") != key("1.2.3.4", "abcdQQQ")  # same prefix: own bucket
    assert key("1.2.3.4", TOKEN[:-1] + "?") != key("1.2.3.4", TOKEN)
    assert key("1.2.3.4", "abcdXYZ") != key("1.2.3.5", "abcdXYZ")
    assert key("1.2.3.4", None) == key("1.2.3.4", "")  # no token: a failure kind of its own
    assert "abcd" not in key("1.2.3.4", "abcdXYZ") and "61626364" not in key("1.2.3.4", "abcd")
    assert access(TOKEN).failure_key("1.2.3.4", "abcdXYZ") != key("1.2.3.4", "abcdXYZ")


def test_a_non_utf8_origin_is_400_not_500(tmp_path: Path) -> None:
    """Over a socket: the test client would re-encode the header as UTF-8."""
    store = RunStore(tmp_path / "runs.sqlite")
    app = create_app(LiveSession({"sea_state": 3}), store, access=access(TOKEN))
    for port in _serve(app):
        with socket.create_connection(("127.0.0.1", port)) as conn:
            conn.sendall(
                b"PATCH /api/live HTTP/1.1\r\nHost: testserver\r\nConnection: close\r\n"
                b"Origin: http://\xff\xfe\r\nAuthorization: Bearer " + TOKEN.encode()
                + b"\r\nContent-Type: application/json\r\nContent-Length: 2\r\n\r\n{}"
            )
            answer = b""
            while chunk := conn.recv(4096):
                answer += chunk
        assert answer.startswith(b"HTTP/1.1 400"), answer[:200]
        assert b"UTF-8" in answer


def test_two_origin_headers_are_refused_even_if_the_last_is_ours(client: TestClient) -> None:
    """A request with two Origin headers is refused 403 even if the last is ours; one same-origin
    header passes."""
    response = client.patch(
        "/api/live", json={"beta": 0.5},
        headers=[("Authorization", f"Bearer {TOKEN}"), ("Origin", "http://evil.example"),
                 ("Origin", SAME_ORIGIN)],
    )  # fmt: skip
    assert response.status_code == 403
    assert _patch(client, TOKEN, Origin=SAME_ORIGIN) == 200


# -- the client address behind uvicorn -------------------------------------------------------


async def _whoami(scope: dict[str, Any], receive: Any, send: Any) -> None:
    if scope["type"] != "http":
        return
    body = scope["client"][0].encode()
    length = [(b"content-length", str(len(body)).encode())]
    await send({"type": "http.response.start", "status": 200, "headers": length})
    await send({"type": "http.response.body", "body": body})


def _serve(app: Any = _whoami, **options: Any) -> Iterator[int]:
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


def _ask(port: int, forwarded: str) -> bytes:
    with socket.create_connection(("127.0.0.1", port)) as conn:
        conn.sendall(
            b"GET / HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n"
            b"X-Forwarded-For: " + forwarded.encode() + b"\r\n\r\n"
        )
        answer = b""
        while chunk := conn.recv(4096):
            answer += chunk
    return answer.split(b"\r\n\r\n", 1)[1]


def test_x_forwarded_for_is_ignored_by_default() -> None:
    """uvicorn's own default trusts X-Forwarded-For from loopback: a made-up one picked the
    address that limits apply to."""
    for port in _serve():
        assert _ask(port, "203.0.113.7") == b"127.0.0.1"
        record("attack30_xff", sent="203.0.113.7", client_seen="127.0.0.1")


def test_x_forwarded_for_names_the_client_behind_a_trusted_proxy() -> None:
    """Behind a trusted proxy, X-Forwarded-For names the client the server sees."""
    for port in _serve(forwarded_allow_ips=("127.0.0.1",)):
        assert _ask(port, "203.0.113.7") == b"203.0.113.7"

"""The viewer port's Host and Origin checks, as a script or a hostile page would meet them."""

from __future__ import annotations

import http.client
import time

import pytest

from tests.figures import record
from tests.web.support import free_port, wait_for
from tests.web.viser_client import ViserClient
from twin.sim.live import LiveSession
from twin.web.access import Access
from twin.web.viewer import (
    Viewer,
    start_viewer,
)


def test_a_cross_origin_websocket_is_refused(viewer: Viewer, session: LiveSession) -> None:
    """A page from another origin (or under a DNS name of its own) cannot open the viewer's
    websocket: 403 at the handshake, so it reads nothing and sends nothing. The viewer's own
    origin, and a script without Origin, connect."""
    from websockets.exceptions import InvalidStatus

    before = (session.scenario, session.controls.model_dump(), session.version)
    refused = []
    for origin in ("http://evil.example", f"http://evil.example:{viewer.port}", "null",
                   f"https://127.0.0.1:{viewer.port}", "http://127.0.0.1:1"):  # fmt: skip
        with pytest.raises(InvalidStatus) as exc:
            ViserClient(viewer.port, origin=origin)
        refused.append(exc.value.response.status_code)
    assert refused == [403] * 5
    own = f"http://127.0.0.1:{viewer.port}"
    with pytest.raises(InvalidStatus) as exc:  # two Origins, even both its own, are none
        ViserClient(viewer.port, origin=[own, own])
    assert exc.value.response.status_code == 403
    assert (session.scenario, session.controls.model_dump(), session.version) == before
    for origin in (f"http://127.0.0.1:{viewer.port}", f"http://localhost:{viewer.port}", None):
        ViserClient(viewer.port, origin=origin).close()
    record("attack_cross_origin_websocket", origins_tried=len(refused), handshake=403,
           changed="nothing")  # fmt: skip


def get(port: int, path: str, host: str | None) -> tuple[int, str]:
    """`GET path` from the viewer's port with exactly this Host header (None: none at all), as
    a page under another DNS name (DNS rebinding) would send it: (status, body)."""
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        connection.putrequest("GET", path, skip_host=True)
        if host is not None:
            connection.putheader("Host", host)
        connection.endheaders()
        response = connection.getresponse()
        return response.status, response.read().decode("utf-8", "replace")
    finally:
        connection.close()


def test_a_spoofed_host_is_refused_on_the_viewer_port(
    viewer: Viewer, session: LiveSession, caplog: pytest.LogCaptureFixture
) -> None:
    """The viewer's port passes the REST API's Host check: a websocket handshake or a page
    request whose Host is not one of the server's names (a DNS-rebinding page, whatever its
    Origin) or is missing gets 400 naming it, builds no panel and changes nothing. Its own
    names, with and without the port, are served."""
    from websockets.exceptions import InvalidStatus

    port = viewer.port
    before = (session.scenario, session.controls.model_dump(), session.version)
    panels = set(viewer.gui.panels)
    refused = []
    for host, origin in (("evil.example", None), (f"evil.example:{port}", None),
                         (f"evil.example:{port}", f"http://evil.example:{port}"),
                         (f"evil.example:{port}", f"http://127.0.0.1:{port}"),
                         (f"127.0.0.1.evil.example:{port}", None)):  # fmt: skip
        with caplog.at_level("WARNING", logger="twin.web.viewer.handshake"):
            with pytest.raises(InvalidStatus) as exc:
                ViserClient(port, origin=origin, host=host)
        response = exc.value.response
        refused.append(response.status_code)
        assert repr(host) in response.body.decode() and "--allow-host" in response.body.decode()
    assert refused == [400] * 5
    assert sum("viewer: request for Host" in r.getMessage() for r in caplog.records) == 5
    time.sleep(0.3)  # a handshake that got through would have built a panel by now
    assert set(viewer.gui.panels) == panels
    assert (session.scenario, session.controls.model_dump(), session.version) == before
    # the page (and anything else on the port) alike; without a Host too
    pages = [get(port, path, host) for path in ("/", "/index.html", "/assets/index.js")
             for host in ("evil.example", f"evil.example:{port}", None)]  # fmt: skip
    assert [status for status, _ in pages] == [400] * 9
    assert "'evil.example'" in pages[0][1] and "None" in pages[2][1]
    assert all("<html" not in body for _, body in pages)
    for host in (f"127.0.0.1:{port}", f"localhost:{port}", "localhost", f"[::1]:{port}"):
        status, body = get(port, "/", host)
        assert (status, "<html" in body) == (200, True), host
    ViserClient(port, origin=f"http://127.0.0.1:{port}", host=f"127.0.0.1:{port}").close()
    ViserClient(port, host=f"localhost:{port}").close()
    record("attack_viewer_host_spoofing", handshakes_tried=len(refused), handshake=400,
           page_requests_tried=len(pages), page=400, changed="nothing")  # fmt: skip


def test_an_allowed_host_reaches_the_viewer(session: LiveSession) -> None:
    """A name given with `--allow-host` (`Access.for_server(allow_hosts=...)`) is served on
    the viewer's port, page and websocket; other names are still refused."""
    from websockets.exceptions import InvalidStatus

    port = free_port()
    access = Access.for_server("127.0.0.1", (port,), allow_hosts=("twin.example",))
    viewer = start_viewer(session, port=port, access=access)
    try:
        port = viewer.port
        status, body = get(port, "/", f"twin.example:{port}")
        assert (status, "<html" in body) == (200, True)
        assert get(port, "/", "TWIN.example")[0] == 200  # a host name is case-insensitive
        assert get(port, "/", f"evil.example:{port}")[0] == 400
        before = set(viewer.gui.panels)
        client = ViserClient(
            port, origin=f"http://twin.example:{port}", host=f"twin.example:{port}"
        )
        client.hello()
        assert wait_for(lambda: set(viewer.gui.panels) - before, 10.0), "no panel was built"
        client.close()
        with pytest.raises(InvalidStatus) as exc:
            ViserClient(port, host=f"evil.example:{port}")
        assert exc.value.response.status_code == 400
    finally:
        viewer.stop()

"""The viewer port's checks of every HTTP request and websocket handshake, before viser
serves anything.

Any request (the page, its assets, the websocket handshake) whose Host is missing or not a
name the server answers to (loopback names, the bind address, `--allow-host`) is refused
(400), as REST refuses it, so a page reached through a DNS name of its own (DNS rebinding)
gets nothing. A cross-origin websocket handshake is refused (403): a page from another site
cannot open it, so it can neither read the scene nor send a control. Allowed origins are the
server's own (http on an allowed host at the viewer's or the REST port) and those given with
`--allow-origin` (`twin.web.access`). A page's report of its WebGL renderer
(`twin.web.viewer.graphics.RENDERER_PATH`) is answered here too. viser offers no hook for
this, so it is installed through `twin.web.viewer.viser_adapter.checked_handshake`.
"""

from __future__ import annotations

import http
import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Any
from urllib.parse import parse_qs, urlsplit

from twin.web.viewer.graphics import RENDERER_PATH
from twin.web.viewer.viser_adapter import Handshake

if TYPE_CHECKING:  # the server's policy, handed in (`start_viewer`)
    from twin.web.access import Access

logger = logging.getLogger(__name__)


def request_check(
    access: Access, port: Callable[[], int], on_renderer: Callable[[str, str], None]
) -> Handshake:
    """The check of one viewer's requests (`viser_adapter.checked_handshake` installs it).

    Args:
        access: the server's Host names and origins.
        port: the viewer's port (its own origin), once bound.
        on_renderer: called (key, renderer) on viser's event loop for a page's renderer
            report; it must return at once (`Viewer.renderer_reported`).
    """

    def check(connection: Any, request: Any) -> Any:
        """A refusal (400 or 403) of the request, or None to let viser serve it."""
        # Host first, on every request (the page, its assets, the websocket): as REST does.
        hosts = request.headers.get_all("Host")  # one, or it is no Host (RFC 9112 § 3.2)
        named = hosts[0] if len(hosts) == 1 else ", ".join(hosts) or None
        if len(hosts) != 1 or not access.allows_host(named):
            logger.warning("viewer: request for Host %r refused", named)
            return connection.respond(
                http.HTTPStatus.BAD_REQUEST,
                f"Host {named!r} is not a name this server answers to; start it with "
                "--allow-host NAME to allow one\n",
            )
        url = urlsplit(request.path)
        if url.path.endswith(RENDERER_PATH):  # a page telling its WebGL renderer
            query = parse_qs(url.query)
            key, name = query.get("key", [""])[0], query.get("renderer", [""])[0][:200]
            on_renderer(key, name)  # returns at once: it ignores a key it did not give out
            return connection.respond(http.HTTPStatus.OK, "noted\n")
        if request.headers.get("Upgrade", "").lower() != "websocket":
            return None  # the page and its assets: the same for anyone it answers to
        origins = request.headers.get_all("Origin")
        if not origins:
            return None  # no Origin: not a browser page (a script); the token still applies
        try:  # websockets reads headers as ASCII with surrogate escapes; UTF-8 text or 400
            origins = [o.encode("ascii", "surrogateescape").decode("utf-8") for o in origins]
        except UnicodeError:
            logger.warning("viewer: websocket with a non-UTF-8 Origin refused")
            return connection.respond(
                http.HTTPStatus.BAD_REQUEST, "Origin header is not UTF-8 text: not an origin\n"
            )
        origin = ", ".join(origins)  # two Origins are no origin: refused below
        if len(origins) == 1 and access.allows_origin(origin, port=port()):
            return None
        logger.warning("viewer: cross-origin websocket from %s refused", origin)
        return connection.respond(
            http.HTTPStatus.FORBIDDEN, f"cross-origin websocket from {origin} refused\n"
        )

    return check

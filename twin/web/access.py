"""Who may change the twin: same-origin requests and, when the server has one, the token.

Checked in an ASGI middleware, before the app reads a body: a request without the token is a
401 whatever its body holds (a malformed body must not earn a 422 that tells an unknown
client how the API parses), and a browser page from another origin is a 403 (no CORS headers
are ever sent either, so other sites can neither read answers nor drive the twin).
"""

from __future__ import annotations

import hmac
from urllib.parse import urlsplit

from twin.web.limits import ASGIApp, Receive, Scope, Send, refuse

#: methods that change something; GET and HEAD stay open
MUTATING = frozenset({"POST", "PATCH", "PUT", "DELETE"})


class Guard:
    """ASGI middleware: mutating requests need the same origin and, if set, the bearer token.

    Args:
        app: the ASGI app.
        token: if set, `Authorization: Bearer <token>`, compared in constant time.
    """

    def __init__(self, app: ASGIApp, token: str | None = None) -> None:
        self.app = app
        self._token = None if token is None else token.encode()

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http" and scope["method"] in MUTATING:
            headers = dict(scope.get("headers", []))
            # Browsers send Origin with every POST/PATCH; scripts send none. A page from
            # another origin (another site, or the viewer's port) must not drive the twin.
            origin = headers.get(b"origin")
            host = headers.get(b"host", b"").decode("latin-1")
            if origin is not None and urlsplit(origin.decode("latin-1")).netloc != host:
                await refuse(send, 403, f"cross-origin request from {origin.decode()} refused")
                return
            if self._token is not None:
                scheme, _, given = headers.get(b"authorization", b"").partition(b" ")
                # constant time: no timing oracle on how much of the token was right
                right = hmac.compare_digest(given.strip(), self._token)
                if scheme.lower() != b"bearer" or not right:
                    await refuse(
                        send,
                        401,
                        "missing or wrong token: send Authorization: Bearer <token>",
                        ((b"www-authenticate", b"Bearer"),),
                    )
                    return
        await self.app(scope, receive, send)

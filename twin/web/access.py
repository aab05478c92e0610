"""Who may talk to the twin: the hosts it answers to, the origins it trusts, and the token.

`Access` is the policy, shared by the REST app (`Guard`, an ASGI middleware) and the 3D viewer
(`twin.web.viewer`, which checks the websocket handshake and unlocks controls with the token):

- **Host** (every REST request): the `Host` header must name the server as it was started: a
  loopback name (localhost, 127.0.0.1, ::1), the address it is bound to, or a name given with
  `--allow-host`. A page that reaches the server through a DNS name of its own (DNS
  rebinding) sends its own name as Host, and is refused (400) before anything is read.
- **Origin** (REST POST and PATCH, and the viewer's websocket handshake): a browser's Origin is
  compared as scheme + host + port with the server's own origins (http on an allowed host, at
  the REST or the viewer port) and those given with `--allow-origin`; anything else is a 403.
  A request without Origin (a script, curl) is not a browser page and is let through to the
  token check. Its Host header is never used to decide what is same-origin.
- **Token** (REST POST, PATCH and DELETE; the viewer's controls): if set, at least
  `MIN_TOKEN` characters, compared in constant time. Wrong tokens are limited per (client
  address, the failure: a keyed hash of the whole token sent, HMAC-SHA256 under a key drawn
  at random when the policy is made, or "none"): past `failure_burst` tries of one wrong token
  a client is refused (429) for a while before that token is even compared again. The right
  token is never counted as a failure, and no other token shares its key, so nobody else's
  failures, from the same address, a NAT or a proxy, ever refuse it (issue 30: ten wrong
  PATCHes from an address made the holder's right one a 429; issue 43: fifteen wrong tokens
  sharing its first 4 characters did, when the key was a 4-character prefix).
  The client address is the socket's, unless the server names trusted proxies
  (`--forwarded-allow-ips`): a made-up X-Forwarded-For picks no address.

The middleware runs before the app reads a body: a request without the token is a 401
whatever its body holds (a malformed body must not earn a 422 that tells an unknown client how
the API parses). No CORS headers are ever sent either, so other sites can neither read
answers nor drive the twin.
"""

from __future__ import annotations

import hashlib
import hmac
import ipaddress
import math
import secrets
from collections.abc import Iterable
from dataclasses import dataclass, field
from urllib.parse import urlsplit

from twin.errors import TwinError
from twin.web.limits import ASGIApp, RateLimit, Receive, Scope, Send, refuse

#: methods that change something; GET and HEAD stay open
MUTATING = frozenset({"POST", "PATCH", "PUT", "DELETE"})
#: names every server answers to
LOOPBACK_NAMES = frozenset({"localhost", "127.0.0.1", "::1"})
#: addresses that bind every interface: not a name a client uses
WILDCARDS = frozenset({"0.0.0.0", "::", ""})
#: fewest characters of a token (16 random hex digits are 64 bits)
MIN_TOKEN = 16
#: failed token attempts a client may make at once, then [1/s] how fast it gets more
FAILURE_BURST = 10
FAILURE_RATE = 0.2
#: the scope key the middleware sets on a request it let through
GRANTED = "twin.access"
#: what a private server's GETs need the token for: stored runs, series, sweeps, heatmaps,
#: workability jobs and their plots
PRIVATE_PATHS = ("/api/runs", "/api/sweeps", "/api/workability")


def split_host(value: str) -> tuple[str, int | None]:
    """A Host header (or host[:port]) as (lower-case name without brackets, port or None).

    Raises:
        ValueError: not a host (an empty name, a bad port, stray characters).
    """
    parts = urlsplit(f"//{value.strip()}")
    host = (parts.hostname or "").lower()
    if not host or parts.path or parts.query or parts.fragment or parts.username:
        raise ValueError(f"not a host: {value!r}")
    return host, parts.port  # .port raises ValueError for a bad port


def _netloc(host: str) -> str:
    return f"[{host}]" if ":" in host else host


def normalise_origin(value: str) -> str:
    """An origin as `scheme://host:port` (the default port of the scheme written out).

    Raises:
        ValueError: not an http(s) origin (a path, `null`, another scheme, a bad port).
    """
    parts = urlsplit(value.strip())
    if parts.scheme not in ("http", "https") or parts.path not in ("", "/"):
        raise ValueError(f"not an http(s) origin (scheme://host[:port]): {value!r}")
    if parts.query or parts.fragment or parts.username or not parts.hostname:
        raise ValueError(f"not an http(s) origin (scheme://host[:port]): {value!r}")
    port = parts.port or (443 if parts.scheme == "https" else 80)
    return f"{parts.scheme}://{_netloc(parts.hostname.lower())}:{port}"


def is_loopback(host: str) -> bool:
    """Whether binding `host` keeps a server reachable from this machine only."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


@dataclass(frozen=True)
class Access:
    """The access policy of one server (see the module docstring).

    Attributes:
        token: the bearer token (None: none; then only Host and Origin are checked).
        hosts: names the server answers to (lower case, IPv6 without brackets).
        origins: origins trusted as the server's own, normalised (`normalise_origin`).
        ports: the server's own ports (REST, viewer): http on an allowed host at one of them is
            one of its origins.
        failure_burst: wrong tokens a client may send at once; then 429 until it has waited.
        failure_rate: [1/s] how fast a client earns another attempt.
        private: with a token, reading stored data (`PRIVATE_PATHS`) needs it too; default
            False: GETs stay open (`twin serve --private`).
    """

    token: str | None = None
    hosts: frozenset[str] = LOOPBACK_NAMES
    origins: frozenset[str] = frozenset()
    ports: frozenset[int] = frozenset()
    failure_burst: int = FAILURE_BURST
    failure_rate: float = FAILURE_RATE
    private: bool = False
    _token: bytes | None = field(init=False, repr=False, compare=False)
    #: the failure keys' HMAC key: random per policy, so a key says nothing of its token
    _failure_secret: bytes = field(
        init=False, repr=False, compare=False, default_factory=lambda: secrets.token_bytes(32)
    )

    def __post_init__(self) -> None:
        if self.token is not None and len(self.token) < MIN_TOKEN:
            raise TwinError(
                f"token: {len(self.token)} characters; a token needs at least {MIN_TOKEN} "
                "(e.g. TWIN_TOKEN=$(openssl rand -hex 16))"
            )
        if not (self.failure_burst >= 1 and math.isfinite(self.failure_rate)
                and self.failure_rate > 0):  # fmt: skip
            raise TwinError("failure limit: need failure_burst ≥ 1 and failure_rate > 0")
        object.__setattr__(self, "_token", None if self.token is None else self.token.encode())

    @classmethod
    def for_server(
        cls,
        bind: str,
        ports: Iterable[int],
        *,
        token: str | None = None,
        allow_hosts: Iterable[str] = (),
        allow_origins: Iterable[str] = (),
        private: bool = False,
        failure_burst: int = FAILURE_BURST,
        failure_rate: float = FAILURE_RATE,
    ) -> Access:
        """The policy of a server bound to `bind` on `ports`.

        Args:
            bind: the address both servers bind; a name other than a wildcard is allowed as
                Host.
            ports: its REST and viewer ports.
            token: the bearer token, if any (≥ `MIN_TOKEN` characters).
            allow_hosts: more names it answers to (`--allow-host`), e.g. its DNS name.
            allow_origins: more origins it trusts (`--allow-origin`), e.g. a TLS proxy's
                `https://twin.example.com`.
            failure_burst, failure_rate: the failed-token limits (`Access`'s).

        Raises:
            ValueError: a host or origin that is not one (naming it), or a short token.
        """
        hosts = set(LOOPBACK_NAMES)
        if bind not in WILDCARDS:
            hosts.add(split_host(bind)[0] if ":" not in bind else bind.strip("[]").lower())
        for name in allow_hosts:
            try:
                host, port = split_host(name)
            except ValueError as exc:
                raise TwinError(f"--allow-host {name!r}: {exc}") from None
            if port is not None:
                raise TwinError(f"--allow-host {name!r}: a host name, without a port")
            hosts.add(host)
        origins = set()
        for origin in allow_origins:
            try:
                origins.add(normalise_origin(origin))
            except ValueError as exc:
                raise TwinError(f"--allow-origin {origin!r}: {exc}") from None
        return cls(
            token, frozenset(hosts), frozenset(origins), frozenset(ports),
            failure_burst=failure_burst, failure_rate=failure_rate, private=private,
        )  # fmt: skip

    def allows_host(self, header: str | None) -> bool:
        """Whether a request's Host header names this server (a request must have one)."""
        if header is None:
            return False
        try:
            return split_host(header)[0] in self.hosts
        except ValueError:
            return False

    def allows_origin(self, header: str, port: int | None = None) -> bool:
        """Whether a browser's Origin header is one of this server's own origins (http on an
        allowed host at one of its ports, or `port`), or one it was told to trust."""
        try:
            origin = normalise_origin(header)
        except ValueError:
            return False  # `null` (a sandboxed page or a file), or garbage
        if origin in self.origins:
            return True
        parts = urlsplit(origin)
        ports = self.ports | ({port} if port is not None else set())
        return parts.scheme == "http" and parts.hostname in self.hosts and parts.port in ports

    def token_matches(self, given: str | bytes) -> bool:
        """Constant-time comparison with the token (True when there is none)."""
        if self._token is None:
            return True
        given = given.encode() if isinstance(given, str) else given
        return hmac.compare_digest(given, self._token)

    def failure_limit(self) -> RateLimit:
        """A fresh per-client limit of failed token attempts (keyed by `failure_key`)."""
        return RateLimit(self.failure_rate, self.failure_burst)

    def failure_key(self, client: str, given: str | bytes | None) -> str:
        """The failure limit's key of a token attempt: the client and the failure (HMAC-SHA256
        of the whole token sent under this policy's random key, "none" without one)."""
        if isinstance(given, str):
            given = given.encode("utf-8", "replace")
        if not given:
            return f"{client} none"
        return f"{client} {hmac.new(self._failure_secret, given, hashlib.sha256).hexdigest()}"


def _client(scope: Scope) -> str:
    client = scope.get("client")
    return client[0] if client else "unknown"


class Guard:
    """ASGI middleware: the Host allow-list on every request; on mutating ones, Origin and the
    token (with its failure limit). A request let through carries `scope[GRANTED] = True`,
    which the routers' `require_access` dependency checks.

    Args:
        app: the ASGI app.
        access: the policy.
    """

    def __init__(self, app: ASGIApp, access: Access) -> None:
        self.app = app
        self.access = access
        self.failures = access.failure_limit()

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers", []))
        host = headers.get(b"host")
        host_text = None if host is None else host.decode("latin-1")
        if not self.access.allows_host(host_text):
            await refuse(
                send,
                400,
                f"Host {host_text!r} is not a name this server answers to; start it with "
                "--allow-host NAME to allow one",
            )
            return
        private = self.access.private and scope["path"].startswith(PRIVATE_PATHS)
        if scope["method"] in MUTATING or private:
            # Browsers send Origin with every POST/PATCH; scripts send none. A page from
            # another origin (another site, the viewer's port) must not drive the twin.
            # Every Origin header, not the last: two are no origin (refused, as the viewer
            # does); one that is not UTF-8 text is no URL at all (400, not a 500).
            origins = [value for name, value in scope.get("headers", []) if name == b"origin"]
            try:
                texts = [value.decode("utf-8") for value in origins]
            except UnicodeDecodeError:
                await refuse(send, 400, "Origin header is not UTF-8 text: not an origin")
                return
            if len(texts) > 1 or (texts and not self.access.allows_origin(texts[0])):
                shown = ", ".join(texts)
                await refuse(send, 403, f"cross-origin request from {shown!r} refused")
                return
            if self.access.token is not None:
                client = _client(scope)
                scheme, _, given = headers.get(b"authorization", b"").partition(b" ")
                given = given.strip() if scheme.lower() == b"bearer" else b""
                key = self.access.failure_key(client, given)
                wait = self.failures.wait(key)
                if wait > 0:
                    await refuse(
                        send,
                        429,
                        f"too many wrong tokens like this one from {client}; retry in "
                        f"{math.ceil(wait)} s",
                        ((b"retry-after", str(math.ceil(wait)).encode()),),
                    )
                    return
                if not given or not self.access.token_matches(given):  # constant time
                    self.failures.acquire(key)
                    await refuse(
                        send,
                        401,
                        "missing or wrong token: send Authorization: Bearer <token>",
                        ((b"www-authenticate", b"Bearer"),),
                    )
                    return
        scope[GRANTED] = True
        await self.app(scope, receive, send)

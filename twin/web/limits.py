"""Limits on what a client may send: request size (413), submission rate (429), (through
`RateLimit`, used by `twin.web.access`) failed token attempts, and the price of a request.

A script in a loop, or a hostile client, must not fill the memory with one huge body nor the
run queue and the disk with thousands of runs: bodies are capped before they are parsed, and
each client address gets a token bucket of submissions.

Every run and sweep is priced before it starts (`price_run`, `price_sweep`: steps, cells,
heatmap panels, bytes it will store) and refused with a 422 that names the limit when it is
over one (issue 30: one sweep of 5,000 headings built 5,000 matplotlib panels for over an
hour).
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Awaitable, Callable, Mapping, MutableMapping
from dataclasses import dataclass
from typing import Any

#: [bytes] largest request body: a scenario is < 2 KiB, a sweep spec with long axes < 16 KiB
MAX_BODY = 64 * 1024
#: [bytes] a run's stored series per step, before compression: 73.6 MB for a 200,000-step run
#: of the hybrid system (issue 30), the largest kind; a price's upper bound
SERIES_BYTES_PER_STEP = 368
#: [bytes] a sweep's stored table per cell and heatmap per panel (upper bounds, measured on
#: 7-axis tables and 120 dpi panels)
SWEEP_BYTES_PER_CELL = 400
HEATMAP_BYTES_PER_PANEL = 40_000

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]


async def refuse(
    send: Send, status: int, message: str, headers: tuple[tuple[bytes, bytes], ...] = ()
) -> None:
    """Answer a request from a middleware: JSON `{detail, message}` like the app's errors."""
    body = json.dumps({"detail": message, "message": message}).encode()
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
                (b"connection", b"close"),
                *headers,
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})


class BodyLimit:
    """ASGI middleware: a body over its route's cap is a 413 before the app reads any of it.

    The declared Content-Length is checked first; a chunked body (no length) is counted as it
    arrives and cut off at the cap, so a client cannot stream an endless body either.

    Args:
        app: the ASGI app.
        max_bytes: largest body accepted, on every route not in `route_limits`.
        route_limits: {(method, path): bytes} for the routes that take more (a site record's
            upload); exact paths, so no other route inherits the larger cap.
    """

    def __init__(
        self,
        app: ASGIApp,
        max_bytes: int = MAX_BODY,
        route_limits: Mapping[tuple[str, str], int] | None = None,
    ) -> None:
        self.app = app
        self.max_bytes = max_bytes
        self.route_limits = dict(route_limits or {})

    @staticmethod
    def _refusal(cap: int, method: str, path: str) -> str:
        return f"request body too large: at most {cap} bytes allowed for {method} {path}"

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        method, path = scope.get("method", ""), scope.get("path", "")
        cap = self.route_limits.get((method, path), self.max_bytes)
        declared = dict(scope.get("headers", [])).get(b"content-length")
        if declared is not None:
            try:
                length = int(declared)
            except ValueError:
                await refuse(send, 400, f"bad Content-Length {declared!r}: not an integer")
                return
            if length > cap:
                await refuse(send, 413, self._refusal(cap, method, path))
                return

        received = 0
        exceeded = False

        async def counted() -> Message:
            # Past the cap the body ends here; whatever the app answers to the cut body is
            # replaced by the 413 (apps turn exceptions raised while reading into a 400).
            nonlocal received, exceeded
            if exceeded:
                return {"type": "http.request", "body": b"", "more_body": False}
            message = await receive()
            received += len(message.get("body", b""))
            if received > cap:
                exceeded = True
                return {"type": "http.request", "body": b"", "more_body": False}
            return message

        async def checked(message: Message) -> None:
            if not exceeded:
                await send(message)
            elif message["type"] == "http.response.start":
                await refuse(send, 413, self._refusal(cap, method, path))

        await self.app(scope, counted, checked)

class RateLimit:
    """A token bucket per client: `burst` submissions at once, then `rate` per second.

    Thread-safe. Buckets that have refilled are dropped, so memory stays bounded by the
    clients active within the last `burst / rate` seconds.

    Args:
        rate: [1/s] sustained submissions per client.
        burst: submissions a client may make at once.
    """

    def __init__(self, rate: float, burst: int) -> None:
        if not (math.isfinite(rate) and rate > 0 and burst >= 1):
            raise ValueError(f"rate limit: need rate > 0 and burst ≥ 1, got {rate}, {burst}")
        self.rate = rate
        self.burst = burst
        self._buckets: dict[str, tuple[float, float]] = {}  # key → (tokens, time)
        self._lock = threading.Lock()

    def acquire(self, key: str, now: float | None = None) -> float:
        """Take one submission for `key`; 0 if allowed, else [s] until one is available."""
        now = time.monotonic() if now is None else now
        with self._lock:
            tokens, then = self._buckets.get(key, (float(self.burst), now))
            tokens = min(float(self.burst), tokens + (now - then) * self.rate)
            if tokens < 1.0:
                self._buckets[key] = (tokens, now)
                return (1.0 - tokens) / self.rate
            self._buckets[key] = (tokens - 1.0, now)
            if len(self._buckets) > 1024:
                self._prune(now)
            return 0.0

    def wait(self, key: str, now: float | None = None) -> float:
        """[s] until `key` may take one (0 if it may now), taking nothing."""
        now = time.monotonic() if now is None else now
        with self._lock:
            tokens, then = self._buckets.get(key, (float(self.burst), now))
        tokens = min(float(self.burst), tokens + (now - then) * self.rate)
        return 0.0 if tokens >= 1.0 else (1.0 - tokens) / self.rate

    def _prune(self, now: float) -> None:
        full = [
            k
            for k, (tokens, then) in self._buckets.items()
            if tokens + (now - then) * self.rate >= self.burst
        ]
        for k in full:
            del self._buckets[k]


@dataclass(frozen=True)
class Price:
    """What a request will cost, known before it starts.

    Attributes:
        steps: planner steps in all (runs × duration / dt).
        cells: grid cells (1 for a run).
        panels: heatmap panels (0 for a run).
        bytes: [bytes] an upper bound of what it stores.
    """

    steps: int
    cells: int
    panels: int
    bytes: int


def price_run(scenario: Any) -> Price:
    """The price of one run of `scenario` (a `Scenario`)."""
    steps = round(scenario.duration / scenario.dt)
    return Price(steps, 1, 0, steps * SERIES_BYTES_PER_STEP)


def price_sweep(spec: Any) -> Price:
    """The price of a sweep (`SweepSpec`): its steps, cells, panels and stored bytes."""
    from twin.runs.sweep import AXES, panel_count

    cells = math.prod(len(getattr(spec, axis)) for axis in AXES)
    panels = panel_count(spec)
    steps = cells * spec.seeds * round(spec.duration / spec.dt)
    return Price(
        steps, cells, panels, cells * SWEEP_BYTES_PER_CELL + panels * HEATMAP_BYTES_PER_PANEL
    )


def sweep_over_limits(spec: Any) -> list[dict[str, Any]]:
    """The limits a sweep is over, as 422 errors naming each (empty: it may run). The grid's
    own caps (cells, runs, steps) are `SweepSpec`'s; this adds the heatmap's panels."""
    from twin.runs.sweep import MAX_PANELS, PANEL_AXES

    price = price_sweep(spec)
    if price.panels <= MAX_PANELS:
        return []
    shape = " × ".join(f"{axis} {len(getattr(spec, axis))}" for axis in PANEL_AXES)
    widest = max(PANEL_AXES, key=lambda axis: len(getattr(spec, axis)))
    return [{
        "loc": ("body", widest),
        "msg": f"heatmap of {price.panels} panels ({shape}); allowed at most {MAX_PANELS} "
        f"(MAX_PANELS): give fewer {widest} values, or split it into several sweeps",
        "type": "limit_exceeded",
    }]  # fmt: skip

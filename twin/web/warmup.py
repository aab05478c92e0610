"""A server that talks while it warms: start-up progress, and a page on the viewer's port.

`twin serve` answers REST at once. Until the compiled kernels are loaded (minutes on a first
start, when numba compiles them; a second or so from its disk cache), the executor is up and
the live session runs, `/api/health` says `warming` with the progress kept here, the live
routes answer 503 with Retry-After, runs are stored queued (202) and run once ready, and the
viewer's port shows `WarmingPage`, which reloads itself until the 3D viewer takes the port.
"""

from __future__ import annotations

import html
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any, Literal, TextIO

from twin.errors import TwinError
from twin.sim.engine import WARM_TOTAL

Status = Literal["warming", "ok", "failed"]
#: ports tried from the asked one, as viser does
PORT_TRIES = 20


class Warmup:
    """Thread-safe progress of a server's start-up, printed as it goes.

    Args:
        out: where progress lines go (the terminal).
    """

    def __init__(self, out: TextIO | None = None) -> None:
        self._out = out if out is not None else sys.stdout
        self._lock = threading.Lock()
        self._began = time.monotonic()
        self.status: Status = "warming"
        self.stage = "compiling kernels"
        self.kernels_done = 0
        self.kernels_total = WARM_TOTAL
        self.last_kernel: str | None = None
        self.error: str | None = None
        self.cancelled = threading.Event()

    @property
    def elapsed(self) -> float:
        """[s] since start-up began."""
        return time.monotonic() - self._began

    def say(self, line: str) -> None:
        print(f"twin: {line}", file=self._out, flush=True)

    def kernel_done(self, label: str) -> None:
        """A lane set of `twin.sim.engine.WARM_SHARES` is compiled (or loaded)."""
        with self._lock:
            self.kernels_done = min(self.kernels_done + 1, self.kernels_total)
            self.last_kernel = label
            done = self.kernels_done
        self.say(f"kernels {done} of {self.kernels_total} ready ({label}), {self.elapsed:.1f} s")

    def begin(self, stage: str) -> None:
        with self._lock:
            self.stage = stage
        self.say(f"{stage} …")

    def ready(self) -> None:
        with self._lock:
            self.status, self.stage = "ok", "ready"
            self.kernels_done = self.kernels_total
        self.say(f"ready in {self.elapsed:.1f} s")

    def fail(self, error: str) -> None:
        with self._lock:
            self.status, self.stage, self.error = "failed", "failed", error
        self.say(f"start-up failed: {error}")

    def snapshot(self) -> dict[str, Any]:
        """What /api/health reports under `warming`."""
        with self._lock:
            return {
                "stage": self.stage,
                "kernels_done": self.kernels_done,
                "kernels_total": self.kernels_total,
                "last_kernel": self.last_kernel,
                "elapsed_s": round(self.elapsed, 1),
                "error": self.error,
            }

    def message(self) -> str:
        """One line for a 503's detail and the warming page."""
        s = self.snapshot()
        if self.status == "failed":
            return f"the twin failed to start: {s['error']}"
        return (
            f"the twin is warming up: {s['stage']} (kernels {s['kernels_done']} of "
            f"{s['kernels_total']}, {s['elapsed_s']:.0f} s so far; a first start compiles them, "
            "later starts load them in seconds); retry shortly"
        )


class WarmingPage:
    """A page on the viewer's port while the kernels compile: the progress, reloading itself
    every 2 s, so a browser opened at once lands in the 3D viewer when it is up.

    Args:
        warmup: whose progress to show.
        host, port: where the viewer will listen: this port or, if taken, the next free one.

    Raises:
        TwinError: no port free in `PORT_TRIES` from `port`.
    """

    def __init__(self, warmup: Warmup, host: str, port: int) -> None:
        progress = warmup

        class Handler(BaseHTTPRequestHandler):
            server_version = "twin"

            def do_GET(self) -> None:
                body = (
                    "<!doctype html><meta charset=utf-8><meta http-equiv=refresh content=2>"
                    "<title>wave-twin: warming up</title><body style='font-family:sans-serif;"
                    "margin:3em'><h1>wave-twin is warming up</h1><p>"
                    f"{html.escape(progress.message())}</p><p>This page reloads itself and "
                    "becomes the 3D viewer when it is ready.</p>"
                ).encode()
                self.send_response(503)
                self.send_header("Content-Type", "text/html; charset=utf-8")
                self.send_header("Retry-After", "2")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, format: str, *args: Any) -> None:  # quiet
                return

        self._server: ThreadingHTTPServer | None = None
        for candidate in range(port, port + PORT_TRIES):  # as viser moves on from a taken port
            try:
                self._server = ThreadingHTTPServer((host, candidate), Handler)
            except OSError:
                continue
            break
        if self._server is None:
            raise TwinError(
                f"no free port for the 3D viewer in {port}-{port + PORT_TRIES - 1} on {host}; "
                "choose another with --viser-port"
            )
        #: the port the viewer takes once the page closes (its origin is trusted from now on)
        self.port: int = self._server.server_address[1]
        self._server.daemon_threads = True
        threading.Thread(
            target=self._server.serve_forever, name="twin-warming-page", daemon=True
        ).start()

    def close(self) -> None:
        """Free the port for the viewer."""
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
            self._server = None

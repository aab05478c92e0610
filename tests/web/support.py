"""Helpers shared by the web tests: a free loopback port, polling for a condition, the access
policy of an app under test (its host as the test client names it), and runs held, watched or
refused on the server's own thread (`twin.web.jobs.run_scenario` patched)."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable
from typing import Any

import pytest

import twin.web.jobs
from tests.timing import scaled
from twin.web.access import Access

#: a token long enough for the server (≥ 16 characters)
TOKEN = "s3cret-token-0123"
#: the Host the test clients send (Starlette's TestClient, schemathesis's ASGI transport)
TEST_HOST = "testserver"
#: the same origin, as a page of the app would send it
SAME_ORIGIN = f"http://{TEST_HOST}"


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(condition: Callable[[], bool], timeout: float = 3.0, poll: float = 0.01) -> bool:
    """Poll `condition` until it holds or `timeout` [s] (an idle machine's, stretched by the
    load now: tests/timing.py) passes; its last value."""
    end = time.monotonic() + scaled(timeout)
    while not condition() and time.monotonic() < end:
        time.sleep(poll)
    return condition()


def access(token: str | None = None, **limits: Any) -> Access:
    """The policy of an app served as http://testserver (port 80), as `twin serve` builds it
    for a server bound to loopback with `--allow-host testserver`."""
    return Access.for_server(
        "127.0.0.1", (80,), token=token, allow_hosts=(TEST_HOST,), **limits
    )


class HeldRuns:
    """The server's own runs (`twin.web.jobs.run_scenario`) held until `release` is set: each
    one, or only the first with `first_only`; `entered` is set when one is held."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch, first_only: bool = False) -> None:
        self.entered, self.release = threading.Event(), threading.Event()
        real = twin.web.jobs.run_scenario

        def held(*args: Any, **kwargs: Any) -> Any:
            if not (first_only and self.entered.is_set()):
                self.entered.set()
                self.release.wait(60)
            return real(*args, **kwargs)

        monkeypatch.setattr(twin.web.jobs, "run_scenario", held)


def record_run_threads(monkeypatch: pytest.MonkeyPatch) -> list[threading.Thread]:
    """The threads that run the server's own runs, appended as each starts."""
    threads: list[threading.Thread] = []
    real = twin.web.jobs.run_scenario

    def recorded(*args: Any, **kwargs: Any) -> Any:
        threads.append(threading.current_thread())
        return real(*args, **kwargs)

    monkeypatch.setattr(twin.web.jobs, "run_scenario", recorded)
    return threads


def refuse_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    """The server's own runs refused as the engine refuses a scenario (a `TwinError`)."""
    from twin.errors import TwinError

    def refusing(*args: Any, **kwargs: Any) -> Any:
        raise TwinError("heading: refused by the engine (test)")

    monkeypatch.setattr(twin.web.jobs, "run_scenario", refusing)

"""The stop deadline is armed when SIGTERM arrives, not when Python gets round to its handler
(issue 43, finding 1): a process whose main thread is stuck in one long C call, so that its
Python SIGTERM handler can never run, is still ended; a prompt graceful stop is left alone."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.serial

#: a server stand-in: a watchdog with the deadline argv[2], a Python SIGTERM handler that stops
#: gracefully (exit 3), then either a C call that never checks for signals or an idle wait
CHILD = """
import signal, sys, time
from twin.web.stop_watchdog import StopWatchdog
watchdog = StopWatchdog(float(sys.argv[2]))
def stop(sig, frame):
    sys.exit(3)
signal.signal(signal.SIGTERM, stop)
watchdog.arm()
print(watchdog.process.pid, flush=True)
if sys.argv[1] == "stuck":
    sum(range(10**13))  # hours in C with the GIL held: the Python handler never runs
elif sys.argv[1] == "close":
    watchdog.close()
    time.sleep(60)
else:
    time.sleep(60)
"""


def start(mode: str, deadline: float) -> tuple[subprocess.Popen[str], int]:
    """The stand-in in `mode` with a `deadline` [s], and its watchdog's pid once both are up."""
    child = subprocess.Popen([sys.executable, "-c", CHILD, mode, str(deadline)],
                             stdout=subprocess.PIPE, text=True)  # fmt: skip
    assert child.stdout is not None
    return child, int(child.stdout.readline())


def alive(pid: int) -> bool:
    """Whether `pid` is a live process (a zombie counts as gone)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def wait_gone(pid: int, limit: float = 60.0) -> bool:
    """Poll until `pid` is gone, at most `limit` seconds."""
    end = time.monotonic() + limit
    while alive(pid) and time.monotonic() < end:
        time.sleep(0.05)
    return not alive(pid)


def test_a_process_stuck_in_c_is_killed_after_sigterm_though_its_handler_never_runs() -> None:
    """SIGTERM to a main thread stuck in one C call (its Python handler cannot run): the
    watchdog SIGKILLs it (without the watchdog it would run for hours)."""
    child, watchdog = start("stuck", 1.0)
    time.sleep(0.5)  # into the C call
    child.send_signal(signal.SIGTERM)
    try:
        code = child.wait(timeout=60)
    finally:
        child.kill()
    assert code == -signal.SIGKILL
    assert wait_gone(watchdog)


def test_a_prompt_graceful_stop_is_left_alone_and_the_watchdog_follows_it() -> None:
    """SIGTERM to an idle stand-in: its own handler's exit code (3), not a kill; the watchdog
    ends with it (a deadline longer than any loaded machine's exit)."""
    child, watchdog = start("idle", 50.0)
    child.send_signal(signal.SIGTERM)
    assert child.wait(timeout=60) == 3
    assert wait_gone(watchdog)


def test_closing_an_unarmed_watchdog_ends_it_while_its_server_lives_on() -> None:
    """`close()` without SIGTERM ends the watchdog at once, while its server lives on."""
    child, watchdog = start("close", 1.0)
    try:
        assert wait_gone(watchdog)
        assert child.poll() is None
    finally:
        os.kill(child.pid, signal.SIGKILL)
        child.wait(timeout=60)

"""The motion UDP listener on loopback, fed by the real sender (`twin.motion.replay.send`)."""

from __future__ import annotations

import socket
import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest

from twin.errors import TwinError
from twin.motion.replay import send, sentences
from twin.motion.series import MotionSeries
from twin.sim.motion_live import LiveMotion
from twin.web.motion_udp import MotionListener, allowed_senders, listening

pytestmark = pytest.mark.serial  # holds a socket and a thread

RATE = 50.0  # [Hz]


def _series(seconds: float) -> MotionSeries:
    """A heave-roll-pitch log at RATE of `seconds`."""
    t = np.arange(0.0, seconds, 1.0 / RATE)
    m = np.zeros((t.size, 6))
    m[:, 2], m[:, 3], m[:, 4] = 0.5 * np.sin(t), 0.02 * np.sin(0.7 * t), 0.01 * np.cos(t)
    return MotionSeries(t, m, ("heave", "roll", "pitch"))


def _until(check: Callable[[], bool], limit: float = 20.0) -> bool:
    """Poll `check` until it holds or `limit` [s] passed (a bound, not the expected time)."""
    end = time.monotonic() + limit
    while not check():
        if time.monotonic() > end:
            return False
        time.sleep(0.02)
    return True


@pytest.fixture
def listener() -> Iterator[MotionListener]:
    """A listener on a free loopback port, loopback senders only."""
    live = LiveMotion("udp test")
    lst = MotionListener(live, 0)
    lst.start()
    yield lst
    lst.stop()


def test_no_sentence_dropped_at_50_hz(listener: MotionListener) -> None:
    """Every sentence the real sender sends at 50 Hz for 3 s becomes one stored sample."""
    sent = send(_series(3.0), "127.0.0.1", listener.address[1], "psxn", RATE)
    assert _until(lambda: listener.live.counts["samples"] >= sent)
    assert listener.live.counts["samples"] == sent == 150
    assert listener.live.counts["datagrams"] == sent
    assert listener.live.latest(time.monotonic()) is not None


def test_disallowed_sender_is_ignored(listener: MotionListener) -> None:
    """A datagram from 127.0.0.2 (not an allowed sender) is counted and never parsed."""
    line = next(sentences(_series(1.0)))[1] + "\r\n"
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as other:
        other.bind(("127.0.0.2", 0))
        other.sendto(line.encode(), listener.address)
    assert _until(lambda: listener.live.counts["refused sender"] == 1)
    assert listener.live.counts["samples"] == 0
    assert listener.live.latest(time.monotonic()) is None


def test_malformed_datagrams_are_counted(listener: MotionListener) -> None:
    """Garbage, a bad checksum and non-ASCII bytes are each counted; the good line is kept."""
    good = next(sentences(_series(1.0)))[1]
    bad_sum = good[:-2] + ("00" if good[-2:] != "00" else "11")
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        for data in (b"garbage\r\n", (bad_sum + "\r\n").encode(), b"\xff\xfe\r\n",
                     (good + "\r\n").encode()):  # fmt: skip
            s.sendto(data, listener.address)
    assert _until(lambda: listener.live.counts["datagrams"] == 4)
    counts = dict(listener.live.counts)
    skipped = sum(n for r, n in counts.items() if r not in ("datagrams", "samples"))
    assert (skipped, counts["samples"]) == (3, 1)


def test_allow_list_takes_addresses_only() -> None:
    """--motion-udp-allow takes IP addresses (normalised); a host name is a TwinError."""
    assert allowed_senders(["192.168.001.20".replace("001", "1")]) >= {"192.168.1.20", "::1"}
    with pytest.raises(TwinError, match="not an IP address"):
        allowed_senders(["mru.local"])


def test_listening_starts_and_refuses_a_taken_port() -> None:
    """`twin serve --motion-udp`'s listener runs for the block; a taken port is a TwinError."""
    with listening(None) as none:
        assert none is None
    with listening(0) as lst:
        assert lst is not None and lst.is_alive()
        with pytest.raises(TwinError, match="cannot bind"), listening(lst.address[1]):
            pass
    assert not lst.is_alive()

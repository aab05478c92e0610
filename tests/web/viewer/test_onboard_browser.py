"""The viewer's Onboard panel in a real headless browser (Debian's Chromium, Playwright): a
`twin serve --motion-udp` on loopback follows a log that the real sender
(`twin.motion.replay.send`) plays to it; the panel shows the stream live with its sample count
and the estimator's refusal of the short window, the hull in the 3D scene moves, and once the
sender stops the panel says the stream is stale and holds the last sample sent."""

from __future__ import annotations

import json
import math
import os
import signal
import socket
import subprocess
import sys
import threading
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from playwright.sync_api import sync_playwright

from tests.timing import scaled
from tests.web.support import free_port, wait_for
from tests.web.viewer.test_browser import ARGS, CHROMIUM, HALF_RESOLUTION
from twin.motion.nmea import parse_line
from twin.motion.replay import send, sentences
from twin.motion.series import MotionSeries

pytestmark = pytest.mark.skipif(not CHROMIUM.exists(), reason="no /usr/bin/chromium")

RATE = 50.0  # [Hz] the sender's rate, the fastest an MRU sends
SECONDS = 8.0  # [s] of motion sent
#: the mechanism base's pose in the page, as viser last placed its node: position and wxyz
BASE_POSE = """() => {
  const pose = window.__viserMutable.nodePoseData["/base"];
  return pose ? [...pose.position, ...pose.wxyz] : null;
}"""


def log() -> MotionSeries:
    """SECONDS of a heaving, rolling hull at RATE (heave 0.5 m, roll 3°, pitch 1.5°)."""
    t = np.arange(0.0, SECONDS, 1.0 / RATE)
    m = np.zeros((t.size, 6))
    m[:, 2] = 0.5 * np.sin(1.3 * t)
    m[:, 3], m[:, 4] = np.radians(3.0) * np.sin(0.9 * t), np.radians(1.5) * np.cos(1.1 * t)
    return MotionSeries(t, m, ("heave", "roll", "pitch"))


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def get(port: int, path: str) -> Any:
    with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=10) as r:
        return json.load(r)


def patch(port: int, body: dict[str, Any]) -> Any:
    request = urllib.request.Request(
        f"http://127.0.0.1:{port}/api/live", data=json.dumps(body).encode(), method="PATCH",
        headers={"Content-Type": "application/json"},
    )  # fmt: skip
    with urllib.request.urlopen(request, timeout=30) as r:
        return json.load(r)


@pytest.fixture
def server(tmp_path: Path) -> Iterator[tuple[int, int, int]]:
    """`twin serve --motion-udp` (viewer in light graphics, executor in process) once healthy:
    (REST port, viewer port, motion UDP port)."""
    rest, viewer, udp = free_port(), free_port(), free_udp_port()
    process = subprocess.Popen(
        [sys.executable, "-m", "twin.cli", "serve", "--port", str(rest), "--viser-port",
         str(viewer), "--scheduler", "in-process", "--graphics", "light", "--motion-udp",
         str(udp)],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ},
    )  # fmt: skip

    def healthy() -> bool:
        try:
            return get(rest, "/api/health")["status"] == "ok"
        except OSError:
            return process.poll() is not None  # ended: stop waiting, the assert says so

    try:
        assert wait_for(healthy, timeout=scaled(90), poll=0.2) and process.poll() is None
        yield rest, viewer, udp
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.communicate(timeout=scaled(20))
        except subprocess.TimeoutExpired:
            process.kill()
            process.communicate()


def shown(sample: tuple[float, float, float]) -> str:
    """How the panel writes a sample (heave [m], roll, pitch [rad])."""
    heave, roll, pitch = sample
    return (f"heave {heave:+.3f} m · roll {math.degrees(roll):+.2f}° "
            f"· pitch {math.degrees(pitch):+.2f}°")  # fmt: skip


def test_the_onboard_panel_follows_a_stream_sent_to_the_server(
    server: tuple[int, int, int],
) -> None:
    """The panel shows the stream live (samples counted), the estimator's refusal of a window
    under 10 min, and the hull moving; after the sender stops, "stale" and the last sample
    sent, every sentence received."""
    rest, viewer, udp = server
    assert patch(rest, {"motion_source": {"kind": "udp"}})["motion_source"]["status"] == "waiting"
    series = log()
    lines = [line for _, line in sentences(series, "psxn", RATE)]
    last = parse_line(lines[-1]).motion  # type: ignore[union-attr]
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        try:
            page = browser.new_page(viewport={"width": 1200, "height": 760})
            page.goto(f"http://127.0.0.1:{viewer}{HALF_RESOLUTION}", timeout=60_000)
            page.get_by_text("Onboard", exact=True).first.wait_for(timeout=60_000)
            assert wait_for(lambda: page.evaluate(BASE_POSE) is not None, timeout=30.0, poll=0.2)
            before = page.evaluate(BASE_POSE)  # at rest: nothing received yet
            sender = threading.Thread(target=send, args=(series, "127.0.0.1", udp, "psxn", RATE))
            sender.start()
            page.get_by_text("stream live", exact=False).first.wait_for(timeout=30_000)
            page.get_by_text("at least 600 s", exact=False).first.wait_for(timeout=30_000)
            moved = lambda: not np.allclose(page.evaluate(BASE_POSE), before, atol=1e-3)  # noqa: E731
            assert wait_for(moved, timeout=30.0, poll=0.2)
            sender.join()
            page.get_by_text("stream stale", exact=False).first.wait_for(timeout=30_000)
            page.get_by_text(f"samples {len(lines)} ", exact=False).first.wait_for(timeout=10_000)
            page.get_by_text(shown(last), exact=False).first.wait_for(timeout=10_000)
        finally:
            browser.close()
    state = get(rest, "/api/live")["motion_source"]
    assert state["status"] == "stale" and state["input"]["counts"]["samples"] == len(lines)

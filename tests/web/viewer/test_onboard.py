"""The Onboard folder's text (`twin.web.viewer.onboard.onboard_text`): the source line with the
newest sample, a stale stream said to hold, the estimator's refusal, the estimate with its
uncertainty, operability and advice, and an alert line only under the threshold; its source
dropdown switches the live session under the viewer's lock."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.web.support import TOKEN, free_port, wait_for
from tests.web.viewer.support import connect
from twin.motion.series import MotionSeries
from twin.sim.live import LiveSession
from twin.sim.measured import LOG_DIR_ENV, store_log
from twin.sim.motion_live import LiveMotion
from twin.web.access import Access
from twin.web.viewer import start_viewer
from twin.web.viewer.onboard import onboard_text

STREAM = {"kind": "udp", "status": "live", "log": None, "speed": None,
          "input": {"counts": {"samples": 1200, "refused sender": 3},
                    "latest": {"t": 24.0, "heave": 0.512, "roll": math.radians(1.25),
                               "pitch": math.radians(-0.5)}}}  # fmt: skip
BASE: dict[str, Any] = {"kind": "udp", "window_s": 24.0, "needed_s": 600.0, "estimate": None,
                        "refused": "window: 24 s; at least 600 s (10 min) is needed",
                        "operability": {}, "advice": {}, "tip_error_max": 0.0042,
                        "leg_margin": 0.21, "span_s": 24.0}  # fmt: skip
ESTIMATED = {**BASE, "refused": None, "operability": {"qp": 0.62},
             "estimate": {"hs": 2.04, "hs_sd": 0.11, "tp": 8.3, "tp_sd": 0.4, "direction": 151.0,
                          "direction_sd": 9.0, "ambiguous": True},
             "advice": {"qp": [{"heading": 180.0, "probability": 0.9, "turn": -29.0},
                               {"heading": 150.0, "probability": 0.62, "turn": 1.0}]}}  # fmt: skip


def test_a_short_window_shows_the_stream_and_the_refusal() -> None:
    """The stream's status, counts and newest sample; the refusal with the window held; the
    tip error and leg margin in mm; no alert without an operability."""
    text = onboard_text(BASE, STREAM, 0.5)
    assert "stream live · samples 1200 · refused senders 3" in text
    assert "heave +0.512 m · roll +1.25° · pitch -0.50°" in text
    assert "refused (24 s of 600 s): window: 24 s; at least 600 s" in text
    assert "tip error max 4 mm · leg margin min 210 mm" in text and "ALERT" not in text


def test_a_stale_stream_says_it_holds() -> None:
    """A stale stream: "stream stale (holding the last pose)", its last sample still shown."""
    text = onboard_text(BASE, {**STREAM, "status": "stale"}, 0.5)
    assert "stream stale (holding the last pose)" in text and "heave +0.512 m" in text


def test_the_estimate_advice_and_an_alert_under_the_threshold() -> None:
    """Hs, Tp, direction ± their σ (ambiguity said), operability, the best headings with
    their turns; ALERT under 0.8, none under 0.5."""
    text = onboard_text(ESTIMATED, STREAM, 0.8)
    assert "Hs 2.04 ± 0.11 m · Tp 8.3 ± 0.4 s · direction 151 ± 9° (port/starboard" in text
    assert "**Operability now** qp 0.62" in text
    assert "qp: 180° (0.90, turn -29°) · 150° (0.62, turn +1°)" in text
    assert "**ALERT** operability under the threshold: qp 0.62 < 0.80" in text
    assert "ALERT" not in onboard_text(ESTIMATED, STREAM, 0.5)


def test_the_source_dropdown_switches_under_the_lock(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A locked browser's choice of the UDP stream is refused and undone; unlocked, it makes
    the session follow the stream; a log chosen through the session shows as an entry."""
    live = LiveMotion("test", stale_after=600.0)
    session = LiveSession({"sea_state": 3}, motion=live)
    session.pause()
    viewer = start_viewer(session, access=Access(token=TOKEN), port=free_port())
    try:
        client, _panel = connect(viewer)
        with client:
            dropdown = client.wait_widget("Motion source")
            client.update(dropdown, value="UDP stream")
            assert wait_for(lambda: any("locked" in n for n in client.notifications()))
            assert session.motion_state()["kind"] == "sea"
            assert wait_for(lambda: viewer.gui.onboard.source.value == "synthesised sea")
            (client_id,) = viewer.gui.panels
            viewer.gui._unlocked.add(client_id)  # as a browser that entered the token
            client.update(dropdown, value="UDP stream")
            assert wait_for(lambda: session.motion_state()["kind"] == "udp")
            monkeypatch.setenv(LOG_DIR_ENV, str(tmp_path))
            t = np.arange(100) / 10
            key = store_log(MotionSeries(t, np.c_[0 * t, 0 * t, np.sin(t), 0 * t, 0 * t, 0 * t],
                                         ("heave",)))  # fmt: skip
            session.patch({"motion_source": {"kind": "log", "log": key, "speed": 2}})
            entry = f"log {key} at 2×"
            assert wait_for(lambda: viewer.gui.onboard.source.value == entry)
    finally:
        viewer.stop()
        session.stop()

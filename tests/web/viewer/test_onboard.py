"""The Onboard folder's text (`twin.web.viewer.onboard.onboard_text`): the source line with the
newest sample, a stale stream said to hold, the estimator's refusal, the estimate with its
uncertainty, operability and advice, and an alert line only under the threshold."""

from __future__ import annotations

import math
from typing import Any

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

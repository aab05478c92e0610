"""The live onboard report (`twin.runs.onboard_live`): the sea estimated from the followed
source's newest window, operability now and the heading advice from the cells, the session's
tip error and leg margin; the estimator's refusal while the window is short; alerts under a
threshold."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from twin.motion.series import MotionSeries
from twin.runs.onboard import OnboardSpec
from twin.runs.onboard_live import LiveOnboard, alerts
from twin.sea.synthesis import wave_components
from twin.sim.base_motion import mount_for
from twin.sim.live import LiveSession
from twin.sim.measured import LOG_DIR_ENV, store_log
from twin.sim.motion_live import LiveMotion
from twin.vessel import load_raos, vessel_motion

GRID = [0.0, 90.0, 180.0, 270.0]
#: the cheapest cells that still run the engine (tests/runs/test_onboard.py's)
CELLS = {"seeds": 1, "duration": 10.0, "hs_grid": [1.0, 2.0], "tp_grid": [8.0],
         "heading_grid": GRID}  # fmt: skip
SCENARIO = {"mechanism": "upr4", "planner": "pid", "sea_state": 1.0}


def test_a_short_stream_is_refused_with_the_estimators_reason() -> None:
    """Thirty seconds of a stream: the estimator's refusal (10 min needed), the window held,
    and the session's tip error and leg margin; the sea source has nothing to estimate."""
    live = LiveMotion("test", stale_after=600.0)
    session = LiveSession(SCENARIO, motion=live)
    onboard = LiveOnboard(session)
    assert "synthesised sea" in onboard.evaluate()["refused"]
    t = np.arange(1500) / 50
    live.push([(float(x), (0.5 * np.sin(x), 0.02, 0.01)) for x in t], time.monotonic())
    session.patch({"motion_source": {"kind": "udp"}})
    session.advance(0.0)
    result = onboard.evaluate()
    assert result["kind"] == "udp" and result["status"] == "live"
    assert result["window_s"] == pytest.approx(29.98)
    assert "at least 600 s" in result["refused"] and result["estimate"] is None
    assert result["leg_margin"] > 0 and np.isfinite(result["tip_error_max"])


def test_a_replayed_log_gives_the_sea_operability_and_advice(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ten minutes of a log of the mount's vessel in Hs 1.5 m, Tp 8 s at β 150°, replayed to
    its end: Hs within 15 %, direction within 20°, the planner's operability in [0, 1], the
    grid's headings ranked; an alert under a threshold above it, none under 0; a second
evaluation within the report period reuses the report."""
    monkeypatch.setenv(LOG_DIR_ENV, str(tmp_path / "logs"))
    t = np.arange(0.0, 600.5, 0.5)
    sea = wave_components(1.5, 8.0, heading=np.radians(150.0), seed=3, n_components=300)
    hull = vessel_motion(sea, load_raos(mount_for("upr4").vessel), t)
    key = store_log(MotionSeries(t, hull, ("surge", "sway", "heave", "roll", "pitch", "yaw")))
    session = LiveSession(SCENARIO)
    session.patch({"motion_source": {"kind": "log", "log": key, "speed": 8}})
    while session.controls.playing:
        session.step(1000)
        session.advance(0.0)  # pauses at the log's end
    onboard = LiveOnboard(session, tmp_path / "cells", OnboardSpec(workability=CELLS))
    result = onboard.evaluate()
    assert result["refused"] is None, result["refused"]
    assert result["estimate"]["hs"] == pytest.approx(1.5, rel=0.15)
    assert abs(result["estimate"]["direction"] - 150.0) < 20.0
    p = result["operability"]["pid"]
    assert 0.0 <= p <= 1.0
    assert sorted(a["heading"] for a in result["advice"]["pid"]) == GRID
    assert alerts(result, 1.01) == [f"pid {p:.2f} < 1.01"] and alerts(result, 0.0) == []
    monkeypatch.setattr("twin.runs.onboard_live.onboard_report", None)  # a call would fail
    again = onboard.evaluate()  # within REPORT_PERIOD: the same report, not computed again
    assert again["estimate"] == result["estimate"] and again["report_age_s"] > 0.0

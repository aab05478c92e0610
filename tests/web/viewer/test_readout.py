"""The readout: limit violations, faults and limit handling in words, and a restart said."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from tests.web.support import free_port, wait_for
from tests.web.viewer.support import caught_up, connect
from tests.web.viser_client import ViserClient
from twin.sim.live import LiveSession
from twin.web.access import Access
from twin.web.viewer import (
    ClientPanel,
    Viewer,
    fault_line,
    limit_line,
    limit_violations,
    si,
    start_viewer,
)
from twin.web.viewer.frame_state import FrameState, read_frame


def test_limit_readout_names_the_violation(session: LiveSession) -> None:
    """A leg beyond its stroke and a state outside its limits are reported by name."""
    fs = read_frame(session)
    assert fs is not None and limit_violations(fs) == []
    lengths = fs.leg_lengths.copy()
    lengths[2] = fs.leg_max[2] + 0.1
    record = {**fs.record, "xi": np.r_[fs.state[:8], 99.0]}
    bad = dataclasses.replace(fs, leg_lengths=lengths, record=record)
    text = "; ".join(limit_violations(bad))
    assert "leg 3" in text and "d3" in text


def test_nan_base_motion_never_reaches_the_scene_and_the_readout_flags_it(
    nan_sea: Callable[[float, float], None],
) -> None:
    """A NaN sea window: every node the scene moves stays finite, and the panel says so."""
    nan_sea(0.22, 0.58)
    session = LiveSession({"sea_state": 3})
    session.pause()
    viewer = start_viewer(session, access=Access(), port=free_port())
    client, _ = connect(viewer)  # the scene and the readout are drawn for a browser
    try:
        session.step(10)  # t = 0.5: inside the window
        assert wait_for(caught_up(viewer, session))
        scene = viewer.scene
        for node in (scene.vessel, scene.base, scene.top):
            assert np.all(np.isfinite(node.position)) and np.all(np.isfinite(node.wxyz))
        assert np.all(np.isfinite(scene.legs.points))
        assert wait_for(lambda: "⚠ Faults:** base motion" in viewer.gui.readout.content, 5.0)
    finally:
        client.close()
        viewer.stop()
        session.stop()


def test_readout_keeps_held_steps_limit_handling_and_violations_apart(
    session: LiveSession,
) -> None:
    """Steps shortened at a limit are not faults nor violations; a state held on its limit is
    within it (a tolerance of its range), one beyond it prints with the digits that show by how
    much; no quantity prints with an exponent."""
    faults = {"counts": {"base_motion": 0, "planner": 0, "kinematics": 0, "joint_limit": 107,
                         "singular": 3}, "held": 0, "events": [], "loop_errors": 0}  # fmt: skip
    assert fault_line(faults) == "**Faults:** none (no step held)"
    assert "stopped at a limit 107" in limit_line(faults, "hold")
    assert "damped near a singularity 3" in limit_line(faults, "hold")
    assert [si(2.5, "m"), si(0.0025, "m"), si(2.5e-6, "m"), si(1234.0, "m")] == [
        "2.50 m", "2.50 mm", "2.50 µm", "1.23 km"]  # fmt: skip

    session.patch({"mechanism": "upu3up", "planner": None})
    fs = read_frame(session)
    assert fs is not None
    high = fs.mechanism.state_limits[1][0]  # z [mm]
    on_limit = dataclasses.replace(fs, record={**fs.record, "state": np.r_[high, fs.state[1:]]})
    assert limit_violations(on_limit) == []
    beyond = dataclasses.replace(fs, record={**fs.record,
                                             "state": np.r_[high + 0.5, fs.state[1:]]})  # fmt: skip
    (line,) = limit_violations(beyond)
    assert line.startswith("z: ") and "mm >" in line and "e+" not in line
    assert f"{high + 0.5:.3f}" in line


def test_changing_the_compare_planner_says_live_time_restarted(
    viewer: Viewer, session: LiveSession, browser: tuple[ViserClient, ClientPanel]
) -> None:
    """A compare planner set (or dropped) restarts live time at 0; the readout says so."""
    session.step(20)
    assert wait_for(caught_up(viewer, session))
    assert "restarted" not in viewer.gui.readout.content
    session.patch({"compare_planner": "pi"})
    assert wait_for(lambda: "Live time restarted at t = 0" in viewer.gui.readout.content, 5.0)
    assert "compare planner is now pi" in viewer.gui.readout.content
    session.patch({"compare_planner": None})
    assert wait_for(lambda: "compare planner was removed" in viewer.gui.readout.content, 5.0)


def test_a_leg_at_its_limit_is_said_in_words_with_since_when(session: LiveSession) -> None:
    """A leg held on its stroke end reads "at the limit" (not nanometres) and "leg 3 at its
    stroke limit since" the time it got there, kept while it stays; off the limit, or after a
    restart (time going back), it reads nothing at a limit again; margins read in mm."""
    from twin.web.viewer.readout import AT_LIMIT, Readout, margin_text

    assert [margin_text(m) for m in (7.93e-7, -2e-8, 0.0995, -0.002)] == [
        "at the limit", "at the limit", "99.5 mm", "2.00 mm beyond the limit"]  # fmt: skip
    fs = read_frame(session)
    assert fs is not None
    readout = Readout()
    readout._since = {}
    assert readout._limits_since(fs) == "nothing"
    lengths = fs.leg_lengths.copy()
    lengths[2] = fs.leg_max[2] - 0.1 * AT_LIMIT

    def at(frame: FrameState, t: float, **changes: Any) -> FrameState:
        return dataclasses.replace(frame, record={**frame.record, "t": t}, **changes)

    held = [at(fs, t, leg_lengths=lengths) for t in (41.2, 50.0)]
    assert readout._limits_since(held[0]) == "⚠ leg 3 at its stroke limit since 41.2 s"
    assert readout._limits_since(held[1]) == "⚠ leg 3 at its stroke limit since 41.2 s"
    assert readout._limits_since(at(held[0], 3.0)).endswith("since 3.0 s")
    assert readout._limits_since(at(fs, 60.0)) == "nothing"

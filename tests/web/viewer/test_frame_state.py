"""One reading of the live session per render frame (`read_frame` → `FrameState`)."""

from __future__ import annotations

import dataclasses

import numpy as np

from twin.sim.live import LiveSession
from twin.spatial import pose_to_transform
from twin.web.viewer.frame_state import STATE_KEY, read_frame


def test_a_frame_is_the_sessions_newest_record(session: LiveSession) -> None:
    """The frame carries the session's version, scenario and newest record, the base pose of
    that record, the mechanism's own state and legs within their strokes; the landing offset
    is the landing point minus where it is held; no compare planner, no ghost."""
    session.step(20)
    fs = read_frame(session)
    assert fs is not None
    record = session.view()["record"]
    assert fs.version == session.version and fs.scenario == session.scenario
    assert fs.t == float(record["t"]) > 0.0
    np.testing.assert_array_equal(fs.transform_base, pose_to_transform(record["base_pose"]))
    np.testing.assert_array_equal(fs.state, record[STATE_KEY.get(fs.scenario.mechanism, "state")])
    assert fs.leg_lengths.shape == fs.leg_min.shape == fs.leg_max.shape
    assert np.all((fs.leg_margin > 0.0) & (fs.leg_margin <= 1.0))  # a calm start: within strokes
    np.testing.assert_allclose(fs.landing_offset, fs.landing - fs.held[:3, 3], atol=0.0)
    assert fs.ghost is None and fs.replay is None


def test_the_leg_margin_is_one_at_mid_stroke_and_zero_at_an_end(session: LiveSession) -> None:
    """The readout's leg margin is 1 at mid-stroke, 0 at either end and negative beyond it."""
    fs = read_frame(session)
    assert fs is not None
    mid = 0.5 * (fs.leg_min + fs.leg_max)
    span = fs.leg_max - fs.leg_min
    lengths = [mid, fs.leg_min, fs.leg_max, fs.leg_max + 0.25 * span]
    margins = [dataclasses.replace(fs, leg_lengths=v).leg_margin for v in lengths]
    np.testing.assert_allclose(margins, [[1.0] * len(mid), [0.0] * len(mid),
                                         [0.0] * len(mid), [-0.5] * len(mid)])  # fmt: skip


def test_a_compare_planner_is_read_as_a_ghost_of_the_same_frame(session: LiveSession) -> None:
    """The compare lane is read in the same reading: same version and time, its own planner."""
    session.patch({"compare_planner": "pi"})
    session.step(5)
    fs = read_frame(session)
    assert fs is not None and fs.ghost is not None
    assert fs.ghost.scenario.planner == "pi" != fs.scenario.planner
    assert (fs.ghost.version, fs.ghost.t) == (fs.version, fs.t)
    assert fs.ghost.scenario.model_copy(update={"planner": fs.scenario.planner}) == fs.scenario

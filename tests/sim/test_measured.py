"""Measured base motion (`twin.sim.measured`, `Scenario.base_motion`): a stored log of the
hull's motion at a sensor drives the one engine exactly as the RAO path would (base poses to
1e-9 on the run's grid), every planner runs on the same measured hour, and a missing log or a
run longer than the log is refused with what is allowed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from twin.errors import TwinError
from twin.motion.series import MotionSeries
from twin.sim import simulate, simulate_many
from twin.sim.base_motion import BaseMotion
from twin.sim.measured import LOG_DIR_ENV, MeasuredMotion, store_log
from twin.sim.scenario import Scenario
from twin.vessel import MOUNTS
from twin.vessel.motion import base_pose, superpose

SENSOR = (15.0, -4.0, 8.0)
SEA = {"mechanism": "hybrid", "hs": 2.0, "tp": 8.0, "heading": 150.0, "seed": 2, "dt": 0.05}


@pytest.fixture()
def logs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A log folder of the test's own (as the server sets it for its workers)."""
    monkeypatch.setenv(LOG_DIR_ENV, str(tmp_path))
    return tmp_path


def measured_hull(duration: float) -> MotionSeries:
    """What an MRU at SENSOR reports of the RAO path's hull motion in SEA: its point's
    displacement and the hull's angles, sampled at the run's dt."""
    motion = BaseMotion.of(Scenario(**SEA, duration=duration))
    t = np.arange(0.0, duration + 1e-9, SEA["dt"])
    hull = superpose(t, motion.omega_e, motion.amplitude)
    at_sensor = base_pose(hull, SENSOR)
    rows = np.c_[at_sensor[:, :3] - np.asarray(SENSOR), at_sensor[:, 3:]]
    return MotionSeries(t, rows, ("surge", "sway", "heave", "roll", "pitch", "yaw"))


def test_a_log_of_the_hulls_motion_drives_the_engine_as_the_sea_does(logs: Path) -> None:
    """The same 30 s, once from the sea and once from its log measured at a sensor 17 m from
    the centre of motion: base poses equal to 1e-9, tip errors to 1e-6 m."""
    key = store_log(measured_hull(30.0), SENSOR)
    assert (logs / f"{key}.npz").is_file() and store_log(measured_hull(30.0), SENSOR) == key
    sea = simulate({**SEA, "planner": "qp", "duration": 30.0})
    log = simulate({**SEA, "planner": "qp", "duration": 30.0,
                    "base_motion": {"source": "log", "log": key}})  # fmt: skip
    np.testing.assert_allclose(log.series["base_pose"], sea.series["base_pose"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(log.series["tip_error"], sea.series["tip_error"], rtol=0, atol=1e-6)


def test_every_planner_runs_on_the_same_measured_hour(logs: Path) -> None:
    """"Would each planner have held the gangway?": every hybrid planner on one stored log,
    from an offset into it, sees the same base poses and reports its own metrics."""
    key = store_log(measured_hull(40.0), SENSOR)
    planners = ["pi", "wpi", "mtmp", "dwa", "qp"]
    runs = simulate_many([{**SEA, "planner": p, "duration": 20.0,
                           "base_motion": {"source": "log", "log": key, "offset": 15.0}}
                          for p in planners])  # fmt: skip
    for run in runs[1:]:
        np.testing.assert_array_equal(run.series["base_pose"], runs[0].series["base_pose"])
    errors = {p: r.metrics["tip_position_error_max"] for p, r in zip(planners, runs, strict=True)}
    assert all(np.isfinite(list(errors.values()))) and len(set(errors.values())) > 1


def test_a_missing_log_or_a_run_past_its_end_is_refused(logs: Path) -> None:
    """An unknown ID, a run longer than the log (both lengths named), a log ID without source
    'log' and a malformed ID are refused."""
    key = store_log(measured_hull(10.0), SENSOR)
    with pytest.raises(TwinError, match="not stored"):
        simulate({**SEA, "duration": 5.0, "base_motion": {"source": "log", "log": "0" * 16}})
    with pytest.raises(TwinError, match="the log lasts 10 s"):
        simulate({**SEA, "duration": 8.0,
                  "base_motion": {"source": "log", "log": key, "offset": 5.0}})  # fmt: skip
    with pytest.raises(ValueError, match="goes with source 'log'"):
        Scenario(**SEA, base_motion={"source": "sea", "log": key})
    with pytest.raises(ValueError, match="base_motion"):
        Scenario(**SEA, base_motion={"source": "log", "log": "../../etc/passwd"})


def test_a_run_across_a_gap_in_the_log_is_refused_and_past_its_end_is_nan(logs: Path) -> None:
    """A window crossing a sensor dropout (no samples for 5 s in a 0.05 s log) is refused with
    the gap's times; a window beside it runs; poses past the log's end are NaN (the engine
    holds and counts them), not the last sample repeated."""
    full = measured_hull(30.0)
    keep = (full.time < 10.0) | (full.time > 15.0)
    key = store_log(MotionSeries(full.time[keep], full.motion[keep], full.channels), SENSOR)
    with pytest.raises(TwinError, match=r"across a gap without samples from 9\.95 to 15\.05 s"):
        MeasuredMotion(key, MOUNTS["hybrid"], offset=5.0, duration=10.0)
    motion = MeasuredMotion(key, MOUNTS["hybrid"], offset=15.5, duration=10.0)
    poses = motion.poses(np.array([0.0, 14.0, 14.6]))
    assert np.isfinite(poses[:2]).all() and np.isnan(poses[2]).all()

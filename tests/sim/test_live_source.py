"""The live session's motion source (issue 40): the hull follows a live stream through the one
engine (the stream's clock drives it, a stale stream holds the last pose, a gap re-anchors),
or a stored log replayed at 1-8×; a bad choice is refused and changes nothing; the followed
stream and the replayed log give the batch `base_motion` run's base poses."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from twin.errors import TwinError
from twin.motion.series import MotionSeries
from twin.sim import simulate
from twin.sim.live import LiveSession
from twin.sim.measured import LOG_DIR_ENV, store_log
from twin.sim.motion_live import LAG, LiveMotion
from twin.vessel import MOUNTS
from twin.web.motion_udp import MotionListener

SENSOR = (15.0, -4.0, 8.0)
SCENARIO = {"mechanism": "hybrid", "planner": "qp", "sea_state": 4.0, "joint_limits": "hold"}
RATE = 50.0


def hull(t: np.ndarray) -> np.ndarray:
    """(N, 3) heave [m], roll, pitch [rad] of a hull rolling in a swell."""
    return np.c_[0.8 * np.sin(0.7 * t), 0.04 * np.sin(0.5 * t + 1.0), 0.02 * np.cos(0.9 * t)]


def samples(t0: float, t1: float) -> list[tuple[float, tuple[float, float, float]]]:
    """The stream's samples with t0 ≤ t < t1 [s] at RATE."""
    t = np.arange(round(t0 * RATE), round(t1 * RATE)) / RATE
    return [(float(ti), (float(h), float(r), float(p))) for ti, (h, r, p) in zip(t, hull(t),
                                                                                  strict=True)]


@pytest.fixture()
def logs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A log folder of the test's own."""
    monkeypatch.setenv(LOG_DIR_ENV, str(tmp_path))
    return tmp_path


def stored(duration: float) -> str:
    """The stream's first `duration` s stored as a log measured at SENSOR; its ID."""
    t = np.arange(round(duration * RATE) + 1) / RATE
    motion = np.full((t.size, 6), np.nan)
    motion[:, 2:5] = hull(t)
    return store_log(MotionSeries(t, motion, ("heave", "roll", "pitch")), SENSOR)


def test_the_followed_stream_gives_the_batch_runs_base_poses(logs: Path) -> None:
    """A session following a stream that arrives in half-second bursts steps only as far as
    samples came, and its base poses equal a batch run of the same samples as a stored log,
    from the stream's offset, to 1e-9."""
    live = LiveMotion("test", sensor_position=SENSOR)
    session = LiveSession(SCENARIO, motion=live)
    live.push(samples(0.0, 1.0), time.monotonic())
    session.patch({"motion_source": {"kind": "udp"}})
    for k in range(2, 14):
        live.push(samples(k / 2 - 0.5, k / 2), time.monotonic())
        session.advance(0.0)
        stream = session._stream()
        assert session.scenario.dt * session._sim.k <= k / 2 - stream.offset + 1e-9
    assert stream.resyncs == 1 and stream.offset == pytest.approx(1.0 - 1 / RATE - LAG)
    steps = session._sim.k
    assert steps > 100
    key = stored(7.0)
    source = {"source": "log", "log": key, "offset": stream.offset}
    batch = simulate({**SCENARIO, "duration": steps * 0.05, "base_motion": source})
    live_poses = session.series()["base_pose"]
    np.testing.assert_allclose(live_poses, batch.series["base_pose"], rtol=0, atol=1e-9)


def test_a_stale_stream_holds_then_a_gap_is_skipped() -> None:
    """Silence past stale_after: no step, the status says stale, the pose stays finite and
    still; samples after the gap re-anchor the run (no straight line across the gap)."""
    live = LiveMotion("test", stale_after=0.05)
    session = LiveSession(SCENARIO, motion=live)
    session.patch({"motion_source": {"kind": "udp"}})
    assert session.motion_state()["status"] == "waiting" and session.advance(0.0) == 0
    live.push(samples(0.0, 2.0), time.monotonic())
    assert session.advance(0.0) == round(LAG / 0.05) and session._stream().resyncs == 1
    time.sleep(0.1)  # twice stale_after of silence: stale whatever the machine's speed
    k, pose = session._sim.k, session.latest()["base_pose"]
    assert session.advance(1.0) == 0 and session._sim.k == k
    assert session.motion_state()["status"] == "stale" and np.isfinite(pose).all()
    np.testing.assert_array_equal(session.latest()["base_pose"], pose)
    live.push(samples(10.0, 11.0), time.monotonic())
    assert session.advance(0.0) == round(LAG / 0.05)
    assert session.motion_state()["status"] == "live" and session._stream().resyncs == 2
    assert np.isfinite(session.series()["base_pose"]).all()


def test_a_refused_sender_never_moves_the_scene() -> None:
    """A datagram from an address outside the allowed ones is counted and never parsed: the
    followed run does not step."""
    live = LiveMotion("test")
    listener = MotionListener(live, 0)
    try:
        session = LiveSession(SCENARIO, motion=live)
        session.patch({"motion_source": {"kind": "udp"}})
        listener._take(b"$PASHR,120000.00,90.0,T,1.0,2.0,0.5,,,,,*00\r\n", "10.1.2.3")
        assert live.counts["refused sender"] == 1 and live.newest() is None
        assert session.advance(1.0) == 0 and session._sim.k == 0
    finally:
        listener.stop()


def test_a_replayed_log_is_the_batch_run_at_its_speed_and_pauses_at_its_end(logs: Path) -> None:
    """kind log: speed set, base poses those of the batch run of the log (the same engine
    path), paused at the log's end; kind sea returns to the synthesised sea at t = 0."""
    key = stored(3.0)
    session = LiveSession(SCENARIO)
    changed = session.patch({"motion_source": {"kind": "log", "log": key, "speed": 4}})
    assert "motion_source" in changed and session.controls.speed == 4.0
    while session.controls.playing:
        session.advance(0.05)
    assert session._sim.t == pytest.approx(3.0) and session.motion_state()["status"] == "ended"
    batch = simulate({**SCENARIO, "duration": 3.0, "base_motion": {"source": "log", "log": key}})
    np.testing.assert_array_equal(session.series()["base_pose"], batch.series["base_pose"])
    session.patch({"motion_source": {"kind": "sea"}, "playing": True})
    assert session._sim.t == 0.0 and session.scenario.base_motion is None
    assert session.motion_state()["status"] == "synthesised"


@pytest.mark.parametrize(
    ("source", "names"),
    [
        ({"kind": "river"}, "kind"),
        ({"kind": "log", "log": "0123456789abcdef", "speed": 9}, "speed"),
        ({"kind": "log"}, "log ID"),
        ({"kind": "sea", "log": "0123456789abcdef"}, "log ID"),
        ({"kind": "log", "log": "0123456789abcdef"}, "not stored"),
        ({"kind": "udp"}, "--motion-udp"),
    ],
)
def test_a_bad_source_is_refused_and_changes_nothing(
    logs: Path, source: dict, names: str
) -> None:
    """An unknown kind, a speed outside 1-8, a log ID without kind log (or the reverse), a log
    not stored, or udp without a motion input: a ValueError naming it; nothing changes."""
    session = LiveSession(SCENARIO)
    session.advance(0.2)
    t, restarts = session._sim.t, session.restarts
    with pytest.raises((ValueError, TwinError), match=names):
        session.patch({"motion_source": source})
    assert session._sim.t == t and session.restarts == restarts
    assert session.motion_state()["kind"] == "sea"


def test_a_comparison_lane_sees_the_same_stream() -> None:
    """With a comparison planner, both lanes follow the one stream at one offset: equal base
    poses, each its own planner; a mechanism switch keeps following it."""
    live = LiveMotion("test", stale_after=600.0, sensor_position=SENSOR)
    session = LiveSession(SCENARIO, motion=live)
    live.push(samples(0.0, 1.0), time.monotonic())
    session.patch({"motion_source": {"kind": "udp"}, "compare_planner": "mtmp"})
    live.push(samples(1.0, 3.0), time.monotonic())
    assert session.advance(0.0) > 0
    np.testing.assert_array_equal(session.series(0)["base_pose"], session.series(1)["base_pose"])
    session.patch({"mechanism": "upr4", "planner": "pid"})
    assert session.motion_state()["kind"] == "udp" and session._stream().mount == MOUNTS["upr4"]
    live.push(samples(3.0, 3.5), time.monotonic())
    assert session.advance(0.0) > 0 and np.isfinite(session.series()["base_pose"]).all()

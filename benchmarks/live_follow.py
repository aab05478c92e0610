"""Benchmark of the live session following a live motion stream (issue 40, the live path): the
CPU the session's thread spends following a 50 Hz MRU stream beside the same session on the
synthesised sea, how far the simulation trails the newest sample, every sentence received,
and the Onboard panel's evaluation time (`twin.runs.onboard_live.LiveOnboard.evaluate`).

    python benchmarks/live_follow.py [--seconds 20] [--full] [--history]

The real sender (`twin.motion.replay.send`, `$PSXN,23` at 50 Hz) feeds the real listener
(`twin.web.motion_udp.MotionListener`) on a free loopback port; the live session (the
`twin serve` demo, `live_demo()`) runs its own thread and follows it (`motion_source` udp).
CPU is that thread's (`time.pthread_getcpuclockid`) over the wall time, in % of one core. The
lag is sampled every 0.1 s: the newest sample's time minus the stream time the simulation has
reached (`t + offset`), the latency a sample waits before it moves the hull. `--full` also
times a full evaluation: the shipped example log replayed (`motion_source` log) to 1200 s, then
`LiveOnboard.evaluate` twice on a fresh cell cache (the first runs its missing cells).
`--history` times the evaluations of a followed stream as its history grows to 20 min: the
SOV's motion in Hs 2 m, Tp 8 s at 50 Hz, pushed a minute at a time, one evaluation each.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from twin.motion.replay import send
from twin.motion.series import MotionSeries
from twin.runs.onboard_live import LiveOnboard
from twin.sim.live import LiveSession, live_demo
from twin.sim.motion_live import LiveMotion
from twin.web.motion_udp import MotionListener

RATE = 50.0  # [Hz] the fastest MRU rate the twin reads


def _log(seconds: float) -> MotionSeries:
    """A heave-roll-pitch log at RATE."""
    t = np.arange(0.0, seconds, 1.0 / RATE)
    m = np.zeros((t.size, 6))
    m[:, 2], m[:, 3], m[:, 4] = np.sin(0.6 * t), 0.03 * np.sin(0.5 * t), 0.02 * np.cos(t)
    return MotionSeries(t, m, ("heave", "roll", "pitch"))


def _cpu(thread: threading.Thread) -> float:
    """[s] CPU time of a running thread."""
    assert thread.ident is not None
    return time.clock_gettime(time.pthread_getcpuclockid(thread.ident))


def run(seconds: float, follow: bool) -> dict[str, float]:
    """One session for `seconds`: on the sea, or following a stream sent meanwhile."""
    live = LiveMotion("bench")
    listener = MotionListener(live, 0)
    listener.start()
    session = LiveSession(live_demo(), motion=live)
    if follow:
        session.patch({"motion_source": {"kind": "udp"}})
    session.start()
    thread = session._thread
    assert thread is not None
    sender = threading.Thread(target=send, args=(_log(seconds), "127.0.0.1",
                                                 listener.address[1], "psxn", RATE))  # fmt: skip
    lags: list[float] = []
    begin, cpu0 = time.monotonic(), _cpu(thread)
    sender.start()
    while sender.is_alive():
        time.sleep(0.1)
        stream = getattr(session._sim.base_motion, "measured", None)
        newest = live.newest()
        if follow and stream is not None and stream.offset is not None and newest is not None:
            lags.append(newest - (session._sim.t + stream.offset))
    wall, cpu = time.monotonic() - begin, _cpu(thread) - cpu0
    onboard = LiveOnboard(session)
    started = time.perf_counter()
    onboard.evaluate()
    evaluate = time.perf_counter() - started
    steps = session._sim.k
    session.stop()
    listener.stop()
    return {"cpu": 100.0 * cpu / wall, "steps": steps, "sent": len(_log(seconds)),
            "stored": live.counts["samples"], "lag_mean": float(np.mean(lags)) if lags else 0.0,
            "lag_max": float(np.max(lags)) if lags else 0.0, "evaluate": evaluate}  # fmt: skip


def full_evaluation() -> None:
    """Print two evaluations of a 20-min window of the shipped log: cells run, then cached."""
    from twin.motion.logs import read_motion
    from twin.motion.sensor import Sensor
    from twin.sim.measured import LOG_DIR_ENV, store_log

    os.environ[LOG_DIR_ENV] = tempfile.mkdtemp()
    sensor = Sensor.load("assets/motion/sensor.yaml")
    key = store_log(read_motion(Path("assets/motion/mru_example.csv"), sensor), sensor.position)
    session = LiveSession(live_demo())
    session.patch({"motion_source": {"kind": "log", "log": key, "speed": 8}})
    while session._sim.t < 1200.0:
        session.step(1000)
    onboard = LiveOnboard(session, tempfile.mkdtemp())
    for what in ("cells run", "cells cached"):
        started = time.perf_counter()
        result = onboard.evaluate()
        print(f"full evaluation ({what}) {time.perf_counter() - started:.2f} s: "
              f"{result['estimate']}, operability {result['operability']}")  # fmt: skip


def history_evaluations() -> None:
    """Print each evaluation's time as a followed 50 Hz stream's history grows to 20 min."""
    from twin.sea.synthesis import wave_components
    from twin.sim.base_motion import mount_for
    from twin.vessel import load_raos, vessel_motion

    t = np.arange(0.0, 1200.0, 1.0 / RATE)
    sea = wave_components(2.0, 8.0, heading=np.radians(150.0), seed=3, n_components=300)
    hull = vessel_motion(sea, load_raos(mount_for("hybrid").vessel), t)
    live = LiveMotion("bench", stale_after=3600.0)
    session = LiveSession(live_demo(), motion=live)
    session.patch({"motion_source": {"kind": "udp"}})
    onboard = LiveOnboard(session, tempfile.mkdtemp())
    for minute in range(20):
        part = slice(int(minute * 60 * RATE), int((minute + 1) * 60 * RATE))
        live.push([(float(ti), (float(h), float(r), float(q)))
                   for ti, (h, r, q) in zip(t[part], hull[part, 2:5], strict=True)],
                  time.monotonic())  # fmt: skip
        session.advance(0.0)
        started = time.perf_counter()
        result = onboard.evaluate()
        what = "refused" if result["estimate"] is None else (
            "reused" if result["report_age_s"] > 0 else "full report")  # fmt: skip
        print(f"history {minute + 1:2d} min: evaluation {time.perf_counter() - started:6.3f} s "
              f"({what})")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="stream length [s]")
    parser.add_argument("--full", action="store_true", help="time a full evaluation too")
    parser.add_argument("--history", action="store_true",
                        help="time the evaluations of a growing 20-min stream history")
    args = parser.parse_args()
    seconds = args.seconds
    sea, follow = run(seconds, False), run(seconds, True)
    print(f"session on the synthesised sea       {sea['cpu']:6.2f} % of a core, "
          f"{sea['steps']} steps")  # fmt: skip
    print(f"session following the 50 Hz stream  {follow['cpu']:6.2f} % of a core, "
          f"{follow['steps']} steps")  # fmt: skip
    print(f"sentences sent {follow['sent']}, samples stored {follow['stored']}, dropped "
          f"{follow['sent'] - follow['stored']}")  # fmt: skip
    print(f"lag behind the newest sample: mean {1000 * follow['lag_mean']:.0f} ms, max "
          f"{1000 * follow['lag_max']:.0f} ms")  # fmt: skip
    print(f"onboard evaluation (a {seconds:.0f} s window: the estimator's refusal) "
          f"{1000 * follow['evaluate']:.0f} ms")  # fmt: skip
    if args.full:
        full_evaluation()
    if args.history:
        history_evaluations()


if __name__ == "__main__":
    main()

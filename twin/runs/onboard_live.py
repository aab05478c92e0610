"""The onboard report of the live session's measured motion (issue 40, the viewer's Onboard
panel): the sea estimated from the newest window of the followed source, operability now, the
heading advice, and the tip error and leg margin the session measured, re-evaluated every
`PERIOD` seconds on a thread of its own, so that neither the estimate nor a workability cell
it runs holds up the live loop or the viewer's frames.

The source is the live session's (`LiveSession.motion_state`):

- a live stream (`udp`): its samples are collected here from the input's buffer
  (`LiveMotion.since`, which keeps a minute) into a history of the last `window` seconds;
- a stored log replayed (`log`): the log's motion up to the session's time;
- the synthesised sea: nothing is measured, nothing estimated (the panel says so).

Until the window holds `twin.motion.estimate.MIN_WINDOW` (10 min) of motion, the estimator's
own refusal is shown; then one window (`OnboardSpec.window`, 20 min, or what there is) goes
through `twin.runs.onboard.onboard_report` — the one path of `twin onboard` and
`POST /api/onboard` — for the session's planner (and its comparison planner), the cells cached
in `data_dir`, missing ones run in this process.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from twin.motion.estimate import MIN_WINDOW, EstimateRefused, estimate_sea
from twin.motion.series import CHANNELS, MotionSeries
from twin.runs.onboard import OnboardSpec, centre_motion, onboard_report
from twin.runs.workability import WorkabilitySpec
from twin.sim.base_motion import raos_named
from twin.sim.live import MOTION_SOURCE, LiveSession
from twin.sim.measured import load_log

log = logging.getLogger(__name__)

#: [s] between two evaluations (well inside the minute `LiveMotion` keeps, so no sample of a
#: stream is missed between two collections)
PERIOD = 5.0
#: [s] between two full reports of one source (the estimate and its cells take about a second
#: once cached: docs/onboard_live.md); the evaluations between reuse the last one
REPORT_PERIOD = 60.0
#: [Hz] the window is resampled to this rate before the estimate (issue 40's 10 Hz budget)
RATE = 10.0
#: samples of a stream's history kept: the default window at the fastest rate an MRU sends
HISTORY = int(OnboardSpec().window * 50)


class LiveOnboard:
    """Evaluates the live session's onboard report every `period` s on its own thread.

    Args:
        session: the live session (its motion source, planner and metrics).
        data_dir: folder of the workability cell cache (None: a temporary one per report).
        spec: the report's window and γ (its workability planners are the session's).
        period: [s] between two evaluations.
        report_period: [s] between two full reports of one source, planners and start.
    """

    def __init__(self, session: LiveSession, data_dir: str | Path | None = None,
                 spec: OnboardSpec | None = None, period: float = PERIOD,
                 report_period: float = REPORT_PERIOD) -> None:  # fmt: skip
        self.session, self.data_dir = session, data_dir
        self.spec = spec or OnboardSpec()
        self.period, self.report_period = period, report_period
        # (what it was of, monotonic time, the report's figures) of the last full report
        self._last: tuple[tuple, float, dict[str, Any]] | None = None
        self._history: deque[tuple[float, tuple[float, float, float]]] = deque(maxlen=HISTORY)
        self._lock = threading.Lock()
        self._latest: dict[str, Any] | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def latest(self) -> dict[str, Any] | None:
        """The newest evaluation (`evaluate`), None before the first."""
        with self._lock:
            return self._latest

    def start(self) -> None:
        """Evaluate now and every `period` s on a daemon thread (idempotent)."""
        if self._thread is None or not self._thread.is_alive():
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="twin-onboard", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                result = self.evaluate()
            except Exception as exc:  # the panel says why; the next period tries again
                log.exception("onboard evaluation failed")
                result = {"kind": None, "error": f"{type(exc).__name__}: {exc}"}
            with self._lock:
                self._latest = result
            self._stop.wait(self.period)

    def evaluate(self) -> dict[str, Any]:
        """One evaluation: `kind` and `status` of the source, `window_s` [s] of motion held,
        `needed_s` [s], the `estimate` (hs, hs_sd [m], tp, tp_sd [s], direction,
        direction_sd [deg, `Scenario.heading`], ambiguous) or why it was `refused`, per planner
        its `operability` [0-1] at the current relative heading and its `advice` (the grid's
        headings ranked: heading, probability, turn [deg, + to port]), `tip_error_max` [m]
        and `leg_margin` [m] over the session's history of `span_s` [s], `elapsed_s` [s]."""
        started = time.perf_counter()
        state = self.session.snapshot()
        source = state[MOTION_SOURCE]
        metrics = state["metrics"]
        out: dict[str, Any] = {
            "kind": source["kind"], "status": source["status"], "window_s": 0.0,
            "needed_s": MIN_WINDOW, "estimate": None, "refused": None, "operability": {},
            "advice": {}, "tip_error_max": metrics.get("tip_position_error_max"),
            "leg_margin": metrics.get("leg_margin"), "span_s": _span(self.session),
            "planner": state["planner"],
        }  # fmt: skip
        if source["kind"] == "sea":
            out["refused"] = "the hull follows the synthesised sea: nothing measured to estimate"
        else:
            t, motion = self._window(source, float(state["t"]))
            out["window_s"] = float(t[-1] - t[0]) if t.size > 1 else 0.0
            out |= self._fresh(t, motion, state)
        out["elapsed_s"] = time.perf_counter() - started
        return out

    def _window(self, source: dict[str, Any], t_now: float) -> tuple[np.ndarray, np.ndarray]:
        """The newest window of the source's motion at the centre of motion: times (N,) [s]
        and motion (N, 6) [m, rad], absent channels NaN."""
        if source["kind"] == "log":
            series, position = load_log(source["log"])
            window = series.window(max(0.0, t_now - self.spec.window), t_now + 1e-9)
            return window.time, centre_motion(window.motion, position)
        live = self.session.motion
        assert live is not None  # a udp source needs one (`LiveSession.patch`)
        last = self._history[-1][0] if self._history else -np.inf
        t, motion = live.since(last)
        new = t > last
        self._history.extend(zip(t[new], map(tuple, motion[new, 2:5]), strict=True))
        while self._history and self._history[0][0] < self._history[-1][0] - self.spec.window:
            self._history.popleft()
        times = np.array([s[0] for s in self._history], dtype=float)
        rows = np.full((times.size, 6), np.nan)
        if times.size:
            rows[:, 2:5] = [s[1] for s in self._history]
        return times, centre_motion(rows, live.sensor_position)

    def _fresh(self, t: np.ndarray, motion: np.ndarray, state: dict[str, Any]) -> dict[str, Any]:
        """The last full report of the same source, planners and start if under
        `report_period` old (with its `report_age_s`), else `_report` now."""
        compare = state["compare"]["planner"] if state["compare"] else None
        of = (state[MOTION_SOURCE]["kind"], state[MOTION_SOURCE]["log"], state["mechanism"],
              state["planner"], compare, state["restarts"])  # fmt: skip
        now = time.monotonic()
        last = self._last
        if last is not None and last[0] == of and now - last[1] < self.report_period:
            return {**last[2], "report_age_s": now - last[1]}
        report = self._report(t, motion, state)
        if report.get("estimate") is not None:
            self._last = (of, now, report)
        return {**report, "report_age_s": 0.0}

    def _report(self, t: np.ndarray, motion: np.ndarray, state: dict[str, Any]) -> dict[str, Any]:
        """The estimate, operability and advice of a window, or the estimator's refusal."""
        if t.size < 2:
            return {"refused": "no motion received yet"}
        channels = tuple(c for i, c in enumerate(CHANNELS) if np.isfinite(motion[:, i]).any())
        uniform = MotionSeries(t - t[0], motion, channels).resampled(RATE)
        span = float(uniform.time[-1] - uniform.time[0]) + 1 / RATE
        if span < MIN_WINDOW:  # the estimator's own refusal, and cheap
            try:
                estimate_sea(uniform.time, uniform.motion, raos_named(self.spec.vessel()))
            except EstimateRefused as exc:
                return {"refused": str(exc)}
        planners = [state["planner"], *([state["compare"]["planner"]] if state["compare"] else [])]
        spec = self.spec.model_copy(update={
            "window": min(self.spec.window, span),
            "workability": WorkabilitySpec(**{
                **self.spec.workability.model_dump(), "mechanism": state["mechanism"],
                "planners": planners}),
        })  # fmt: skip
        report = onboard_report(uniform.time, uniform.motion, spec, data_dir=self.data_dir,
                                scheduler="in-process")  # fmt: skip
        return _summary(report)


def _summary(report: Any) -> dict[str, Any]:
    """The panel's figures of a one-window `OnboardReport`."""
    sea = report.estimates[-1]
    rows = report.windows
    if sea is None:
        return {"refused": str(rows["refused"].iloc[-1])}
    estimate = {k: float(getattr(sea, k)) for k in ("hs", "hs_sd", "tp", "tp_sd", "direction",
                                                     "direction_sd")}  # fmt: skip
    estimate["ambiguous"] = bool(sea.ambiguous)
    advice = {
        str(planner): [{"heading": float(r.heading), "probability": float(r.probability),
                        "turn": float(r.turn)} for r in group.sort_values("rank").itertuples()]
        for planner, group in report.advice.groupby("planner", sort=False)
    }  # fmt: skip
    now = zip(rows["planner"], rows["probability"], strict=True)
    return {"estimate": estimate, "advice": advice,
            "operability": {str(p): float(v) for p, v in now}}  # fmt: skip


def _span(session: LiveSession) -> float:
    """[s] the time the session's history (the metrics' window) covers."""
    t = session.series()["t"]
    return float(t[-1] - t[0]) if t.size > 1 else 0.0


def alerts(result: dict[str, Any], threshold: float) -> list[str]:
    """The planners whose operability now is under `threshold` [0-1], each as
    "planner p < threshold"."""
    return [f"{planner} {p:.2f} < {threshold:.2f}"
            for planner, p in result.get("operability", {}).items()
            if np.isfinite(p) and p < threshold]  # fmt: skip

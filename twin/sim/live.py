"""The live session: one simulation stepped in real time, shared by every browser and client.

A background thread steps the simulation at dt of simulated time, paced to wall time × speed.
Readers (the 3D scene, REST) take `latest()` / `snapshot()` under a lock and never block the
loop for longer than a copy. Writers (`patch`, `reset`, `replay`, `seek`, `play`, `pause`, from
the GUI's callbacks and REST alike) put a command on a queue that the session's own thread
alone applies, between two steps, and wait for its outcome (without a running thread, the
caller applies it, one command at a time); each validates first, so a bad value changes
nothing and a good one acts on the next step. A change that restarts the simulation builds the
new `Simulation` outside the lock (readers and the render loop go on reading the old one) and
swaps it in under it. While paused, the thread sleeps until a command comes. `step(n)` takes
the lock one chunk of steps at a time and stops at a wall-clock cap, so stepping on demand
never holds up readers either.

A numerical fault holds, damps or clamps inside the step (`twin.sim.faults`) and shows in
`snapshot()["faults"]`; anything else a step raises is caught by the loop, logged, counted
(`loop_errors`) and the loop goes on: a live twin does not stop on a bad step.

Planners side by side: `patch({"compare_planner": "pi"})` restarts the session with a second
lane of the same `Simulation`, the same scenario under another planner; both lanes see the
same sea, so the same vessel motion. Every later patch applies to both lanes, except that the
second keeps its own planner; `compare_planner: None` drops it (another restart at t = 0).

Replay: `replay(result, run_id)` shows a stored run instead of the simulation: readers get
the run's scenario and its recorded samples at the replay time, which the loop advances at
`speed` while `playing` (nothing is simulated; the live simulation waits). `seek` moves it,
`reset()` or any scenario patch returns to the live simulation.

Motion source: `patch({"motion_source": {"kind": "udp"}})` makes the hull follow the live
stream the session was given (`twin serve --motion-udp`; `twin.sim.motion_live`): the stream's
clock then drives the simulation, which stands still, holding the last pose, while the stream
is stale. `{"kind": "log", "log": ID, "speed": 1-8}` replays a stored log as the scenario's
`base_motion` (the batch path), at that speed, pausing at its end; `{"kind": "sea"}` returns to
the synthesised sea. Each choice restarts live time at t = 0 and is kept across later
restarts; the vessel motion always enters the one engine as base poses.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, StrictBool, model_validator

from twin.errors import TwinError
from twin.planners import PLANNERS, get_planner
from twin.sea.components import WaveComponents
from twin.sim.engine import RESTART_FIELDS, Simulation
from twin.sim.measured import describe_log
from twin.sim.motion_live import LiveMotion, StreamMotion, stream_motions
from twin.sim.result import SimulationResult
from twin.sim.scenario import MAX_DURATION, Scenario, check_one_sea

log = logging.getLogger(__name__)

#: the live session's start: the papers' hybrid MTMP run, held at the joint limits as a real
#: machine is (`Scenario.joint_limits`)
LIVE_DEFAULTS = {"joint_limits": "hold"}
#: the live demo's start per mechanism (`twin serve`, the viewer's mechanism switch): a planner
#: and a sea it holds within every limit with the landing point (the readout's tip error,
#: `FrameState.landing_offset`) millimetres from where it is held. Measured in a live session
#: over 150 s at heading 150° (hold), largest offset: the hybrid system with qp at WMO 4,
#: 0.12 mm, no stop at a limit (MTMP there: 0.5-1.7 m on sea seeds 0-1); the 3UPU_UP with pid at
#: WMO 2, 2.0 mm (WMO 3: 123 mm, WMO 4: 1.9 m); the 4-UPR with pid at WMO 1,
#: 2.3 mm: it levels the pad (heave, roll, pitch) but cannot cancel surge and sway, so the pad
#: drifts with the vessel, 190-250 mm at WMO 2 whatever the heading.
LIVE_DEMO: dict[str, dict[str, Any]] = {
    "hybrid": {"planner": "qp", "sea_state": 4.0},
    "upu3up": {"planner": "pid", "sea_state": 2.0},
    "upr4": {"planner": "pid", "sea_state": 1.0},
}


def live_demo(mechanism: str = "hybrid") -> dict[str, Any]:
    """The live demo's scenario fields for `mechanism` (`LIVE_DEMO`), on top of
    `LIVE_DEFAULTS`."""
    return {"mechanism": mechanism, **LIVE_DEMO[mechanism]}


#: samples the live session keeps (a ring buffer: 100 s at dt = 0.05 s)
HISTORY = 2000
#: most steps one wall-clock tick may take; a stalled machine drops simulated time instead of
#: spiralling (the loop never tries to catch up more than this)
MAX_CATCH_UP = 40
#: steps one call of the engine takes within a tick, between two checks of the tick's budget
CHUNK = 8
#: [s] shortest pause between two ticks: the loop lets readers and writers (REST, viewer)
#: take the lock even when stepping cannot keep up with wall time × speed
MIN_PAUSE = 0.002
#: steps `step(n)` takes per hold of the lock, and [s] the most wall time one call may take
STEP_CHUNK = 16
STEP_WALL = 2.0
#: [s] longest sleep of the paused loop between two looks at its stop flag (a command, a
#: stop or a play wakes it at once)
PAUSED_WAIT = 1.0
#: [s] how often a caller waiting for its command checks that the session thread still runs
COMMAND_POLL = 0.5


class _Command:
    """A writer's change, applied once by whoever runs it first (the session thread, or the
    caller itself once that thread has stopped); the caller waits for its outcome."""

    def __init__(self, apply: Callable[[], Any]) -> None:
        self._apply = apply
        self._claimed = threading.Lock()
        self.done = threading.Event()
        self._result: Any = None
        self._error: BaseException | None = None

    def run(self) -> None:
        if not self._claimed.acquire(blocking=False):
            return  # already run
        try:
            self._result = self._apply()
        except BaseException as exc:  # handed to the caller, raised in its thread
            self._error = exc
        finally:
            self.done.set()

    def outcome(self) -> Any:
        """The change's return value; its error raised again."""
        if self._error is not None:
            raise self._error
        return self._result


class LiveControls(BaseModel):
    """Knobs of the live session that are not part of a scenario."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_assignment=True)

    speed: float = Field(1.0, ge=0.25, le=8.0, description="[-] simulated / wall time")
    playing: StrictBool = Field(True, description="whether the loop advances (true or false)")


#: Scenario fields a live session takes: not `duration` (it means nothing live), nor
#: `base_motion` (the live session's is chosen as a whole by `motion_source`, which also sets
#: a log's length as the duration)
LIVE_FIELDS = tuple(n for n in Scenario.model_fields if n not in ("duration", "base_motion"))
#: the patch key of the comparison lane's planner (not a scenario field)
COMPARE = "compare_planner"
#: the patch key of the live motion source (`LiveMotionSource`, not a scenario field)
MOTION_SOURCE = "motion_source"


class LiveMotionSource(BaseModel):
    """Where the live session's hull motion comes from."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    kind: Literal["sea", "udp", "log"] = Field(
        "sea", description="sea: the synthesised sea; udp: the live motion input (twin serve "
        "--motion-udp PORT); log: a stored motion log replayed (POST /api/motion-logs)",
    )  # fmt: skip
    log: str | None = Field(None, pattern=r"^[0-9a-f]{16}$",
                            description="the stored log's ID (kind log only)")  # fmt: skip
    speed: float = Field(1.0, ge=1.0, le=8.0, description="[-] a log's replay speed, 1-8×")

    @model_validator(mode="after")
    def _log_named(self) -> LiveMotionSource:
        if (self.kind == "log") != (self.log is not None):
            raise TwinError("motion_source: a log ID goes with kind 'log', and only with it")
        return self


@dataclass
class Replay:
    """A stored run played back: its series, the replay time, and what draws it.

    Attributes:
        run_id: the stored run's id.
        scenario: its scenario.
        series: its samples, (T, ...) per key.
        metrics: its metrics over the whole run.
        mechanism: a mechanism object of its kind (only read).
        sea: its sea (to draw the surface).
        held: (4, 4) ᴵT*, the inertial pose it held.
        t: [s] the replay time.
    """

    run_id: str
    scenario: Scenario
    series: dict[str, np.ndarray]
    metrics: dict[str, Any]
    mechanism: Any
    sea: WaveComponents
    held: np.ndarray
    t: float = 0.0

    @classmethod
    def of(cls, result: SimulationResult, run_id: str) -> Replay:
        """The replay of a stored result. Its mechanism, sea and held pose come from a
        `Simulation` of the scenario that is built, never stepped: the same objects the run
        had at t = 0."""
        sim = Simulation(result.scenario, history_limit=1)
        series = {k: np.asarray(v) for k, v in result.series.items()}
        if series["t"].size == 0:
            raise TwinError(f"run {run_id}: no samples to replay")
        return cls(run_id, result.scenario, series, dict(result.metrics), sim.mechanism,
                   sim.base_motion.components, np.array(sim.held[0]))  # fmt: skip

    @property
    def duration(self) -> float:
        """[s] time of the last sample."""
        return float(self.series["t"][-1])

    @property
    def dt(self) -> float:
        return float(self.scenario.dt)

    def seek(self, t: float) -> None:
        """Move to time t [s] (0 ≤ t ≤ duration; a TwinError naming `t` otherwise)."""
        if not (np.isfinite(t) and 0.0 <= t <= self.duration + 1e-9):
            raise TwinError(
                f"t: {t:g} s is outside run {self.run_id}; allowed 0 ≤ t ≤ {self.duration:g}"
            )
        self.t = min(float(t), self.duration)

    def record(self) -> dict[str, np.ndarray]:
        """The sample at or just before the replay time (copies)."""
        k = int(np.searchsorted(self.series["t"], self.t + 1e-9, side="right")) - 1
        k = min(max(k, 0), self.series["t"].size - 1)
        return {key: np.array(values[k]) for key, values in self.series.items()}

    def state(self) -> dict[str, Any]:
        """What `LiveSession.snapshot()["replay"]` shows."""
        return {"run_id": self.run_id, "t": self.t, "duration": self.duration}


class LiveSession:
    """A running `Simulation` with real-time pacing, pause/play/step/reset and live patches.

    Args:
        scenario: the starting scenario: a `Scenario`, or a dict of fields on top of
            `LIVE_DEFAULTS`. Its `duration` is ignored: a live session runs until stopped.
        tick: [s] wall-clock period of the loop (default 1/60 s).
        motion: the live motion input (`twin serve --motion-udp`) that the `udp` motion
            source follows; None: no such source.
    """

    def __init__(self, scenario: Scenario | dict | None = None, tick: float = 1 / 60,
                 motion: LiveMotion | None = None) -> None:  # fmt: skip
        base = (
            scenario
            if isinstance(scenario, Scenario)
            else Scenario(**{**LIVE_DEFAULTS, **(scenario or {})})
        )
        self._lock = threading.RLock()
        # writers' commands, applied one at a time (`_applying`) by the session thread
        self._commands: queue.SimpleQueue[_Command | None] = queue.SimpleQueue()
        self._applying = threading.RLock()
        self.controls = LiveControls()
        self.tick = tick
        self._compare: str | None = None  # the comparison lane's planner, if any
        self._replay: Replay | None = None
        self._live_playing = True  # `playing` of the live simulation while a replay plays
        self.motion = motion
        self._source = LiveMotionSource()
        self._sim = Simulation(base, history_limit=HISTORY)
        self._debt = 0.0  # [s] simulated time owed to the wall clock
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.version = 0  # bumps on every reset, so viewers can clear trails
        #: times live time restarted at t = 0 (a restarting change or a reset), and why last
        self.restarts = 0
        self.restart_reason: str | None = None
        self.loop_errors = 0  # steps the loop caught an unexpected error in

    # -- readers -----------------------------------------------------------------------------
    @property
    def scenario(self) -> Scenario:
        """The scenario shown: the live one, or the replayed run's."""
        with self._lock:
            return self._replay.scenario if self._replay is not None else self._sim.scenario

    @property
    def mechanism(self) -> Any:
        with self._lock:
            return self._replay.mechanism if self._replay is not None else self._sim.mechanism

    @property
    def sea(self) -> WaveComponents:
        """The sea shown (a new object after a sea patch), e.g. to draw its surface."""
        with self._lock:
            if self._replay is not None:
                return self._replay.sea
            return self._sim.base_motion.components

    @property
    def held_transform(self) -> np.ndarray:
        """ᴵT* (4, 4): the inertial pose the mechanism holds, fixed at each (re)start."""
        with self._lock:
            if self._replay is not None:
                return np.array(self._replay.held)
            return np.array(self._sim.held[0])

    @property
    def compare_planner(self) -> str | None:
        """The comparison lane's planner (None: no comparison, or a replay is shown)."""
        with self._lock:
            return None if self._replay is not None else self._compare

    @property
    def replaying(self) -> dict[str, Any] | None:
        """The replay shown ({run_id, t, duration}), or None when live."""
        with self._lock:
            return None if self._replay is None else self._replay.state()

    def latest(self, lane: int = 0) -> dict[str, np.ndarray]:
        """The newest sample's record (arrays are copies): lane 1 is the comparison lane. A
        replay's sample at the replay time while one is shown."""
        with self._lock:
            if self._replay is not None:
                return self._replay.record()
            return self._sim.latest(lane)

    def view(self) -> dict[str, Any]:
        """One consistent reading for a viewer's frame, taken under one hold of the lock:
        `version`, `scenario`, `mechanism`, `record` (the newest sample, or the replay's),
        `compare` (its planner or None) with `compare_record`, `sea`, `held` (4, 4),
        `playing`, `speed` and `replay` (`replaying`)."""
        with self._lock:
            r = self._replay
            common = {"version": self.version, "playing": self.controls.playing,
                      "speed": self.controls.speed}  # fmt: skip
            if r is not None:
                return {**common, "scenario": r.scenario, "mechanism": r.mechanism,
                        "record": r.record(), "compare": None, "compare_record": None,
                        "sea": r.sea, "held": np.array(r.held), "replay": r.state()}  # fmt: skip
            sim = self._sim
            return {
                **common,
                "scenario": sim.scenario,
                "mechanism": sim.mechanism,
                "record": sim.latest(0),
                "compare": self._compare,
                "compare_record": sim.latest(1) if self._compare is not None else None,
                "sea": sim.base_motion.components,
                "held": np.array(sim.held[0]),
                "replay": None,
            }

    def series(self, lane: int = 0) -> dict[str, np.ndarray]:
        """The ring buffer of a lane of the live simulation, oldest first, per key (copies of
        its slices)."""
        with self._lock:
            return self._sim.series(lane)

    def snapshot(self) -> dict[str, Any]:
        """Flat scenario fields, sim time, speed, playing and the metrics over the buffer.

        Under the lock only copies are taken (the ring's slices, the fault counts and the
        joint-limit mode, `Simulation.metrics_later`); the metrics are computed after it is
        released, so a reader never holds up the loop, and from what was copied, so their
        fault counts are the series'.
        """
        with self._lock:
            if self._replay is not None:
                return self._replay_snapshot()
            sim, compare = self._sim, self._compare
            series, metrics = sim.series(), sim.metrics_later()
            head = {
                **sim.scenario.model_dump(exclude={"duration"}),
                "t": sim.t,
                **self.controls.model_dump(),
                "faults": {**sim.faults[0].summary(), "loop_errors": self.loop_errors},
                "replay": None,
                "restarts": self.restarts,
                "restart_reason": self.restart_reason,
                MOTION_SOURCE: self._motion_state(),
            }
            if compare is not None:
                other, other_metrics = sim.series(1), sim.metrics_later(1)
                faults = {**sim.faults[1].summary(), "loop_errors": self.loop_errors}
        out = {**head, "metrics": metrics(series), "compare": None}
        if compare is not None:
            out["compare"] = {"planner": compare, "metrics": other_metrics(other),
                              "faults": faults}  # fmt: skip
        return out

    def _replay_snapshot(self) -> dict[str, Any]:
        """`snapshot()` of a replay (under the lock): the run's scenario and stored metrics."""
        r = self._replay
        assert r is not None
        metrics = r.metrics
        faults = {
            "counts": dict(metrics.get("fault_counts", {})),
            "held": int(metrics.get("faults", 0)),
            "events": [],
            "loop_errors": self.loop_errors,
        }
        return {
            **r.scenario.model_dump(exclude={"duration"}),
            "t": r.t,
            **self.controls.model_dump(),
            "faults": faults,
            "metrics": metrics,
            "compare": None,
            "replay": r.state(),
            MOTION_SOURCE: self._motion_state(),
        }

    def motion_state(self) -> dict[str, Any]:
        """The motion source and how it goes (`snapshot()["motion_source"]`)."""
        with self._lock:
            return self._motion_state()

    def _motion_state(self) -> dict[str, Any]:
        """(Under the lock) `kind`, `log`, `speed` (a log's), `status`: "synthesised", a
        stream's "waiting" (nothing received yet), "live" or "stale" (the run holds its last
        pose), a log's "playing" or "ended"; `input`: the live motion input's status
        (`LiveMotion.status`, None without one); `resyncs` of a followed stream."""
        source, sim = self._source, self._sim
        out: dict[str, Any] = {"kind": source.kind, "log": source.log,
                               "speed": source.speed if source.kind == "log" else None,
                               "status": "synthesised", "resyncs": None,
                               "input": None if self.motion is None
                               else self.motion.status(time.monotonic())}  # fmt: skip
        if source.kind == "log":
            ended = sim.t >= sim.scenario.duration - 0.5 * sim.dt
            out["status"] = "ended" if ended else "playing"
        elif source.kind == "udp":
            stream = self._stream()
            live = out["input"] is not None and out["input"]["live"]
            out["status"] = ("live" if live else
                             "waiting" if stream.live.newest() is None else "stale")  # fmt: skip
            out["resyncs"] = stream.resyncs
        return out

    # -- writers -----------------------------------------------------------------------------
    def patch(self, changes: dict[str, Any]) -> set[str]:
        """Change scenario fields, `compare_planner` and/or `speed`, `playing`; all validated
        before any applies.

        The new scenario is validated once: by `Simulation.update` (which changes nothing
        unless all of it is good) or, for a field that needs a restart (`RESTART_FIELDS`, or
        a new `compare_planner`), as the `Scenario` the new `Simulation` starts from. The
        controls are validated once, as a `LiveControls`, before either. A comparison lane
        takes every change but keeps its own planner; after a mechanism switch it is kept if
        its planner plans for the new mechanism, else dropped. While a replay is shown, the
        controls act on it, and any other change returns to the live simulation.

        Returns:
            The names of the fields whose value changed, controls included.

        Raises:
            ValueError: an unknown field or a bad value, empty names included (nothing changes).
        """
        changes = dict(changes)
        controls = {k: changes.pop(k) for k in list(changes) if k in LiveControls.model_fields}
        given = COMPARE in changes
        compare = changes.pop(COMPARE, None)
        raw = changes.pop(MOTION_SOURCE, None)
        source = None if raw is None else LiveMotionSource.model_validate(raw)
        if source is not None and source.kind == "udp" and self.motion is None:
            raise TwinError(f"{MOTION_SOURCE}: kind 'udp' needs the live motion input; start "
                            "the server with twin serve --motion-udp PORT")  # fmt: skip
        if isinstance(changes.get("sea_state"), int | float):  # the code takes over from hs, tp
            check_one_sea(changes)
            changes = {"hs": None, "tp": None, **changes}
        unknown = sorted(set(changes) - set(LIVE_FIELDS))
        if unknown:
            raise TwinError(
                f"{unknown[0]}: not a live field; allowed: {sorted(LIVE_FIELDS)}, "
                f"{COMPARE}, {MOTION_SOURCE} and {sorted(LiveControls.model_fields)}"
            )
        return self._command(lambda: self._patch(changes, controls, compare, given, source))

    def _patch(
        self, changes: dict[str, Any], controls: dict[str, Any], compare: str | None, given: bool,
        source: LiveMotionSource | None = None,
    ) -> set[str]:  # fmt: skip
        """`patch`, applied by the session thread (the one writer): validate, build a new
        Simulation if the change restarts it (outside the lock), then change everything under
        the lock at once. A log source sets the speed (unless `speed` is given too)."""
        if source is not None and source.kind == "log" and "speed" not in controls:
            controls = {**controls, "speed": source.speed}
        new_controls = LiveControls(**{**self.controls.model_dump(), **controls})
        changed, swap = self._prepare(changes, compare if given else self._compare, given, source)
        with self._lock:
            if swap is not None:
                swap()
            elif changes:  # an update in place of the running simulation (under the lock)
                lanes = None if self._compare is None else [{}, {"planner": self._compare}]
                changed = self._sim.update(changes, lanes)
            if self._replay is not None and (changes or given or source):  # back to live
                self._replay = None
                self.version += 1
                if "playing" not in controls:
                    new_controls.playing = self._live_playing
            self.controls = new_controls
        return changed | set(controls)

    def _prepare(
        self, changes: dict[str, Any], compare: str | None, given: bool,
        source: LiveMotionSource | None = None,
    ) -> tuple[set[str], Callable[[], None] | None]:  # fmt: skip
        """For a change that restarts the simulation (a new motion source always does): the
        changed names and the swap that puts the new Simulation (built here, outside the
        lock) in place; otherwise (set(), None): an update in place. Raises before anything
        changes."""
        current = self._sim.scenario
        restart = any(k in RESTART_FIELDS and v != getattr(current, k) for k, v in changes.items())
        if not restart and compare == self._compare and source is None:
            return set(), None
        new = Scenario(**{**current.model_dump(), **changes,
                          **(_source_fields(source) if source else {})})  # fmt: skip
        if compare is not None and not given and new.mechanism not in _mechanisms(compare):
            compare = None  # the new mechanism has no such planner: the comparison ends
        follow = source or self._source
        sim = self._build(new, compare, follow)
        changed = {k for k in changes if getattr(new, k) != getattr(current, k)}
        if compare != self._compare:
            changed.add(COMPARE)
        if source is not None:
            changed.add(MOTION_SOURCE)

        def swap() -> None:
            self._sim, self._compare, self._debt, self._source = sim, compare, 0.0, follow
            self.restarts += 1
            self.restart_reason = ", ".join(sorted(changed)) + " changed"
            self.version += 1

        return changed, swap

    def _build(
        self, scenario: Scenario, compare: str | None, source: LiveMotionSource
    ) -> Simulation:
        """The live Simulation of a scenario, with a comparison lane under `compare`, its
        hull following the live stream for a `udp` source."""
        motions = None
        if source.kind == "udp" and self.motion is not None:
            motions = stream_motions(self.motion)
        if compare is None:
            return Simulation(scenario, history_limit=HISTORY, motions=motions)
        try:
            get_planner(compare, scenario.mechanism)
        except ValueError as exc:
            raise TwinError(f"{COMPARE}: {str(exc).removeprefix('planner: ')}") from None
        other = Scenario(**{**scenario.model_dump(), "planner": compare})
        return Simulation([scenario, other], history_limit=HISTORY, motions=motions)

    def reset(self) -> None:
        """Start the current scenario (and its comparison lane) again from t = 0; a replay
        shown returns to the live simulation."""
        self._command(self._reset)

    def _reset(self) -> None:
        sim = self._build(self._sim.scenario, self._compare, self._source)  # outside the lock
        with self._lock:
            self._sim = sim
            self._debt = 0.0
            self.restarts += 1
            self.restart_reason = "reset"
            if self._replay is not None:
                self._replay = None
                self.controls.playing = self._live_playing
            self.version += 1

    def replay(
        self, result: SimulationResult, run_id: str, t: float = 0.0, playing: bool = True
    ) -> None:
        """Show a stored run from time t [s] instead of the live simulation (which waits).

        Raises:
            ValueError: t outside the run (nothing changes).
        """
        replay = Replay.of(result, run_id)  # outside the lock: it builds the run's geometry
        replay.seek(t)

        def show() -> None:
            with self._lock:
                if self._replay is None:
                    self._live_playing = self.controls.playing
                self._replay = replay
                self.controls.playing = bool(playing)
                self.version += 1

        self._command(show)

    def seek(self, t: float, playing: bool | None = None) -> None:
        """Move the replay shown to time t [s]; `playing` true or false plays or pauses it.

        Raises:
            ValueError: no replay is shown, or t is outside the run (nothing changes).
        """
        self._command(lambda: self._seek(t, playing))

    def _seek(self, t: float, playing: bool | None) -> None:
        with self._lock:
            if self._replay is None:
                raise TwinError("t: no replay is shown; start one with a run id first")
            self._replay.seek(t)
            if playing is not None:
                self.controls.playing = bool(playing)

    def pause(self) -> None:
        self.patch({"playing": False})

    def play(self) -> None:
        self.patch({"playing": True})

    def step(self, n: int = 1, max_seconds: float | None = None) -> int:
        """Advance n steps now (also while paused), `STEP_CHUNK` at a time under the lock,
        which is let go between chunks; stops early once `max_seconds` (default `STEP_WALL`)
        of wall time have passed. Returns the steps taken (≥ 1 for n ≥ 1)."""
        deadline = time.monotonic() + (STEP_WALL if max_seconds is None else max_seconds)
        with self._lock:
            if self._replay is not None:  # a replay steps through its samples
                r = self._replay
                r.t = min(r.t + n * r.dt, r.duration)
                return n
        taken = 0
        while taken < n:
            chunk = min(STEP_CHUNK, n - taken)
            with self._lock:
                self._advance(chunk)
            taken += chunk
            if time.monotonic() > deadline:
                break
            time.sleep(0)  # readers and writers waiting for the lock get it now
        return taken

    def _advance(self, n: int) -> None:
        # a live session runs past the scenario's duration: extend it instead of stopping
        sim = self._sim
        if sim.k + n > sim.n_steps:
            sim.n_steps = sim.k + max(n, sim.n_steps)
        sim.advance(n)

    # -- the real-time loop ----------------------------------------------------------------
    def advance(self, wall_dt: float, budget: float | None = None) -> int:
        """Step as many dt as `wall_dt` × speed of simulated time owes; returns steps taken.

        At most `MAX_CATCH_UP` steps and, given a `budget` [s] of wall time (the loop gives
        half a tick), no more than fit in it: what is left is dropped, not owed, so a machine
        that cannot keep up runs slower than real time instead of holding the lock (and every
        client) for ever longer ticks.
        """
        with self._lock:
            if not self.controls.playing:
                self._debt = 0.0
                return 0
            if self._replay is not None:  # the replay's clock moves; nothing is simulated
                r = self._replay
                r.t = min(r.t + wall_dt * self.controls.speed, r.duration)
                if r.t >= r.duration:
                    self.controls.playing = False  # paused at its end
                return 0
            n = self._owed(wall_dt)
            # steps run in chunks; after each, the budget is checked (a chunk of a few steps
            # costs well under a millisecond on the compiled engine)
            deadline = time.perf_counter() + (np.inf if budget is None else budget)
            taken = 0
            while taken < n:
                chunk = min(n - taken, CHUNK)
                self._advance(chunk)
                taken += chunk
                if taken < n and time.perf_counter() > deadline:
                    self._debt = 0.0
                    break
            return taken

    def _owed(self, wall_dt: float) -> int:
        """(Under the lock) the steps this tick owes: what wall time × speed owes the
        synthesised sea or a log (which pauses at its end), what arrived of a live stream."""
        sim, kind = self._sim, self._source.kind
        if kind == "udp":  # the stream's clock, not the wall's, drives the run
            self._debt = 0.0
            return min(self._stream().due(sim.t, sim.dt, time.monotonic()), MAX_CATCH_UP)
        left = np.inf
        if kind == "log":
            left = round((sim.scenario.duration - sim.t) / sim.dt)
            if left <= 0:  # the log ended: paused there, its last pose held
                self.controls.playing = False
                return 0
        self._debt += wall_dt * self.controls.speed
        n = int(self._debt / sim.dt + 1e-9)
        if n > MAX_CATCH_UP:  # a stall drops simulated time; it is not owed
            n, self._debt = MAX_CATCH_UP, 0.0
        else:
            self._debt -= n * sim.dt
        return int(min(n, left))

    def _stream(self) -> StreamMotion:
        """(Under the lock) the live stream lane 0 follows (a `udp` source)."""
        measured = getattr(self._sim.base_motion, "measured", None)
        assert isinstance(measured, StreamMotion)  # `_build` put it there for `udp`
        return measured

    # -- commands ----------------------------------------------------------------------------
    def _command(self, apply: Callable[[], Any]) -> Any:
        """Have the session thread apply a change and return its outcome (its error raised
        here). Without a running session thread (not started, stopped, or this is it), the
        change is applied here, one command at a time."""
        thread = self._thread
        if thread is None or not thread.is_alive() or thread is threading.current_thread():
            with self._applying:
                return apply()
        command = _Command(apply)
        self._commands.put(command)
        while not command.done.wait(COMMAND_POLL):
            if not thread.is_alive():  # it stopped before it got to this one
                self._apply_queued()
        return command.outcome()

    def _apply_queued(self) -> None:
        """Apply every queued command, in order."""
        with self._applying:
            while True:
                try:
                    command = self._commands.get_nowait()
                except queue.Empty:
                    return
                if command is not None:
                    command.run()

    def _serve_commands(self, timeout: float) -> None:
        """(The session thread) wait up to `timeout` [s] for a command; apply those queued."""
        try:
            first = self._commands.get(timeout=max(timeout, 0.0))
        except queue.Empty:
            return
        if first is not None:
            with self._applying:
                first.run()
        self._apply_queued()

    def start(self) -> None:
        """Run the loop in a daemon thread (idempotent)."""
        if self._thread is not None and self._thread.is_alive():
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="twin-live", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._commands.put(None)  # wakes the loop
        if self._thread is not None:
            self._thread.join(timeout=5)
        self._apply_queued()  # commands it left: nobody waits for ever

    def _run(self) -> None:
        last = time.perf_counter()
        while not self._stop.is_set():
            now = time.perf_counter()
            try:
                self.advance(now - last, budget=0.5 * self.tick)
            except Exception:  # a bug must not stop the twin: log it and go on
                self.loop_errors += 1
                log.exception("live step failed (%d so far); the loop goes on", self.loop_errors)
            last = now
            if self.controls.playing:
                self._serve_commands(max(MIN_PAUSE, self.tick - (time.perf_counter() - now)))
            else:  # nothing to step: sleep until a command (a play, a patch) or a stop
                self._serve_commands(PAUSED_WAIT)
                last = time.perf_counter()  # a play steps from now, owing nothing


def _source_fields(source: LiveMotionSource) -> dict[str, Any]:
    """The scenario fields a motion source sets: a log's `base_motion` and its length (at most
    `MAX_DURATION`, its first hour) as the `duration`, where the live run pauses; the sea's and
    a stream's no `base_motion`.

    Raises:
        TwinError: a log ID that is not stored.
    """
    if source.kind != "log":
        return {"base_motion": None}
    assert source.log is not None  # LiveMotionSource checked it
    try:
        length = min(describe_log(source.log)["duration"], MAX_DURATION)
    except TwinError as exc:
        raise TwinError(f"{MOTION_SOURCE}: {exc}") from None
    return {"base_motion": {"source": "log", "log": source.log}, "duration": length}


def _mechanisms(planner: str) -> tuple[str, ...]:
    """The mechanisms a registered planner plans for (none for an unknown name)."""
    spec = PLANNERS.get(planner)
    return () if spec is None else tuple(spec.mechanisms)

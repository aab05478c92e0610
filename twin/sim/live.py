"""The live session: one simulation stepped in real time, shared by every browser and client.

A background thread steps the simulation at dt of simulated time, paced to wall time × speed.
Readers (the 3D scene, REST) take `latest()` / `snapshot()` under a lock and never block the
loop for longer than a copy; writers (`patch`, `reset`, …) validate first and apply between
two steps, so a bad value changes nothing and a good one acts on the next step. `step(n)` takes
the lock one chunk of steps at a time and stops at a wall-clock cap, so stepping on demand
never holds up readers either.

A numerical fault holds, damps or clamps inside the step (`twin.sim.faults`) and shows in
`snapshot()["faults"]`; anything else a step raises is caught by the loop, logged, counted
(`loop_errors`) and the loop goes on: a live twin does not stop on a bad step.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, StrictBool

from twin.errors import TwinError
from twin.sea.components import WaveComponents
from twin.sim.engine import RESTART_FIELDS, Simulation
from twin.sim.scenario import Scenario

log = logging.getLogger(__name__)

#: the live session's start: the papers' hybrid MTMP run, held at the joint limits as a real
#: machine is (`Scenario.joint_limits`)
LIVE_DEFAULTS = {"joint_limits": "hold"}
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


class LiveControls(BaseModel):
    """Knobs of the live session that are not part of a scenario."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_assignment=True)

    speed: float = Field(1.0, ge=0.25, le=8.0, description="[-] simulated / wall time")
    playing: StrictBool = Field(True, description="whether the loop advances (true or false)")


#: Scenario fields a live session takes (`duration` means nothing live).
LIVE_FIELDS = tuple(name for name in Scenario.model_fields if name != "duration")


class LiveSession:
    """A running `Simulation` with real-time pacing, pause/play/step/reset and live patches.

    Args:
        scenario: the starting scenario: a `Scenario`, or a dict of fields on top of
            `LIVE_DEFAULTS`. Its `duration` is ignored: a live session runs until stopped.
        tick: [s] wall-clock period of the loop (default 1/60 s).
    """

    def __init__(self, scenario: Scenario | dict | None = None, tick: float = 1 / 60) -> None:
        base = (
            scenario
            if isinstance(scenario, Scenario)
            else Scenario(**{**LIVE_DEFAULTS, **(scenario or {})})
        )
        self._lock = threading.RLock()
        self.controls = LiveControls()
        self.tick = tick
        self._sim = Simulation(base, history_limit=HISTORY)
        self._debt = 0.0  # [s] simulated time owed to the wall clock
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.version = 0  # bumps on every reset, so viewers can clear trails
        self.loop_errors = 0  # steps the loop caught an unexpected error in

    # -- readers -----------------------------------------------------------------------------
    @property
    def scenario(self) -> Scenario:
        with self._lock:
            return self._sim.scenario

    @property
    def mechanism(self) -> Any:
        with self._lock:
            return self._sim.mechanism

    @property
    def sea(self) -> WaveComponents:
        """The sea being simulated (a new object after a sea patch), e.g. to draw its surface."""
        with self._lock:
            return self._sim.base_motion.components

    @property
    def held_transform(self) -> np.ndarray:
        """ᴵT* (4, 4): the inertial pose the mechanism holds, fixed at each (re)start."""
        with self._lock:
            return np.array(self._sim.held[0])

    def latest(self) -> dict[str, np.ndarray]:
        """The newest sample's record (arrays are copies)."""
        with self._lock:
            return self._sim.latest()

    def series(self) -> dict[str, np.ndarray]:
        """The ring buffer, oldest first, per key (copies of its slices)."""
        with self._lock:
            return self._sim.series()

    def snapshot(self) -> dict[str, Any]:
        """Flat scenario fields, sim time, speed, playing and the metrics over the buffer.

        Under the lock only copies are taken (the ring's slices, the fault log); the metrics
        are computed after it is released, so a reader never holds up the loop.
        """
        with self._lock:
            sim = self._sim
            series = sim.series()
            head = {
                **sim.scenario.model_dump(exclude={"duration"}),
                "t": sim.t,
                **self.controls.model_dump(),
                "faults": {**sim.faults[0].summary(), "loop_errors": self.loop_errors},
            }
        return {**head, "metrics": sim.metrics(series)}

    # -- writers -----------------------------------------------------------------------------
    def patch(self, changes: dict[str, Any]) -> set[str]:
        """Change scenario fields and/or `speed`, `playing`; all validated before any applies.

        The new scenario is validated once: by `Simulation.update` (which changes nothing
        unless all of it is good) or, for a field that needs a restart (`RESTART_FIELDS`), as
        the `Scenario` the new `Simulation` starts from. The controls are validated once, as a
        `LiveControls`, before either.

        Returns:
            The names of the fields whose value changed, controls included.

        Raises:
            ValueError: an unknown field or a bad value, empty names included (nothing changes).
        """
        changes = dict(changes)
        controls = {k: changes.pop(k) for k in list(changes) if k in LiveControls.model_fields}
        unknown = sorted(set(changes) - set(LIVE_FIELDS))
        if unknown:
            raise TwinError(
                f"{unknown[0]}: not a live field; allowed: {sorted(LIVE_FIELDS)} and "
                f"{sorted(LiveControls.model_fields)}"
            )
        with self._lock:
            new_controls = LiveControls(**{**self.controls.model_dump(), **controls})
            current = self._sim.scenario
            if any(k in RESTART_FIELDS and v != getattr(current, k) for k, v in changes.items()):
                new = Scenario(**{**current.model_dump(), **changes})
                changed = {k for k in changes if getattr(new, k) != getattr(current, k)}
                self._sim = Simulation(new, history_limit=HISTORY)
                self.version += 1
            else:
                changed = self._sim.update(changes) if changes else set()
            self.controls = new_controls
        return changed | set(controls)

    def reset(self) -> None:
        """Start the current scenario again from t = 0."""
        with self._lock:
            self._sim = Simulation(self._sim.scenario, history_limit=HISTORY)
            self._debt = 0.0
            self.version += 1

    def pause(self) -> None:
        self.patch({"playing": False})

    def play(self) -> None:
        self.patch({"playing": True})

    def step(self, n: int = 1, max_seconds: float | None = None) -> int:
        """Advance n steps now (also while paused), `STEP_CHUNK` at a time under the lock,
        which is let go between chunks; stops early once `max_seconds` (default `STEP_WALL`)
        of wall time have passed. Returns the steps taken (≥ 1 for n ≥ 1)."""
        deadline = time.monotonic() + (STEP_WALL if max_seconds is None else max_seconds)
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
            self._debt += wall_dt * self.controls.speed
            dt = self._sim.dt
            n = int(self._debt / dt + 1e-9)
            if n > MAX_CATCH_UP:  # a stall drops simulated time; it is not owed
                n, self._debt = MAX_CATCH_UP, 0.0
            else:
                self._debt -= n * dt
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

    def start(self) -> None:
        """Run the loop in a daemon thread (idempotent)."""
        if self._thread is not None and self._thread.is_alive():
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="twin-live", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)

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
            self._stop.wait(max(MIN_PAUSE, self.tick - (time.perf_counter() - now)))

"""The one simulation engine: N lanes stepped together by a compiled kernel, chunk by chunk.

A `Simulation` holds N ≥ 1 scenarios of one mechanism and one dt as arrays (lanes). Each
chunk of steps it

1. samples every lane's base motion for a block of steps (vectorised over the wave
   components; a non-finite sample holds the last finite one and flags `Fault.BASE_MOTION`),
2. builds the chunk's held targets ᴮT_d and their twists from the block's poses
   (`twin.sim.target.held_targets`, into the thread's scratch buffer: they die with the chunk),
3. calls the mechanism's kernel (`twin.sim.kernels`, compiled by numba): plan, guard,
   integrate, step after step, writing states, diagnostics and fault bits,
4. computes what is recorded from the chunk's states at once (`twin.sim.records`) and writes
   it into the history, a preallocated ring of arrays — or, for a batch run stepped in one
   chunk, makes the chunk's arrays the history, with no copy.

`simulate(s)` is `Simulation(s).run().` and `simulate_many` groups scenarios into
Simulations; `step()` and `advance(n)` run the same chunks, so stepping one by one, in chunks
or all at once gives the same numbers (tested). The planner objects of `twin.planners` are
built by the registry and packed into the kernel's rows: they state the math, the kernel runs
it, and the tests hold one against the other.

A step never raises for numerical reasons and never records NaN: a non-finite base sample is
replaced by the last finite one, a planner or kinematics failure holds the mechanism for the
step, and each such step is flagged (`twin.sim.faults`) and counted in the metrics.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from twin.compiled import limit_threads, numba_threads
from twin.errors import TwinError
from twin.mechanisms import MECHANISMS
from twin.planners.parameters import as_records
from twin.sim.base_motion import BaseMotion
from twin.sim.faults import (
    HOLDS,
    Fault,
    FaultLog,
    flag_name,
    hold_invalid,
    hold_nonfinite,
    series_faults,
    tracking_diverged,
)
from twin.sim.history import History
from twin.sim.kernels import layout
from twin.sim.lanes import HybridLanes, PlatformLanes, runner, use_numba
from twin.sim.metrics import Reduction
from twin.sim.protocols import Lanes, LanesFactory, ReducingLanes
from twin.sim.result import SimulationResult
from twin.sim.scenario import DEFAULT_PLANNER, Scenario
from twin.sim.scratch import scratch
from twin.sim.target import held_targets
from twin.spatial import pose_to_transform

#: steps of base motion prepared at once for a live session (a sea change re-samples from
#: the current step, so a short block wastes little)
LIVE_BLOCK = 256
#: most steps × lanes prepared and stepped at once for a batch run (bounds the chunk's memory:
#: 18 floats of target and 18 of diagnostics each), and most steps per lane
BLOCK = 262_144
MAX_BLOCK = 8192

#: Scenario fields that change the sea: `Simulation.update` re-synthesises it in place.
SEA_FIELDS = frozenset(
    {"sea_state", "hs", "tp", "heading", "spectrum", "gamma", "spreading", "n_components",
     "seed", "regular_waves", "forward_speed", "base_motion"}
)  # fmt: skip
#: Scenario fields that need a new Simulation (a different machine, vessel or clock).
RESTART_FIELDS = frozenset({"mechanism", "vessel", "dt", "initial_state"})
#: errors the base motion's evaluation may raise, held like a NaN sea (ValueError covers
#: TwinError and numpy's LinAlgError)
NUMERICAL = (ArithmeticError, ValueError)
#: what a Simulation keeps (`Simulation`'s `keep`)
KEEPS = ("series", "metrics")
#: lane classes by mechanism name (each makes a `Lanes`)
LANES: dict[str, LanesFactory] = {
    "hybrid": HybridLanes,
    "upu3up": PlatformLanes,
    "upr4": PlatformLanes,
}


@dataclass
class _Block:
    """Base motion for steps `start` … `start + steps` of every lane.

    Attributes:
        start: the first step.
        poses: (N, steps + 1, 6) finite base poses [m, rad].
        bad: (N, steps + 1) samples that were not finite (held).
    """

    start: int
    poses: np.ndarray
    bad: np.ndarray

    @property
    def steps(self) -> int:
        return self.poses.shape[1] - 1


class Simulation:
    """Scenarios being stepped together: states, time and history as arrays, one lane each.

    Args:
        scenarios: a `Scenario` (or a dict of its fields, validated), or a sequence of them:
            one mechanism and one dt for all; each lane runs to the longest duration and its
            result keeps its own.
        history_limit: keep only the newest samples (a live session's ring buffer); None
            keeps the whole run.
        engine: "auto" (numba when it imports), "numba", or "python" (the same kernels
            interpreted: slow, for machines without numba; the same numbers).
        keep: "series" (the history, results with series and metrics) or "metrics" (results
            with metrics alone and series {}: a sweep's or a workability run's lanes, issue 28
            item 6). The metrics are then reduced as each chunk is stepped (`HybridReduction`,
            `PlatformReduction`: the same numbers as the whole series', to the bit or to
            rounding) and the history holds the newest sample alone, so memory does not grow
            with the run's length; the records are still computed, as the metrics are reduced
            from them.
        motions: makes the lanes' base motions from their scenarios, here and on a sea change
            (None: `BaseMotion.many`, the sea or a stored log); a live session following a
            live stream passes its own (`twin.sim.motion_live.stream_motions`). A motion's
            `horizon` bounds how many steps are sampled ahead.

    Raises:
        ValueError: a bad scenario (naming the field), none, or lanes that differ in mechanism
            or dt.
    """

    def __init__(
        self,
        scenarios: Scenario | dict | Sequence[Scenario | dict],
        history_limit: int | None = None,
        engine: str = "auto",
        keep: str = "series",
        motions: Callable[[Sequence[Scenario]], list[BaseMotion]] | None = None,
    ) -> None:
        if keep not in KEEPS:
            raise TwinError(f"keep: unknown {keep!r}; allowed: {list(KEEPS)}")
        if keep == "metrics" and history_limit:
            raise TwinError("keep='metrics' keeps no series: history_limit (a live session's "
                            "ring of samples) goes with keep='series'")  # fmt: skip
        if isinstance(scenarios, Scenario | dict):
            scenarios = [scenarios]
        self.scenarios = [s if isinstance(s, Scenario) else Scenario(**s) for s in scenarios]
        if not self.scenarios:
            raise TwinError("Simulation needs at least one scenario; got none")
        first = self.scenarios[0]
        for i, s in enumerate(self.scenarios[1:], 1):
            if (s.mechanism, s.dt) != (first.mechanism, first.dt):
                raise TwinError(
                    f"scenario {i}: lanes of one Simulation share mechanism and dt; got "
                    f"{s.mechanism!r} at dt = {s.dt} beside {first.mechanism!r} at {first.dt}"
                )
        self.compiled = use_numba(engine)
        self.dt = first.dt
        self.n_lanes = len(self.scenarios)
        self.n_steps = max(round(s.duration / s.dt) for s in self.scenarios)
        self.k = 0
        self.mechanism = MECHANISMS[first.mechanism]()
        self._motions = motions
        self.base_motions = self._motions_of(self.scenarios)
        self._block_size = min([
            LIVE_BLOCK if history_limit else min(MAX_BLOCK, max(16, BLOCK // self.n_lanes)),
            *(m.horizon for m in self.base_motions if m.horizon is not None),
        ])  # fmt: skip
        x0 = np.stack(
            [
                self.mechanism.working_state if s.initial_state is None else s.initial_state
                for s in self.scenarios
            ]
        ).astype(float)
        # every lane sits on its mechanism's mount: the pose at rest is computed once
        at_rest = np.broadcast_to(self.base_motions[0].mount.pose(np.zeros((1, 6)))[0],
                                  (self.n_lanes, 6))  # fmt: skip
        block = self._sample(self.base_motions, 0, at_rest)
        T_IB0 = pose_to_transform(block.poses[:, 0])
        self.lanes: Lanes = LANES[first.mechanism](self.mechanism, x0, T_IB0, self.compiled)
        self._block = block
        self.x = x0.copy()
        self.prm, self.memory = self._pack(self.scenarios, self._block, 0)
        self._run = runner(self.lanes.kind, self.compiled, self.n_lanes)
        self.faults = [FaultLog() for _ in self.scenarios]
        self.keep = keep
        self._reduction: Reduction | None = None
        if keep == "metrics":
            ends = np.array([round(s.duration / s.dt) + 1 for s in self.scenarios])
            modes = [s.joint_limits for s in self.scenarios]
            self._reduction = self.lanes.reduction(ends, modes)
            # the series' fault counts (`series_faults`), summed chunk by chunk
            self._limited = [dict.fromkeys(("joint_limit", "singular"), 0) for _ in ends]
        # a batch run keeps every sample, unless its metrics are reduced as it goes
        self._keep_all = history_limit is None and self._reduction is None
        # A batch run grows its history to the whole run at its first chunk, unless that chunk
        # is the whole run: then its arrays become the history (`_chunk`).
        self.history = History(history_limit or 1)
        first_row = self.lanes.initial_records(self._block.poses[:, :1], self.x)
        self.history.append({"t": np.zeros((self.n_lanes, 1)), **first_row})

    # -- readers -----------------------------------------------------------------------------
    @property
    def scenario(self) -> Scenario:
        """Lane 0's scenario (the only one of a one-lane Simulation)."""
        return self.scenarios[0]

    @property
    def base_motion(self) -> BaseMotion:
        """Lane 0's base motion."""
        return self.base_motions[0]

    @property
    def held(self) -> np.ndarray:
        """(N, 4, 4) ᴵT*: each lane's held inertial pose, fixed at t = 0."""
        return self.lanes.held

    @property
    def t(self) -> float:
        """[s] simulated time of the latest sample."""
        return self.k * self.dt

    @property
    def done(self) -> bool:
        return self.k >= self.n_steps

    def latest(self, lane: int = 0) -> dict[str, np.ndarray]:
        """The newest sample's record of a lane (copies)."""
        return self._select(self.history.latest(lane), lane)

    def series(self, lane: int = 0) -> dict[str, np.ndarray]:
        """A lane's history, (T, ...) per key, oldest first (copies)."""
        return self._select(self.history.series(lane), lane)

    def _select(self, record: dict[str, np.ndarray], lane: int) -> dict[str, np.ndarray]:
        """The keys a lane's planner has: another family's diagnostics are left out."""
        mine = self.lanes.keys(self.scenarios[lane].planner_name)
        every = self.lanes.diagnostics
        return {k: v for k, v in record.items() if k in mine or k not in every}

    def metrics(self, series: dict[str, np.ndarray], lane: int = 0) -> dict[str, Any]:
        """A lane's metrics over a series of it (`series(lane)`), its fault counts included."""
        return self.metrics_later(lane)(series)

    def metrics_later(self, lane: int = 0) -> Callable[[dict[str, np.ndarray]], dict[str, Any]]:
        """`metrics` as of now, to call later on a series taken now: the lane's joint-limit
        mode and fault counts are copied here, so a reader that copies the series under its
        lock (`LiveSession.snapshot`) computes the metrics after releasing it with counts
        that match that series, however far the loop has stepped meanwhile."""
        log = self.faults[lane]
        counts, holds = {flag_name(f): log.counts[flag_name(f)] for f in Fault}, log.holds
        lanes, joint_limits = self.lanes, self.scenarios[lane].joint_limits

        def compute(series: dict[str, np.ndarray]) -> dict[str, Any]:
            return with_faults(lanes.metrics(series, lane, joint_limits), series, counts, holds)

        return compute

    def result(self, lane: int = 0) -> SimulationResult:
        """A lane's result: its scenario, its series up to its own duration, its metrics (with
        keep="metrics", its metrics alone: `results()[lane]`)."""
        if self.keep == "metrics":
            return self.results()[lane]
        series = self._result_series(lane)
        return SimulationResult(self.scenarios[lane], series, self.metrics(series, lane))

    def _result_series(self, lane: int) -> dict[str, np.ndarray]:
        """A lane's series for its result, up to its own duration while every sample is held.

        A finished batch run's series are views of its history, which has room for every
        sample and so never overwrites one; a live session's, or a run's midway, are copies."""
        views = self._keep_all and self.done
        series = self._select(self.history.series(lane, copy=not views), lane)
        if self.history.complete:
            scenario = self.scenarios[lane]
            end = round(scenario.duration / scenario.dt) + 1
            series = {k: v[:end] for k, v in series.items()}
        return series

    def results(self) -> list[SimulationResult]:
        """Every lane's result, in order, each equal to `result(lane)`: the metrics of all lanes
        are reduced in one call over the history's arrays in place (`lanes.metrics_lanes`).
        With keep="metrics", their metrics alone (series {}), at the end of the run.

        Raises:
            TwinError: keep="metrics" before the run's end (its sums are not complete)."""
        if self.keep == "metrics" and not self.done:
            raise TwinError(f"results: a Simulation keeping metrics alone has them at the end "
                            f"of its run; it is at step {self.k} of {self.n_steps}")  # fmt: skip
        if self._reduction is not None:
            return [
                SimulationResult(s, {}, with_fault_counts(m, self._limited[i],
                                                          self.faults[i].counts,
                                                          self.faults[i].holds))
                for i, (s, m) in enumerate(zip(self.scenarios, self._reduction.results(),
                                               strict=True))
            ]  # fmt: skip
        if not self.history.complete:  # a wrapped ring: a lane's samples do not start at slot 0
            return [self.result(i) for i in range(self.n_lanes)]
        series = [self._result_series(i) for i in range(self.n_lanes)]
        ends = np.array([len(x["t"]) for x in series])
        modes = [s.joint_limits for s in self.scenarios]
        reduced = self.lanes.metrics_lanes(self.history.data, ends, modes)
        return [
            SimulationResult(s, x,
                             with_faults(m, x, self.faults[i].counts, self.faults[i].holds))
            for i, (s, x, m) in enumerate(zip(self.scenarios, series, reduced, strict=True))
        ]  # fmt: skip

    def _reduce(self, records: dict[str, np.ndarray], start: int) -> None:
        """keep="metrics": add samples start … start + S − 1 of records (N, S, ...) to every
        lane's metrics (`HybridReduction`, `PlatformReduction`) and to its series' fault
        counts (`series_faults` of the lane's samples before its end, as its whole series
        would count them)."""
        assert self._reduction is not None
        self._reduction.add(records, start)
        self._count_limited(records, start)

    def _count_limited(self, records: dict[str, np.ndarray], start: int) -> None:
        """keep="metrics": add samples start … start + S − 1 of records (N, S, ...), each
        lane's before its end, to its series' fault counts (`series_faults`)."""
        assert self._reduction is not None
        size = records["t"].shape[1]
        for lane, end in enumerate(self._reduction.ends.tolist()):
            count = min(max(end - start, 0), size)
            if count:
                mine = self._select({k: v[lane, :count] for k, v in records.items()}, lane)
                for name, n in series_faults(mine).items():
                    self._limited[lane][name] += n

    # -- stepping ----------------------------------------------------------------------------
    def step(self) -> dict[str, np.ndarray]:
        """Advance one dt; returns lane 0's new record."""
        self.advance(1)
        return self.latest()

    def advance(self, n: int) -> int:
        """Advance up to n steps (fewer at the end of the run); returns the steps taken."""
        taken = 0
        while taken < n and not self.done:
            local = self.k - self._block.start
            if local >= self._block.steps:
                last = self._block.poses[:, -1]
                self._block = self._sample(self.base_motions, self.k, last)
                local = 0
            m = min(n - taken, self._block.steps - local, self.n_steps - self.k)
            self._chunk(local, m)
            taken += m
        return taken

    def run(self, progress: bool = False) -> SimulationResult:
        """Step to the end of the run; lane 0's result (`results()` has every lane's)."""
        with tqdm(total=self.n_steps - self.k, disable=not progress, unit="step") as bar:
            while not self.done:
                bar.update(self.advance(self._block_size))
        return self.result()

    def _chunk(self, local: int, m: int) -> None:
        """Run the kernel over m steps from the block's step `local`, record them.

        A batch run stepped in one chunk (the usual: up to MAX_BLOCK steps of a part of
        MAX_LANES lanes) records its start with it, and the chunk's arrays (states, diagnostics,
        records) become its history as they are: nothing is copied."""
        N, block = self.n_lanes, self._block
        whole = self._keep_all and self.history.count == 1 and m == self.n_steps
        first = 0 if whole else 1
        xs = np.empty((N, m + 1, self.x.shape[1]))
        xs[:, 0] = self.x
        diag = np.zeros((N, m + 1, self.lanes.n_diagnostics))
        faults = np.zeros((N, m), dtype=np.int64)
        out = scratch("targets", (N, m + 1, layout.N_TARGET))
        targets = self.targets(block, local, m, out, end=True)
        self.lanes.run(self._run, xs, targets, self.prm, self.memory, self.dt, diag, faults, first)
        if self.k == 0:  # no step has been taken at t = 0: the first step's diagnostics repeat
            diag[:, 0] = diag[:, 1]
        poses = block.poses[:, local : local + m + 1]
        faults |= np.where(
            block.bad[:, local : local + m] | block.bad[:, local + 1 : local + m + 1],
            layout.FAULT_BASE_MOTION,
            0,
        )
        t = (self.k + np.arange(first, m + 1)) * self.dt  # exact multiples, chunk-independent
        newest = self._reduce_as_recorded(poses, xs, diag, t)
        if newest is not None:  # the history's one slot takes the newest sample (`latest`)
            self.history.append(newest)
            self._advance_to(xs, t, faults, m)
            return
        records = self.lanes.records(poses, xs, diag, self.dt, first)
        held = hold_nonfinite(records, self.history.newest())
        faults |= np.where(held[:, -m:], layout.FAULT_PLANNER, 0)  # not the start's
        if whole:  # "t" first, as the history's keys have been since sample 0
            self.history.adopt({"t": np.repeat(t[None], N, axis=0), **records})
        else:
            records["t"] = np.broadcast_to(t, (N, m))
            if self._keep_all:
                self.history.reserve(self.n_steps + 1)
            if self.k == 0:
                step_keys = {"limit_scale", "clipped", "saturated"}
                self.history.backfill_first(records, self.lanes.diagnostics | step_keys)
            if self._reduction is not None:
                if self.k == 0:  # sample 0, its step's diagnostics backfilled just above
                    self._reduce(self.history.data, 0)
                self._reduce(records, self.k + 1)
            self.history.append(records)
        self._advance_to(xs, t, faults, m)

    def _advance_to(self, xs: np.ndarray, t: np.ndarray, faults: np.ndarray, m: int) -> None:
        """End a chunk of m steps: its last state xs[:, -1] the lanes' state, its faults (N,
        m) at its samples' times t [s] into their logs."""
        self.x = xs[:, -1].copy()
        for lane in np.flatnonzero(faults.any(axis=1)):
            self.faults[lane].add_chunk(t[-m:], faults[lane])
        self.k += m

    def _reduce_as_recorded(
        self, poses: np.ndarray, xs: np.ndarray, diag: np.ndarray, t: np.ndarray
    ) -> dict[str, np.ndarray] | None:
        """keep="metrics" on lanes that reduce as they record (`ReducingLanes`: the hybrid
        system's): the chunk's samples 1 … m (at times t [s]), after sample 0 on the first
        chunk, added to the metrics as each is recorded (no record array of the chunk is made)
        and to the series' fault
        counts. Returns the newest sample's records (N, 1, ...), for the history; None, with
        nothing added, where the run keeps a series, or a state, diagnostic or record is not
        finite (the chunk is then recorded whole and held, `hold_nonfinite`)."""
        lanes = self.lanes
        if self._reduction is None or not isinstance(lanes, ReducingLanes):
            return None
        if not (np.isfinite(xs).all() and np.isfinite(diag).all() and np.isfinite(poses).all()):
            return None
        states = lanes.state_records(poses, xs, diag)
        states["t"] = np.broadcast_to(t, (self.n_lanes, len(t)))
        before = self._reduction.acc.copy()
        if self.k == 0:  # sample 0 first, its step's diagnostics backfilled (as `_chunk`)
            step_keys = {"limit_scale", "clipped", "saturated"}
            self.history.backfill_first(states, lanes.diagnostics | step_keys)
            self._reduction.add(self.history.data, 0)
        newest = lanes.reduce(self._reduction, t, self.k + 1)
        if newest is None:
            self._reduction.acc[:] = before
            return None
        if self.k == 0:
            self._count_limited(self.history.data, 0)
        self._count_limited(states, self.k + 1)
        return {key: values[:, -1:] for key, values in states.items()} | newest

    # -- changes -----------------------------------------------------------------------------
    def update(
        self, changes: dict[str, Any], lanes: Sequence[dict[str, Any]] | None = None
    ) -> set[str]:
        """Apply changed scenario fields to every lane from the next step on, without a reset.

        Everything is validated and built before anything changes, so a bad value raises a
        ValueError naming the field and changes nothing. A sea change re-synthesises the sea
        from the current step (the held pose stays; the planner's closed loop absorbs the jump
        in base motion); a planner or parameter change rebuilds and repacks the planner at the
        current state; `joint_limits` switches holding at the limits on or off.

        Args:
            changes: fields every lane takes.
            lanes: per lane, fields it takes over `changes` (a comparison lane keeping its own
                planner, say); None: none.

        Returns:
            The names of the fields whose value changed (in any lane).

        Raises:
            ValueError: a bad value, or a field in `RESTART_FIELDS` (start a new Simulation).
        """
        own = [{}] * self.n_lanes if lanes is None else list(lanes)
        if len(own) != self.n_lanes:
            raise TwinError(f"lanes: {len(own)} given for {self.n_lanes} lanes")
        new = [
            Scenario(**{**s.model_dump(), **changes, **mine})
            for s, mine in zip(self.scenarios, own, strict=True)
        ]
        changed = {
            k for k in set(changes).union(*own) for n, s in zip(new, self.scenarios, strict=True)
            if getattr(n, k) != getattr(s, k)
        }  # fmt: skip
        if changed & RESTART_FIELDS:
            raise TwinError(
                f"{sorted(changed & RESTART_FIELDS)} cannot change while running; start a new "
                f"simulation (fields needing a restart: {sorted(RESTART_FIELDS)})"
            )
        if self._reduction is not None and "duration" in changed:
            raise TwinError("duration cannot change in a Simulation keeping metrics alone "
                            "(keep='metrics': each lane's sums end where it started to end); "
                            "start a new simulation")  # fmt: skip
        n_steps = max(self.n_steps if "duration" not in changed else 0,
                      max(round(s.duration / s.dt) for s in new))  # fmt: skip
        base_motions, block = self.base_motions, self._block
        local = self.k - block.start
        if changed & SEA_FIELDS or local >= block.steps:  # a new sea, or the block is used up
            base_motions = self._motions_of(new) if changed & SEA_FIELDS else base_motions
            now = block.poses[:, min(local, block.steps)]
            block = self._sample(base_motions, self.k, now, n_steps)
        replan = bool(changed - SEA_FIELDS - {"duration", "joint_limits"})
        prm, memory = self.prm.copy(), self.memory.copy()
        if replan:
            prm, memory = self._pack(new, block, self.k - block.start)
        as_records(prm, layout.COMMON_PARAMETERS)["hold"] = [
            float(s.joint_limits == "hold") for s in new
        ]
        # nothing below raises
        self.scenarios, self.base_motions, self._block = new, base_motions, block
        self.prm, self.memory, self.n_steps = prm, memory, n_steps
        if self._keep_all:
            self.history.reserve(n_steps + 1)
        return changed

    # -- internals ---------------------------------------------------------------------------
    def _motions_of(self, scenarios: Sequence[Scenario]) -> list[BaseMotion]:
        """The lanes' base motions: `motions`' if given, else `BaseMotion.many`'s."""
        return (self._motions or BaseMotion.many)(scenarios)

    def _pack(
        self, scenarios: Sequence[Scenario], block: _Block, local: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """Every lane's planner built, reset at the current state and packed: (prm, memory)."""
        targets = self.targets(block, local, 1)[:, 0]
        rows = [self.lanes.pack(i, s, self.x[i], targets[i]) for i, s in enumerate(scenarios)]
        return np.stack([r[0] for r in rows]), np.stack([r[1] for r in rows])

    def _sample(
        self,
        base_motions: Sequence[BaseMotion],
        start: int,
        last_good: np.ndarray,
        n_steps: int | None = None,
    ) -> _Block:
        """Base samples for steps start … start + block (one more for the last step's end),
        each finite: a sample that is not, or a sea that fails to evaluate, holds the last
        good pose before it (`hold_invalid`; `last_good` (N, 6) for the first). The block ends
        at the run's end (`n_steps`, default the current one)."""
        end = self.n_steps if n_steps is None else n_steps
        steps = max(1, min(self._block_size, end - start))
        try:
            sampled = BaseMotion.uniform_poses(
                base_motions, 0.0, self.dt, steps + 1, self.compiled, first=start
            )
        except NUMERICAL:
            sampled = np.full((len(base_motions), steps + 1, 6), np.nan)
        poses, bad = hold_invalid(sampled, last_good)
        return _Block(start, poses, bad)

    def targets(
        self, block: _Block, local: int, m: int, out: np.ndarray | None = None, end: bool = False
    ) -> np.ndarray:
        """The held targets (N, m + end, 18) of the block's steps local … local + m − 1, and
        with `end` the desired pose at the last one's end (`held_targets` of its poses; a
        target depends only on its step's pose and the next), into `out` when given."""
        poses = block.poses[:, local : local + m + 1]
        return held_targets(self.lanes.held, poses, self.dt, self.compiled, out, end)


def with_faults(
    metrics: dict[str, Any], series: dict[str, np.ndarray], counts: Mapping[str, int], holds: int
) -> dict[str, Any]:
    """A lane's metrics with its fault counts added: held steps and their kinds from its
    fault log (`counts` per kind name, `holds` steps held), limited and damped samples from
    its series (`series_faults`)."""
    return with_fault_counts(metrics, series_faults(series), counts, holds)


def with_fault_counts(
    metrics: dict[str, Any], limited: Mapping[str, int], counts: Mapping[str, int], holds: int
) -> dict[str, Any]:
    """`with_faults` with the series' counts given (`series_faults`'s, `limited`): a run that
    keeps no series sums them chunk by chunk."""
    metrics["faults"] = holds
    metrics["tracking_diverged"] = tracking_diverged(metrics)
    metrics["fault_counts"] = {
        **{flag_name(f): counts[flag_name(f)] for f in Fault if f in HOLDS},
        **limited,
        "infeasible": counts["infeasible"],
        "tracking_diverged": int(metrics["tracking_diverged"]),
    }
    return metrics


def simulate(
    scenario: Scenario | dict, progress: bool = False, engine: str = "auto"
) -> SimulationResult:
    """Run a scenario to completion; see `SimulationResult` for `.series` and `.metrics`."""
    return Simulation(scenario, engine=engine).run(progress=progress)


#: most scenarios `simulate_many` steps together in one Simulation. The compiled runners go
#: lane by lane, so lanes gain nothing from sharing one Simulation beyond its fixed cost (a few
#: ms), while parts this small run a 200 s run in one chunk, with temporaries small enough
#: that the allocator hands one part's memory to the next instead of fresh pages the kernel
#: must zero, and spread evenly over the threads. Measured on 2 cores, 256 lanes of the
#: reference run, interleaved: parts of 16 took 0.83× the time of two parts of 128, parts of
#: 8 0.86×, of 32 0.88× (docs/simulation.md).
MAX_LANES = 16


def simulate_many(
    scenarios: Iterable[Scenario | dict],
    *,
    progress: bool = False,
    engine: str = "auto",
    keep: str = "series",
) -> list[SimulationResult]:
    """Run many scenarios: the same results as `[simulate(s) for s in scenarios]` (tested),
    stepped together in lanes — scenarios of one mechanism, dt and number of steps share a
    `Simulation`.

    A group larger than MAX_LANES runs as near-equal parts of at most MAX_LANES lanes, one
    `Simulation` each. With several numba threads the parts run on threads of their own, each
    part's runners serial: the runners release the GIL, so one part's Python bookkeeping
    (sampling set-up, copying into the history, results) overlaps the other parts' compiled
    steps, where lanes in one Simulation would leave all but one core idle while it runs. A
    lane's numbers do not depend on which lanes it runs beside.

    Args:
        scenarios: `Scenario`s or dicts of their fields (validated).
        progress: show a tqdm bar over all steps.
        engine: as `Simulation`'s.
        keep: as `Simulation`'s: "metrics" for lanes whose series nobody reads (a sweep's, a
            workability run's): the same metrics, memory flat in the run's length.

    Returns:
        One `SimulationResult` per scenario, in order (series {} with keep="metrics").

    Raises:
        ValueError: a bad scenario (naming the field) or an unknown or unavailable engine.
    """
    checked = [s if isinstance(s, Scenario) else Scenario(**s) for s in scenarios]
    threads = numba_threads() if use_numba(engine) else 1  # an unknown engine fails here
    groups: dict[tuple, list[int]] = {}
    for i, s in enumerate(checked):
        groups.setdefault((s.mechanism, s.dt, round(s.duration / s.dt)), []).append(i)
    parts = sorted(
        (part for members in groups.values() for part in lane_parts(members, threads)),
        key=len,
        reverse=True,
    )
    results: list[SimulationResult | None] = [None] * len(checked)
    total = sum(round(s.duration / s.dt) for s in checked)
    lock = threading.Lock()
    with tqdm(total=total, disable=not progress, unit="step", unit_scale=True) as bar:

        def run(lanes: list[int]) -> None:
            sim = Simulation([checked[i] for i in lanes], engine=engine, keep=keep)
            while not sim.done:
                steps = sim.advance(sim._block_size) * len(lanes)
                with lock:
                    bar.update(steps)
            for i, result in zip(lanes, sim.results(), strict=True):
                results[i] = result

        def run_serial(lanes: list[int]) -> None:
            with limit_threads(1):
                run(lanes)

        if threads > 1 and len(parts) > 1:
            pool = ThreadPoolExecutor(threads, thread_name_prefix="lanes")
            try:
                list(pool.map(run_serial, parts))  # re-raises a part's error here
            finally:  # on an error or Ctrl-C the parts not yet started are dropped
                pool.shutdown(wait=True, cancel_futures=True)
        else:
            for lanes in parts:
                run(lanes)
    return results  # type: ignore[return-value]  # every part filled its lanes


#: fewest lanes in a part of the guided schedule (`lane_parts`)
MIN_LANES = 2


def lane_parts(members: list[int], threads: int = 1) -> list[list[int]]:
    """A group's lanes as parts of at most MAX_LANES lanes, in order.

    On one thread, near-equal parts. On several, guided self-scheduling (Polychronopoulos and
    Kuck 1987, OpenMP's `guided` schedule): each part takes the remaining lanes over the
    threads, within [MIN_LANES, MAX_LANES], so the last parts shrink (256 lanes on 2 threads:
    fifteen of 16, then 8, 4, 2, 2) and the threads finish together, where the last of
    sixteen equal parts kept one thread busy for a whole part while the other waited: 1.86 of
    2 cores busy. Measured on 2 cores, 256 reference lanes, paired runs: 0.96× the time of
    equal parts (median of 16 pairs; a minimum of 1 lane, 1.00×; of 4, 0.99×)."""
    if threads <= 1:
        n = -(-len(members) // MAX_LANES)
        return [part.tolist() for part in np.array_split(np.array(members), n)]
    parts, start = [], 0
    while start < len(members):
        size = -(-(len(members) - start) // threads)
        size = max(MIN_LANES, min(MAX_LANES, size))
        parts.append(members[start : start + size])
        start += size
    return parts


#: the lanes of the Simulations `warm` steps (0.1 s each), in two shares that compile
#: different runners in about equal time (`warm_in_processes`; docs/performance.md): the
#: hybrid system's differential and allocation runner, with the sea, targets, records and
#: metrics, serial then parallel, then the 3UPU_UP's own object-level loops (its frame, a
#: `LaneBatch` its records call; the platforms' runner loads from the cache); and the
#: platforms' runner, serial then parallel, then the hybrid system's qp runner, whose records
#: and metrics then load from the cache share 0 has written meanwhile (compiled twice if the
#: qp lane set came first). A lane set of two compiles a runner's parallel form; each lane set
#: runs keeping its series and keeping its metrics alone (`KEEPS`: the one records runner
#: keeps or reduces as it records, `twin.sim.kernels.records.run_hybrid_records`; the
#: reductions' `run_*_add`).
WARM_SHARES: tuple[tuple[tuple[dict[str, str], ...], ...], ...] = (
    (
        ({"planner": "mtmp"},),
        ({"planner": "mtmp"}, {"planner": "dwa"}),
        ({"mechanism": "upu3up"},),
    ),
    (
        ({"mechanism": "upr4"},),
        ({"mechanism": "upr4"}, {"mechanism": "upr4", "planner": "ik"}),
        ({"planner": "qp"},),
        ({"planner": "qp"}, {"planner": "qp"}),
    ),
)


def warm_label(lanes: tuple[dict[str, str], ...]) -> str:
    """'hybrid mtmp', 'hybrid mtmp + dwa', 'upr4 pid', …: one lane set of `WARM_SHARES`, as a
    warm-up's progress names it."""
    names = []
    for lane in lanes:
        mechanism = lane.get("mechanism", "hybrid")
        names.append(f"{mechanism} {lane.get('planner', DEFAULT_PLANNER[mechanism])}")
    return " + ".join(names)


#: lane sets in all shares: the `total` of a warm-up's progress
WARM_TOTAL = sum(len(share) for share in WARM_SHARES)

#: `progress(label)`: called as each lane set of a warm-up is done
WarmProgress = Callable[[str], None]


def warm(
    engine: str = "auto",
    shares: Sequence[int] | None = None,
    progress: WarmProgress | None = None,
) -> float:
    """Compile every kernel runner, serial and parallel, or load it from numba's disk cache
    (minutes on a first start, a fraction of a second after): a few steps of every planner
    family of every kind of mechanism. A server calls it before serving, a worker before its
    first run; `warm_in_processes` splits it over processes.

    Args:
        engine: as `Simulation`'s.
        shares: indices into `WARM_SHARES` to step; None: all.
        progress: called with `warm_label(lanes)` as each lane set is done.

    Returns:
        [s] the wall time it took.

    Raises:
        ValueError: a share index outside 0 … len(WARM_SHARES) − 1.
    """
    chosen = range(len(WARM_SHARES)) if shares is None else list(shares)
    wrong = [i for i in chosen if not 0 <= i < len(WARM_SHARES)]
    if wrong:
        raise ValueError(f"warm: shares {wrong} unknown; they are 0-{len(WARM_SHARES) - 1}")
    start = time.perf_counter()
    for i in chosen:
        for lanes in WARM_SHARES[i]:
            for keep in KEEPS:  # "metrics": the runners that reduce as they step
                simulation = Simulation([{"duration": 0.1, **lane} for lane in lanes],
                                        engine=engine, keep=keep)  # fmt: skip
                simulation.run()  # lane 0's result: the one-lane (serial) metrics runner
                simulation.results()  # every lane's: the parallel one where there are several
            if progress is not None:
                progress(warm_label(lanes))
    return time.perf_counter() - start


def _warm_group(shares: list[int], done: Any) -> None:
    """Shares of `warm_in_processes` in a process of their own, putting each finished lane
    set's label on `done`."""
    warm("auto", shares, progress=done.put)


#: [s] with numba's cache filled, how long this process's first share may take before the
#: others go to processes of their own (a cache gone stale compiles): loading every kernel
#: from the cache takes 1-6 s, 13 s at load 13, compiling share 0 40-80 s. With the cache
#: empty they go at once.
SPAWN_AFTER = 30.0


def kernel_cache_filled() -> bool:
    """Whether numba's disk cache holds compiled kernels of this package (any index file):
    where it does not, a warm-up compiles and its other shares go to processes at once."""
    import numba

    # numba sets its config attributes at import (numba.core.config), unseen by mypy
    cache_dir: str = numba.config.CACHE_DIR  # type: ignore[attr-defined]
    root = Path(cache_dir) if cache_dir else Path(__file__).parents[1]
    return any(root.rglob("*.nbi"))


def warm_in_processes(processes: int | None = None, progress: WarmProgress | None = None) -> float:
    """`warm` with its shares spread over processes that compile at once: share 0 in this one
    and, if numba's cache is empty (or share 0 still compiles after `SPAWN_AFTER` s), the
    others in new processes (numba
    writes what each compiles to its disk cache, where this process then loads it). On a first
    start with 2 cores, the time of the costliest share instead of the sum; with the cache
    full, `warm`'s second: no process is started.

    Args:
        processes: 1 … len(WARM_SHARES) processes, this one included (1: `warm` here); None:
            one per core, at most one per share.
        progress: called in this process with each lane set's label as it is done.

    Returns:
        [s] the wall time it took.

    Raises:
        ValueError: processes outside 1 … len(WARM_SHARES).
    """
    import os

    if processes is None:
        processes = max(1, min(len(WARM_SHARES), os.cpu_count() or 1))
    if not 1 <= processes <= len(WARM_SHARES):
        raise ValueError(f"warm: {processes} processes; 1-{len(WARM_SHARES)} (one per share)")
    if processes == 1:
        return warm(progress=progress)
    start = time.perf_counter()
    shares = list(range(len(WARM_SHARES)))
    groups = [shares[i::processes] for i in range(processes)]
    relay = _WarmRelay(groups, progress)
    relay.thread.start()
    rest = [share for group in groups[1:] for share in group]
    try:
        own = warm("auto", groups[0], progress=relay.report)
        relay.first_done.set()
        # what the processes compile loads from the cache once they are done: waited for (as
        # long as share 0 took at most), as a runner still compiling there would compile here
        # too, twice at once (measured: 137 s against 104 s); past that, or without processes,
        # the rest compiles here too, so the slower of two copies never holds the start-up
        relay.wait_spawned(own)
        warm("auto", rest, progress=relay.report)
    finally:
        relay.close()
    return time.perf_counter() - start


class _WarmRelay:
    """The shares of `warm_in_processes` beyond this process's first group (`groups[1:]`): a
    thread that, after `SPAWN_AFTER` s of share 0 (at once with numba's cache empty), starts
    them in processes of their own and relays their progress. `report` calls `progress` once
    per lane set, whether it was done here or there; `close` stops what the thread started."""

    def __init__(self, groups: list[list[int]], progress: WarmProgress | None) -> None:
        self.groups, self.progress = groups, progress
        self.lock = threading.Lock()
        self.first_done, self.decided = threading.Event(), threading.Event()
        self.spawned: dict[str, Any] = {}
        self.reported: set[str] = set()
        self.thread = threading.Thread(target=self.relay, name="twin-warm", daemon=True)

    def report(self, label: str) -> None:
        """`progress`, once per lane set (a share may be done here and in a process)."""
        with self.lock:
            if label in self.reported or self.progress is None:
                return
            self.reported.add(label)
            self.progress(label)

    def relay(self) -> None:
        """After `SPAWN_AFTER` s of share 0, the other shares in processes of their own."""
        import multiprocessing

        spawned = self.spawned
        try:
            if self.first_done.wait(SPAWN_AFTER if kernel_cache_filled() else 0.0):
                return  # loaded from the cache: no process needed
            # spawned, not forked: a fork would copy this process's numba and thread state
            context = multiprocessing.get_context("spawn")
            spawned["manager"] = manager = context.Manager()
            spawned["done"] = done = manager.Queue()
            # one process per group but this process's own
            spawned["pool"] = pool = context.Pool(len(self.groups) - 1)
            spawned["result"] = pool.starmap_async(
                _warm_group, [(group, done) for group in self.groups[1:]]
            )
        finally:
            self.decided.set()
        while (label := done.get()) is not None:
            self.report(label)

    def wait_spawned(self, timeout: float) -> None:
        """Once this process's first group is done: wait up to `timeout` s for the processes'
        shares, if processes were started."""
        self.decided.wait()
        if "result" in self.spawned:
            self.spawned["result"].wait(timeout)

    def close(self) -> None:
        """Once this process's shares are done (or failed): end the processes, the relay
        thread and the manager, if they were started."""
        self.first_done.set()
        self.decided.wait()
        spawned = self.spawned
        if "pool" in spawned:
            spawned["pool"].terminate()  # numba writes its cache files whole (os.replace)
            spawned["pool"].join()
            spawned["done"].put(None)
            self.thread.join()
        if "manager" in spawned:
            spawned["manager"].shutdown()

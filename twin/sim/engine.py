"""The simulation engine: `Simulation` steps a scenario, `simulate` runs it to the end.

`simulate(s)` is `Simulation(s)` stepped to the end, so the live server's stepping and a
batch run give the same numbers by construction (tested).

A step never raises for numerical reasons and never records NaN: a non-finite base sample is
replaced by the last finite one, a planner or kinematics failure holds the mechanism for the
step, and each such step is flagged (`twin.sim.faults`) and counted in the metrics.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np
from tqdm import tqdm

from twin.errors import ConvergenceError, TwinError, UnreachableError
from twin.mechanisms import MECHANISMS
from twin.planners import PlannerParameters
from twin.sim.base_motion import BaseMotion, BaseSamples
from twin.sim.faults import HOLDS, Fault, FaultLog, finite_record, hold_invalid, series_faults
from twin.sim.hybrid_rig import HybridRig
from twin.sim.metrics import hybrid_metrics
from twin.sim.platform_rig import PlatformRig, platform_metrics
from twin.sim.result import SimulationResult
from twin.sim.scenario import Scenario

#: samples of base motion evaluated at once (vectorised over the wave components)
CHUNK = 256


def _hybrid(scenario: Scenario, mechanism: Any, parameters: PlannerParameters, state: np.ndarray):
    rig = HybridRig(mechanism, scenario.planner, parameters, state, scenario.dt)
    return rig, lambda series: hybrid_metrics(series, mechanism)


def _platform(scenario: Scenario, mechanism: Any, parameters: PlannerParameters, state: np.ndarray):
    rig = PlatformRig(mechanism, scenario.planner, parameters, state, scenario.dt)
    return rig, lambda series: platform_metrics(series, rig.model)


#: mechanism name → builder of (rig, metrics function)
RIGS: dict[str, Callable] = {"hybrid": _hybrid, "upu3up": _platform, "upr4": _platform}


#: Scenario fields that change the sea: `Simulation.update` re-synthesises it in place.
SEA_FIELDS = frozenset(
    {"sea_state", "hs", "tp", "heading", "spectrum", "gamma", "spreading", "n_components",
     "seed", "regular_waves", "forward_speed"}
)  # fmt: skip
#: Scenario fields that need a new Simulation (a different machine, vessel or clock).
RESTART_FIELDS = frozenset({"mechanism", "vessel", "dt", "initial_state"})
#: errors a step turns into a held, flagged sample instead of raising (ValueError covers
#: TwinError and numpy's LinAlgError)
NUMERICAL = (ArithmeticError, ValueError)


class Simulation:
    """A scenario being stepped: state, time and history.

    Args:
        scenario: a `Scenario` or a dict of its fields (validated).
        history_limit: keep only the newest samples (a live session's ring buffer); None
            keeps all (a batch run).
    """

    def __init__(self, scenario: Scenario | dict, history_limit: int | None = None) -> None:
        self.scenario = scenario if isinstance(scenario, Scenario) else Scenario(**scenario)
        s = self.scenario
        self.base_motion = BaseMotion.of(s)
        self.mechanism = MECHANISMS[s.mechanism]()
        state = (
            self.mechanism.working_state if s.initial_state is None else np.array(s.initial_state)
        )
        parameters = s.parameters()
        self.rig, self._metrics = RIGS[s.mechanism](s, self.mechanism, parameters, state)
        self.dt = s.dt
        self.n_steps = round(s.duration / s.dt)
        self.k = 0
        self.faults = FaultLog()
        self._chunk_start = 0
        self._last_good = self.base_motion.mount.pose(np.zeros((1, 6)))[0]  # the mount at rest
        self._base = self._load_chunk(0)
        self.rig.hold_limits = s.joint_limits == "hold"
        self.history: deque[dict[str, np.ndarray]] = deque(
            [self.rig.reset(self._base)], maxlen=history_limit
        )

    def update(self, changes: dict[str, Any]) -> set[str]:
        """Apply changed scenario fields from the next step on, without a reset.

        The whole new scenario is validated first, so a bad value raises a ValueError naming
        the field and changes nothing. A sea change re-synthesises the sea at the current time
        (the tip target stays; the planner's closed loop absorbs the jump in base motion); a
        planner or parameter change rebuilds the planner at the current state.

        Returns:
            The names of the fields whose value changed.

        Raises:
            ValueError: a bad value, or a field in `RESTART_FIELDS` (start a new Simulation).
        """
        new = Scenario(**{**self.scenario.model_dump(), **changes})
        changed = {k for k in changes if getattr(new, k) != getattr(self.scenario, k)}
        if changed & RESTART_FIELDS:
            raise TwinError(
                f"{sorted(changed & RESTART_FIELDS)} cannot change while running; start a new "
                f"simulation (fields needing a restart: {sorted(RESTART_FIELDS)})"
            )
        # everything that can fail is built before any state changes
        base_motion = BaseMotion.of(new) if changed & SEA_FIELDS else None
        parameters = new.parameters()
        self.scenario = new
        self.n_steps = round(new.duration / new.dt)
        self.rig.hold_limits = new.joint_limits == "hold"
        if base_motion is not None:
            self.base_motion = base_motion
            self._base = self._load_chunk(self.k)
        if changed - SEA_FIELDS - {"duration", "joint_limits"}:
            self.rig.replan(new.planner, parameters, self._base, self.k - self._chunk_start)
        return changed

    def _load_chunk(self, start: int) -> BaseSamples:
        """Base samples for steps start … start + CHUNK (one extra for the step's end), each
        finite: a sample that is not (or a sea that fails to evaluate) holds the last good
        base pose and is marked in `_base_bad`."""
        self._chunk_start = start
        t = (start + np.arange(CHUNK + 1)) * self.dt
        try:
            samples = self.base_motion.sample(t)
        except NUMERICAL:
            nan = np.full((t.size, 6), np.nan)
            samples = BaseSamples(t, nan, np.full((t.size, 4, 4), np.nan))
        samples, self._base_bad, self._last_good = hold_invalid(samples, self._last_good)
        return samples

    @property
    def t(self) -> float:
        """[s] simulated time of the latest sample."""
        return self.k * self.dt

    @property
    def done(self) -> bool:
        return self.k >= self.n_steps

    def step(self) -> dict[str, np.ndarray]:
        """Advance one dt; returns the new sample's record (also appended to `history`).

        Never raises for a numerical fault and never records a non-finite number: see the
        module docstring; the step's `Fault` flags are in `faults` (a `FaultLog`).
        """
        local = self.k - self._chunk_start
        if local >= CHUNK:
            self._base = self._load_chunk(self.k)
            local = 0
        fault, message = Fault(0), ""
        if self._base_bad[local] or self._base_bad[local + 1]:
            fault |= Fault.BASE_MOTION
        try:
            record = self.rig.advance(self._base, local, self.dt)
            fault |= self.rig.fault
        except NUMERICAL as exc:  # hold the mechanism where it is for this step
            failed = isinstance(exc, ConvergenceError | UnreachableError)
            fault |= Fault.KINEMATICS if failed else Fault.PLANNER
            message = f"{type(exc).__name__}: {exc}"
            record = self.rig.hold(self._base, local)
        record, replaced = finite_record(record, self.history[-1])
        if replaced:
            fault |= Fault.PLANNER
        record["t"] = np.float64((self.k + 1) * self.dt)  # exact multiples, chunk-independent
        self.k += 1
        self.faults.add(float(record["t"]), fault, message)
        self.history.append(record)
        return record

    def series(self) -> dict[str, np.ndarray]:
        """The history stacked per key, (N + 1, ...). Planner diagnostics do not exist at t = 0
        (no step taken yet), nor at a step held before the planner answered; there they
        repeat the nearest step's values (the first step's, or the previous one's)."""
        history = list(self.history)
        first: dict[str, np.ndarray] = {}
        for rec in history:
            for key, value in rec.items():
                first.setdefault(key, value)
        columns: dict[str, list[np.ndarray]] = {key: [] for key in history[-1]}
        for key, column in columns.items():
            value = first[key]
            for rec in history:
                value = rec.get(key, value)
                column.append(value)
        return {key: np.stack(column) for key, column in columns.items()}

    def result(self) -> SimulationResult:
        series = self.series()
        metrics = self._metrics(series)
        counts = self.faults.counts
        metrics["faults"] = self.faults.holds
        metrics["fault_counts"] = {
            **{f.name.lower(): counts[f.name.lower()] for f in Fault if f in HOLDS},
            **series_faults(series),
        }
        return SimulationResult(self.scenario, series, metrics)

    def run(self, progress: bool = False) -> SimulationResult:
        """Step to the end of the scenario's duration."""
        with tqdm(total=self.n_steps - self.k, disable=not progress, unit="step") as bar:
            while not self.done:
                self.step()
                bar.update()
        return self.result()


def simulate(scenario: Scenario | dict, progress: bool = False) -> SimulationResult:
    """Run a scenario to completion; see `SimulationResult` for `.series` and `.metrics`."""
    return Simulation(scenario).run(progress=progress)

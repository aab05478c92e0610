"""The simulation engine: `Simulation` steps a scenario, `simulate` runs it to the end.

`simulate(s)` is `Simulation(s)` stepped to the end, so the live server's stepping and a
batch run give the same numbers by construction (tested).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np
from tqdm import tqdm

from twin.errors import TwinError
from twin.mechanisms import MECHANISMS
from twin.planners import PlannerParameters
from twin.sim.base_motion import BaseMotion, BaseSamples
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
        parameters = PlannerParameters(**s.model_dump(include=set(PlannerParameters.model_fields)))
        self.rig, self._metrics = RIGS[s.mechanism](s, self.mechanism, parameters, state)
        self.dt = s.dt
        self.n_steps = round(s.duration / s.dt)
        self.k = 0
        self._chunk_start = 0
        self._base = self._load_chunk(0)
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
        self.scenario = new
        self.n_steps = round(new.duration / new.dt)
        if changed & SEA_FIELDS:
            self.base_motion = BaseMotion.of(new)
            self._base = self._load_chunk(self.k)
        if changed - SEA_FIELDS - {"duration"}:
            parameters = PlannerParameters(
                **new.model_dump(include=set(PlannerParameters.model_fields))
            )
            self.rig.replan(new.planner, parameters, self._base, self.k - self._chunk_start)
        return changed

    def _load_chunk(self, start: int) -> BaseSamples:
        """Base samples for steps start … start + CHUNK (one extra for the step's end)."""
        self._chunk_start = start
        return self.base_motion.sample((start + np.arange(CHUNK + 1)) * self.dt)

    @property
    def t(self) -> float:
        """[s] simulated time of the latest sample."""
        return self.k * self.dt

    @property
    def done(self) -> bool:
        return self.k >= self.n_steps

    def step(self) -> dict[str, np.ndarray]:
        """Advance one dt; returns the new sample's record (also appended to `history`)."""
        local = self.k - self._chunk_start
        if local >= CHUNK:
            self._base = self._load_chunk(self.k)
            local = 0
        record = self.rig.advance(self._base, local, self.dt)
        record["t"] = np.float64((self.k + 1) * self.dt)  # exact multiples, chunk-independent
        self.k += 1
        self.history.append(record)
        return record

    def series(self) -> dict[str, np.ndarray]:
        """The history stacked per key, (N + 1, ...). Planner diagnostics do not exist at t = 0
        (no step taken yet); there they repeat the first step's values."""
        history = list(self.history)
        if len(history) > 1:
            history = [{**history[1], **history[0]}, *history[1:]]
        return {key: np.stack([rec[key] for rec in history]) for key in history[-1]}

    def result(self) -> SimulationResult:
        series = self.series()
        metrics = self._metrics(series)
        metrics["faults"] = int(getattr(self.rig, "faults", 0))
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

"""The engine's interface to a mechanism's lanes (`twin.sim.lanes`).

The engine (`twin.sim.engine.Simulation`) is one for every mechanism; what differs by kind of
mechanism — the state, the kernel, how a planner becomes kernel rows, what is recorded and
judged — sits behind `Lanes`, which `HybridLanes` and `PlatformLanes` implement (structural
typing, PEP 544: they do not inherit from it; mypy checks them where the engine's `LANES`
names them, tests/sim/test_protocols.py at run time).

Arrays are per lane (N) and per sample (S) of a chunk; their layout is
`twin.sim.kernels.layout`'s.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

from twin.sim.metrics import Reduction
from twin.sim.scenario import Scenario


@runtime_checkable
class Lanes(Protocol):
    """A mechanism's N lanes in the engine: its kernel's constants, its planners packed, its
    records and metrics.

    Attributes (read by the engine):
        kind: the kernel family, "hybrid" or "platform" (`twin.sim.lanes.runner`).
        state_key: the name of the state in the records ("xi" or "state").
        x0: (N, n) the states at t = 0.
        held: (N, 4, 4) ᴵT*: each lane's held inertial pose, fixed at t = 0.
        n_diagnostics: diagnostics per step the kernel writes.
        diagnostics: the names of every planner family's diagnostics (a lane's series keeps
            only its own family's, `keys`).
        extra: (N, 4) the small platforms' actuator lengths [native], None for the hybrid.
    """

    @property
    def kind(self) -> str: ...

    @property
    def state_key(self) -> str: ...

    @property
    def x0(self) -> np.ndarray: ...

    @property
    def held(self) -> np.ndarray: ...

    @property
    def n_diagnostics(self) -> int: ...

    @property
    def diagnostics(self) -> frozenset[str]: ...

    @property
    def extra(self) -> np.ndarray | None: ...

    def pack(
        self, lane: int, scenario: Scenario, x: np.ndarray, target: np.ndarray, /
    ) -> tuple[np.ndarray, np.ndarray]:
        """Build lane `lane`'s planner from the registry for `scenario`, reset it at the state
        x and target row (18,), and pack it: (prm row, memory row)."""
        ...

    def run(
        self,
        run: Callable[..., Any],
        xs: np.ndarray,
        targets: np.ndarray,
        prm: np.ndarray,
        memory: np.ndarray,
        dt: float,
        diag: np.ndarray,
        faults: np.ndarray,
        first: int = 1,
        /,
    ) -> None:
        """Step a chunk with the kernel runner `run`: states xs (N, S, n) from row 0,
        targets (N, S, 18), diagnostics diag (N, S, n_diagnostics) and fault bits written."""
        ...

    def records(
        self,
        poses: np.ndarray,
        xs: np.ndarray,
        diag: np.ndarray,
        dt: float,
        first: int = 1,
        /,
    ) -> dict[str, np.ndarray]:
        """Records (N, S − first, …) of the chunk `run` just stepped, on base poses
        (N, S, 6) [m, rad], samples first … S − 1."""
        ...

    def initial_records(self, poses: np.ndarray, x: np.ndarray, /) -> dict[str, np.ndarray]:
        """Records (N, 1, …) at t = 0 of the states x (N, n) on base poses (N, 1, 6)."""
        ...

    def keys(self, planner: str, /) -> set[str]:
        """The diagnostics the planner named `planner` records."""
        ...

    def metrics(
        self, series: dict[str, np.ndarray], lane: int, joint_limits: str = "record", /
    ) -> dict[str, Any]:
        """Lane `lane`'s metrics from its series (S, …)."""
        ...

    def metrics_lanes(
        self, data: dict[str, np.ndarray], ends: np.ndarray, joint_limits: Sequence[str], /
    ) -> list[dict[str, Any]]:
        """Every lane's `metrics` from series (N, C, …), lane n over its first ends[n]
        samples."""
        ...

    def reduction(self, ends: np.ndarray, joint_limits: Sequence[str], /) -> Reduction:
        """The running metrics of keep="metrics" (`twin.sim.metrics`): lane n's over its first
        ends[n] samples, in its `joint_limits` mode; the engine adds each chunk to it."""
        ...


@runtime_checkable
class ReducingLanes(Lanes, Protocol):
    """Lanes that add a chunk's samples to their running metrics as each is recorded, so a
    keep="metrics" run makes no record array of the chunk (the hybrid system's, `HybridLanes`);
    other lanes record the chunk and then reduce it."""

    def state_records(
        self, poses: np.ndarray, xs: np.ndarray, diag: np.ndarray, /
    ) -> dict[str, np.ndarray]:
        """The chunk's records that need no kinematics: states, poses, diagnostics (N, S, …)."""
        ...

    def reduce(
        self, reduction: Reduction, t: np.ndarray, start: int, /
    ) -> dict[str, np.ndarray] | None:
        """Samples 1 … S − 1 of the chunk just stepped (at times t [s]; sample 1 is the run's
        `start`-th) recorded and added to `reduction`; the newest sample's records (N, 1, …),
        or None where one is not finite (the caller puts back what `reduction` held before)."""
        ...


#: what makes a mechanism's lanes: (mechanism, x0 (N, n), T_IB0 (N, 4, 4), compiled) → Lanes
LanesFactory = Callable[[Any, np.ndarray, np.ndarray, bool], Lanes]

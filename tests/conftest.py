"""Shared fixtures: random states inside each mechanism's workspace, a NaN-injecting sea."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import settings

from tests.figures import record
from twin.mechanisms import HybridBoardingSystem
from twin.planners.parameters import as_records
from twin.sim.base_motion import BaseMotion
from twin.sim.engine import Simulation
from twin.sim.kernels.layout import TARGET

# No property test may depend on the machine's speed: hypothesis' 200 ms deadline failed a
# first example that compiled a kernel (0.5 s) on a loaded machine.
settings.register_profile("twin", deadline=None)
settings.load_profile("twin")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20231123)


def random_hybrid_states(rng: np.random.Generator, n: int, shrink: float = 0.5) -> np.ndarray:
    """n virtual-joint states (n, 9) uniformly within `shrink` of the Table 6 ranges about the
    working state, keeping only those whose legs are inside Table 1."""
    h = HybridBoardingSystem()
    w = h.working_state
    lo, hi = w + shrink * (h.lower - w), w + shrink * (h.upper - w)
    kept: list[np.ndarray] = []
    while sum(map(len, kept)) < n:
        draw = rng.uniform(lo, hi, size=(4 * n, 9))
        kept.append(draw[h.within_limits(draw)])
    return np.concatenate(kept)[:n]


@pytest.fixture
def nan_sea(monkeypatch: pytest.MonkeyPatch) -> Callable[[float, float], None]:
    """`nan_sea(start, end)`: every BaseMotion built afterwards (or re-sampled) returns NaN
    poses (and so transforms) for start ≤ t ≤ end [s] (± 1e-9), as a fault injection."""

    def inject(start: float, end: float = np.inf) -> None:
        original, uniform = BaseMotion.poses, BaseMotion.uniform_poses

        def inside(t: np.ndarray) -> np.ndarray:
            t = np.asarray(t, dtype=float)
            return (t >= start - 1e-9) & (t <= end + 1e-9)

        def poses(self: BaseMotion, t: np.ndarray) -> np.ndarray:
            out = original(self, t).copy()
            out[inside(t)] = np.nan
            return out

        def uniform_poses(
            motions: list, t0: float, dt: float, n: int, *args: object, first: int = 0
        ) -> np.ndarray:
            out = uniform(motions, t0, dt, n, *args, first=first).copy()
            out[:, inside(t0 + (first + np.arange(n)) * dt)] = np.nan
            return out

        monkeypatch.setattr(BaseMotion, "poses", poses)
        monkeypatch.setattr(BaseMotion, "uniform_poses", staticmethod(uniform_poses))

    return inject


@pytest.fixture
def nan_target(monkeypatch: pytest.MonkeyPatch) -> Callable[..., None]:
    """`nan_target(k, ...)`: every Simulation built afterwards gets a NaN twist in the held
    target of steps k, … (each lane), so its planner's velocity is not finite there — a
    planner fault injected into the one engine, whatever the mechanism."""

    def inject(*steps: int) -> None:
        original = Simulation.targets

        def poisoned(
            self: Simulation, block: Any, local: int, m: int, out: np.ndarray | None = None,
            end: bool = False,
        ) -> np.ndarray:  # fmt: skip
            rows = original(self, block, local, m, out, end)
            for k in steps:
                if 0 <= k - block.start - local < m:
                    as_records(rows[:, k - block.start - local], TARGET)["twist"] = np.nan
            return rows

        monkeypatch.setattr(Simulation, "targets", poisoned)

    return inject


@pytest.fixture(autouse=True)
def _record_fuzz_examples(request: pytest.FixtureRequest):
    """After a `tests.figures.fuzz` property test passed, log how many inputs it fuzzed."""
    failed = request.session.testsfailed
    yield
    examples = getattr(getattr(request.node, "function", None), "fuzz_examples", None)
    if examples is not None and request.session.testsfailed == failed:
        record(request.node.nodeid, examples=examples, kind="hypothesis")

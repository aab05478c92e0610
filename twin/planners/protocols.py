r"""The planner layer's interfaces: what a planner, a task, a weight and a limit must offer.

Planners are composed from parts in the spirit of mink (`Task`, `Limit`) and pink: a task
states a residual and its Jacobian J (ẋ = J q̇), a weight scales the joints in the weighted
pseudo-inverse (the diagonal of W⁻¹, seed 000 eq (27)), a limit bounds the velocity, and a
planner turns the desired tip motion into joint velocities step by step. Anything with these
methods plugs in (structural typing, PEP 544): the concrete classes do not inherit from these
protocols, mypy checks them where they are used (`PlannerSpec.build` returns a `Planner`),
and tests/planners/test_protocols.py checks every registry planner and its parts at run time.

Shapes: xi or state (..., n) is the planner's state (for the hybrid system the nine virtual
joints of seed 000 eq (14) [m, rad]; for the small platforms the actuator lengths [native]);
velocities have the same shape [unit/s].
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from twin.planners.target import PlannerOutput, TipTarget


@runtime_checkable
class Planner(Protocol):
    """A planner: the registry's `PlannerSpec.build` makes one per lane.

    `reset` is called once before the first `step` (and again when a live session rebuilds
    the planner); `step` may keep state between calls (the PID's integral, DWA's shares).
    """

    def reset(self, state: np.ndarray, target: TipTarget, /) -> None:
        """Start (or restart) at `state` (n,) with the desired tip motion `target`."""
        ...

    def step(self, state: np.ndarray, target: TipTarget, dt: float, /) -> PlannerOutput:
        """The velocity (n,) [unit/s] for `state` (n,) towards `target` over dt [s], with
        diagnostics (`PlannerOutput`)."""
        ...


@runtime_checkable
class Task(Protocol):
    """A task's Jacobian: J (..., k, n) with ẋ = J q̇ for its k rows (seed 000 eq (24) for
    the tip, eq (39) for a joint's posture)."""

    def jacobian(self, xi: np.ndarray, /) -> np.ndarray:
        """J (..., k, n) at the state xi (..., n)."""
        ...


@runtime_checkable
class TargetTask(Task, Protocol):
    """A task that follows the desired tip motion (`TipPoseTask`, seed 000 eqs (25), (34)):
    it asks for ẋ_demand = ẋ_d + k e with e = x_d − x.

    Attributes:
        gain: k [1/s], the closed-loop deviation coefficient (0: open loop, eq (33)).
    """

    @property
    def gain(self) -> float: ...

    def error(self, xi: np.ndarray, target: TipTarget, /) -> np.ndarray:
        """e (..., k) of the state xi (..., n) against `target`."""
        ...

    def demand(self, xi: np.ndarray, target: TipTarget, /) -> tuple[np.ndarray, np.ndarray]:
        """(ẋ_d + k e, e), each (..., k)."""
        ...


@runtime_checkable
class SecondaryTask(Task, Protocol):
    """A task that holds its own set-point, run in the primary task's null space or as a QP
    term (`JointPostureTask`, seed 000 eqs (39)-(40); `PlatformYawTask`, Algorithm 1)."""

    def demand(self, xi: np.ndarray, /) -> np.ndarray:
        """ζ̇ + k e (..., k) at the state xi (..., n)."""
        ...


@runtime_checkable
class Weight(Protocol):
    """Joint weights: the diagonal of W⁻¹ (..., n), each ≥ 0, of the weighted pseudo-inverse
    (seed 000 eqs (27)-(37)); weights compose by multiplication (`ProductWeights`)."""

    def __call__(self, xi: np.ndarray, /) -> np.ndarray:
        """diag(W⁻¹) (..., n) at the state xi (..., n)."""
        ...


@runtime_checkable
class Limit(Protocol):
    """A hard limit of a QP planner, as linear rows on the step's velocity v (mink's `Limit`
    with its velocity dampers): lower ≤ C v ≤ upper (`LegStrokeLimit`, `JointLimit`)."""

    def rows(self, xi: np.ndarray, dt: float, /) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(C (m, n), lower (m,), upper (m,)) [unit/s] at the state xi (n,) for a step of
        dt [s] (`twin.planners.qp.Rows`)."""
        ...


@runtime_checkable
class VelocityShaper(Protocol):
    """A limit applied to the solved velocity that depends on the state: seed 000
    Algorithm 1 (`SlewPriority`) moves velocity between joints that turn the tip alike."""

    def __call__(self, xi: np.ndarray, v: np.ndarray, /) -> np.ndarray:
        """The shaped velocity (..., n) for the state xi (..., n) and velocity v (..., n)."""
        ...


@runtime_checkable
class VelocityScaler(Protocol):
    """A rate limit applied last (`VelocityLimit`): the velocity scaled so that no joint
    exceeds its rate, its direction kept."""

    def __call__(self, v: np.ndarray, /) -> tuple[np.ndarray, np.ndarray]:
        """(scaled v (..., n), scale (...,) in (0, 1])."""
        ...

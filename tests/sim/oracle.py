"""The oracle of the compiled kernels and of the engine: the planner objects, stepped as the
deleted per-step rigs stepped them.

`twin.sim.hybrid_rig.HybridRig` and `twin.sim.platform_rig.PlatformRig` (removed with the
one engine, `git show 3a6bc9a~1:twin/sim/hybrid_rig.py`) were the readable statement of a
simulation step: ask the planner object, hold on a non-finite answer, stop at the limits,
integrate (hybrid) or move the actuators and fit the state (small platforms); the former
engine around them flagged a step whose base motion failed. Their step is restated here once,
in numpy, for the kernel tests (`tests/sim/kernels`) and the engine test
(`tests/sim/test_engine_oracle.py`):

- `held_target`: the held target of one sample (`twin.sim.target.held_targets` compiled);
- `pack_target` / `unpack_target`: a `TipTarget` as the kernels' (18,) row and back;
- `limit_scale`, `hybrid_advance`: `HybridRig.advance` on one state;
- `platform_advance`: `PlatformRig.advance` on one state;
- `OracleRun`: one lane of a `Simulation` stepped by planner objects built from the registry.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from twin.errors import ConvergenceError, TwinError, UnreachableError
from twin.mechanisms.hybrid import HybridBoardingSystem
from twin.planners import PlatformModel, PlatformPlanner, TipTarget, get_planner
from twin.sim.base_motion import BaseMotion, BaseSamples
from twin.sim.engine import Simulation
from twin.sim.faults import Fault
from twin.sim.kernels.hybrid import LIMIT_BISECTIONS, LIMIT_SLACK
from twin.sim.kernels.layout import N_TARGET, TARGET_P, TARGET_R, TARGET_V
from twin.sim.scenario import Scenario
from twin.spatial import invert_transform, so3_log

#: what the former engine caught around a rig's step or the base motion's evaluation and held
#: as a fault (`twin.sim.engine` before the one engine: ValueError covers TwinError and
#: numpy's LinAlgError)
NUMERICAL = (ArithmeticError, ValueError)


def raised(exc: Exception) -> int:
    """The fault bits the former engine gave a step whose rig raised `exc`: KINEMATICS for a
    kinematics failure (no convergence, unreachable), else PLANNER."""
    kinematics = isinstance(exc, ConvergenceError | UnreachableError)
    return int(Fault.KINEMATICS if kinematics else Fault.PLANNER)


# ------------------------------------------------------------------------------------ targets



def held_target(held: np.ndarray, base: BaseSamples, k: int, dt: float) -> TipTarget:
    """Desired pose in B at sample k and its mean twist to sample k + 1, for the inertial pose
    `held` (4, 4); the twist is [ᴮṗ; ᴮω] in B [m/s, rad/s] (seed 000 §5.1, docs/planners.md:
    ᴮT_d = ᴵT_B⁻¹ ᴵT*, and the rate that carries it to the next sample over dt)."""
    T0 = invert_transform(base.transform[k]) @ held
    T1 = invert_transform(base.transform[k + 1]) @ held
    v = (T1[:3, 3] - T0[:3, 3]) / dt
    w = so3_log(T1[:3, :3] @ T0[:3, :3].T) / dt
    return TipTarget(transform=T0, twist=np.r_[v, w])


def pack_target(target: TipTarget) -> np.ndarray:
    """A `TipTarget` as the kernels' (N_TARGET,) row: ᴮR_d row-major, ᴮp_d, twist
    (`twin.sim.kernels.layout.TARGET_*`)."""
    row = np.empty(N_TARGET)
    row[TARGET_R : TARGET_R + 9] = target.transform[:3, :3].reshape(9)
    row[TARGET_P : TARGET_P + 3] = target.transform[:3, 3]
    row[TARGET_V : TARGET_V + 6] = target.twist
    return row


def unpack_target(row: np.ndarray) -> TipTarget:
    """The `TipTarget` of a kernel row (18,): `pack_target`'s inverse."""
    T = np.eye(4)
    T[:3, :3] = row[TARGET_R : TARGET_R + 9].reshape(3, 3)
    T[:3, 3] = row[TARGET_P : TARGET_P + 3]
    return TipTarget(T, np.array(row[TARGET_V : TARGET_V + 6], dtype=float))


# ------------------------------------------------------------------------------------- hybrid


def limit_scale(
    mechanism: HybridBoardingSystem, xi: np.ndarray, velocity: np.ndarray, dt: float
) -> float:
    """The former `twin.sim.hybrid_rig.limit_scale`, verbatim: the largest s in [0, 1] such that
    the step s·velocity·dt carries no joint and no leg further past its limit than it already
    is (`LIMIT_SLACK` allowed), bisected `LIMIT_BISECTIONS` times."""
    now = mechanism.limit_excess(xi) + LIMIT_SLACK

    def fits(s: float) -> bool:
        return bool(
            np.all(mechanism.limit_excess(mechanism.integrate(xi, s * velocity, dt)) <= now)
        )

    if fits(1.0):
        return 1.0
    low, high = 0.0, 1.0
    for _ in range(LIMIT_BISECTIONS):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if fits(mid) else (low, mid)
    return low


class HybridStep(NamedTuple):
    """One `hybrid_advance`: the planner's velocity (9,) and diagnostics, the next xi (9,), the
    fraction of the step taken (0 on a hold), the fault bits (`Fault`)."""

    velocity: np.ndarray
    diagnostics: dict
    x: np.ndarray
    scale: float
    faults: int


def hybrid_advance(
    planner: object,
    mechanism: HybridBoardingSystem,
    x: np.ndarray,
    target: TipTarget,
    dt: float,
    hold: bool,
) -> HybridStep:
    """The former `HybridRig.advance` on one state xi (9,): plan; SINGULAR when the planner
    damped (diagnostics `damping` > 0), INFEASIBLE when the qp planner relaxed its limits
    (diagnostics `qp_level` 2); a non-finite velocity holds the state (PLANNER, scale
    0); in hold mode (`joint_limits == "hold"`) the step is shortened to `limit_scale`
    (JOINT_LIMIT when < 1); integrate the (scaled) velocity for dt. A planner that raises
    (`NUMERICAL`; e.g. `AllocationPlanner` on a NaN target) holds the state as the former
    engine held the rig (`raised`; velocity NaN, no diagnostics, scale 0)."""
    try:
        out = planner.step(x, target, dt)  # type: ignore[attr-defined]
    except NUMERICAL as exc:
        return HybridStep(np.full(x.shape, np.nan), {}, x.copy(), 0.0, raised(exc))
    v = out.velocity
    bits = Fault.SINGULAR if out.diagnostics.get("damping", 0.0) > 0 else Fault(0)
    if out.diagnostics.get("qp_level", 0.0) == 2:  # the qp planner relaxed its limits
        bits |= Fault.INFEASIBLE
    if not np.all(np.isfinite(v)):
        return HybridStep(v, out.diagnostics, x.copy(), 0.0, int(bits | Fault.PLANNER))
    scale = limit_scale(mechanism, x, v, dt) if hold else 1.0
    if scale < 1.0:
        bits |= Fault.JOINT_LIMIT
    return HybridStep(v, out.diagnostics, mechanism.integrate(x, scale * v, dt), scale, int(bits))


# ---------------------------------------------------------------------------------- platforms


class PlatformStep(NamedTuple):
    """One `platform_advance`: the next state (3,) and actuator lengths (n,) [native], the
    planner's diagnostics, the fault bits (`Fault`)."""

    state: np.ndarray
    legs: np.ndarray
    diagnostics: dict
    faults: int


def platform_advance(
    planner: PlatformPlanner,
    model: PlatformModel,
    state: np.ndarray,
    legs: np.ndarray,
    target: TipTarget,
    dt: float,
) -> PlatformStep:
    """The former `PlatformRig.advance` on one state (3,) and its lengths (n,): the planner's
    rates; non-finite ones hold (PLANNER); the lengths move one dt and stop at the stroke's
    ends (JOINT_LIMIT); `model.fit` warm-started at the state gives the new state, its failure
    holds (KINEMATICS). `model` is the rig's (its z held from t = 0), not the planner's. A
    planner that raises (`NUMERICAL`) holds, as the former engine held the rig (`raised`)."""
    try:
        out = planner.step(legs, target, dt)
    except NUMERICAL as exc:
        return PlatformStep(state.copy(), legs.copy(), {}, raised(exc))
    v = np.asarray(out.velocity, dtype=float)
    if not np.all(np.isfinite(v)):
        return PlatformStep(state.copy(), legs.copy(), out.diagnostics, int(Fault.PLANNER))
    fault = Fault(0)
    low, high = model.stroke
    lengths = np.clip(legs + v * dt, low, high)  # the actuators' end stops
    if np.any(lengths != legs + v * dt):
        fault |= Fault.JOINT_LIMIT
    try:
        new = model.fit(lengths, state)
    except TwinError:  # no convergence, or lengths met only outside the workspace
        new = None
    if new is None or not np.all(np.isfinite(new)):
        return PlatformStep(
            state.copy(), legs.copy(), out.diagnostics, int(fault | Fault.KINEMATICS)
        )
    return PlatformStep(new, lengths, out.diagnostics, int(fault))


# ------------------------------------------------------------------------------- engine lanes


class OracleRun:
    """One lane of a `Simulation` stepped by planner objects, as the rigs stepped it.

    What the oracle takes from the engine: the lane's start (`sim.lanes.x0`; for the small
    platforms its actuator lengths `sim.lanes.extra` and its rig model `sim.lanes.models`) and
    the held targets of each step (`sim.targets` of its current block, so a sea change or an
    injected fault reaches both). Planners are built from the registry as `twin.sim.lanes`
    builds them: the hybrid's with the lane's x0 (MTMP's q2 set-point, seed 000 eq (40)), a
    platform's at the current state; each reset at the current state and target. What the
    oracle judges itself: whether the base motion failed, from its own `BaseMotion.of` the
    scenario at the step's start and end (`base_fault`), not from the engine's block.

    Use: build it on a fresh Simulation; after the Simulation advanced, `follow()` steps the
    oracle up to it (the steps must still be in the engine's current block); after
    `sim.update(changes)`, `update(changes)` (the oracle must have followed first).

    Attributes:
        states: (k + 1, S) list: the state at every step so far.
        legs: (k + 1, n) list (platforms): the actuator lengths at every step.
        faults: (k,) list of fault bits; scales: (k,) hybrid limit scales.
        diagnostics: (k,) list of the planner's diagnostics; targets: (k, 18) rows read.
    """

    def __init__(self, sim: Simulation, lane: int = 0) -> None:
        if sim.k != 0:
            raise ValueError(f"OracleRun needs a fresh Simulation; this one is at step {sim.k}")
        self.sim, self.lane = sim, lane
        self.mechanism = sim.mechanism
        self.hybrid = sim.lanes.kind == "hybrid"
        self.scenario = sim.scenarios[lane]
        self.k = 0
        self.x0 = np.array(sim.lanes.x0[lane], dtype=float)
        self.x = self.x0.copy()
        self.states = [self.x.copy()]
        self.faults: list[int] = []
        self.scales: list[float] = []
        self.diagnostics: list[dict] = []
        self.targets: list[np.ndarray] = []
        if not self.hybrid:
            self.model: PlatformModel = sim.lanes.models[lane]
            self.leg = np.array(sim.lanes.extra[lane, : self.model.n_legs], dtype=float)
            self.legs = [self.leg.copy()]
        self.planner = self._build(self.scenario)
        self.base = BaseMotion.of(self.scenario)

    @property
    def hold(self) -> bool:
        return self.scenario.joint_limits == "hold"

    def base_fault(self) -> int:
        """BASE_MOTION if the base pose at the start or the end of step `self.k` is not finite
        or cannot be evaluated (the former engine's flag; the target it holds meanwhile is the
        engine's row, checked on its own by the engine test), else 0."""
        t = np.array([self.k, self.k + 1]) * self.scenario.dt
        try:
            poses = self.base.poses(t)
        except NUMERICAL:
            return int(Fault.BASE_MOTION)
        return 0 if np.all(np.isfinite(poses)) else int(Fault.BASE_MOTION)

    def _row(self) -> np.ndarray:
        """The engine's held target row (18,) for step `self.k`, from its current block."""
        block = self.sim._block
        local = self.k - block.start
        if not 0 <= local < block.steps:
            raise ValueError(
                f"step {self.k} is outside the engine's block ({block.start} … "
                f"{block.start + block.steps - 1}): follow before the engine re-samples"
            )
        return self.sim.targets(block, local, 1)[self.lane, 0]

    def _build(self, scenario: Scenario) -> object:
        """The registry's planner for `scenario`, built at the lane's start x0 (MTMP's q̃2, the
        Upr4's held height), reset at the current state and target."""
        target = unpack_target(self._row())
        if self.hybrid:
            planner = get_planner(scenario.planner, "hybrid").build(
                self.mechanism, scenario.parameters(), self.x0
            )
            planner.reset(self.x.copy(), target)
            return planner
        planner = get_planner(scenario.planner, self.model.name).build(
            self.mechanism, scenario.parameters(), self.x0
        )
        planner.reset(self.leg.copy(), target)
        return planner

    def step(self) -> None:
        """One step from `self.k`, on the engine's target row for it."""
        row = self._row()
        target = unpack_target(row)
        dt = self.scenario.dt
        if self.hybrid:
            out = hybrid_advance(self.planner, self.mechanism, self.x, target, dt, self.hold)
            self.x = out.x
            self.scales.append(out.scale)
        else:
            out = platform_advance(self.planner, self.model, self.x, self.leg, target, dt)
            self.x, self.leg = out.state, out.legs
            self.legs.append(self.leg.copy())
        self.states.append(self.x.copy())
        self.faults.append(out.faults | self.base_fault())
        self.diagnostics.append(out.diagnostics)
        self.targets.append(row)
        self.k += 1

    def follow(self) -> None:
        """Step up to the engine's step."""
        while self.k < self.sim.k:
            self.step()

    def update(self, changes: dict) -> None:
        """The engine's `update(changes)` as the oracle sees it, at the engine's step: a planner
        or a knob changed rebuilds the planner (reset at the current state and the engine's
        target, a new sea's if the sea changed too); `joint_limits` switches hold mode; the
        base motion is the new scenario's (the same sea unless a sea field changed)."""
        if self.k != self.sim.k:
            raise ValueError(f"update at step {self.sim.k}: the oracle is at {self.k}; follow")
        new = Scenario(**{**self.scenario.model_dump(), **changes})
        if (new.planner, new.parameters()) != (self.scenario.planner, self.scenario.parameters()):
            self.planner = self._build(new)
        self.scenario, self.base = new, BaseMotion.of(new)

    def fault_counts(self) -> dict[str, int]:
        """Steps flagged per kind, as `FaultLog.counts` names them."""
        bits = np.array(self.faults, dtype=np.int64)
        return {f.name.lower(): int(np.count_nonzero(bits & int(f))) for f in Fault}

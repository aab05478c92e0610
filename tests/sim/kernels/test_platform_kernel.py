"""The small platforms' kernel (twin/sim/kernels/platform.py) against its oracle, step by step.

The oracle is `PlatformPlanner` and `PlatformModel` stepped as the rig stepped them (the old
`PlatformRig.advance`, transcribed in `tests.sim.oracle.platform_advance`): planner step,
non-finite rates held (PLANNER), lengths stopped at the stroke (JOINT_LIMIT), forward
kinematics warm-started at the previous state, its failure held (KINEMATICS). Lanes of one
mechanism run together in chunks, on the plain-Python and the compiled kernel, and must agree
with the oracle at every step.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field
from functools import cache

import numpy as np
import pytest

from tests.sim.oracle import held_target, pack_target, platform_advance
from twin.errors import TwinError
from twin.mechanisms import Upr4, Upu3Up
from twin.planners.platform import (
    FIT_MAX_ITER,
    FIT_TOL,
    PlatformModel,
    PlatformPlanner,
    platform_builder,
)
from twin.sim.base_motion import BaseMotion
from twin.sim.kernels import platform as kernel
from twin.sim.kernels.layout import (
    FAULT_JOINT_LIMIT,
    FAULT_KINEMATICS,
    FAULT_PLANNER,
    KIND_PLATFORM,
    N_MEMORY,
    N_PARAMETERS,
    N_TARGET,
    P_HOLD,
    P_KIND,
)
from twin.sim.scenario import Scenario
from twin.spatial import pose_to_transform

STEPS = 160
#: chunk lengths the lanes are stepped in (memory and rows carried across)
CHUNKS = (64, 40, 56)
TOL = 1e-9


@dataclass(frozen=True)
class Lane:
    """One scenario of the test: the sea, the law, and what is done to it.

    Attributes:
        law: "pid" or "ik".
        sea: Scenario fields of the sea and the planner's knobs.
        initial_state: (3,) [native, rad, rad]; None: the working state.
        legs: (n,) [native] initial actuator lengths instead of the state's (inconsistent
            ones make forward kinematics fail).
        nan: samples whose base transform is NaN (the targets at k − 1 and k are then not
            finite).
    """

    law: str
    sea: dict = field(default_factory=dict)
    initial_state: tuple[float, ...] | None = None
    legs: tuple[float, ...] | None = None
    nan: tuple[int, ...] = ()


LANES: dict[str, tuple[Lane, ...]] = {
    "upu3up": (
        Lane("pid", dict(sea_state=9)),  # the speed limit binds, tilts clip at 20°
        Lane("ik", dict(sea_state=9)),
        Lane("pid", dict(regular_waves="state3", actuator_speed=0.01)),
        Lane("ik", dict(sea_state=6, seed=3), nan=(50, 51, 52)),  # FAULT_PLANNER
        Lane("ik", dict(sea_state=6), legs=(620.0, 1460.0, 1460.0)),  # no convergence
        Lane("pid", dict(sea_state=6), legs=(1405.5, 1305.3, 622.3)),  # beyond the envelope
    ),
    "upr4": (
        Lane("pid", dict(sea_state=9)),
        Lane("ik", dict(sea_state=9)),
        Lane("ik", dict(regular_waves="state3", actuator_speed=0.01)),  # the speed limit binds
        # near full stroke: desired lengths clip, the fast PID overshoots into the end stops
        Lane("pid", dict(sea_state=9, kp=30.0), initial_state=(0.84, 0.0, 0.0)),
        Lane("pid", dict(sea_state=5, seed=2), nan=(70,)),  # FAULT_PLANNER
        Lane("pid", dict(sea_state=6), legs=(0.7225, 1.1225, 1.1225, 0.7225)),  # no fit
    ),
}


@dataclass
class Record:
    """A run of lanes: states (N, S + 1, 3), legs (N, S + 1, 4), diag (N, S, 2), faults (N, S)."""

    xs: np.ndarray
    legs: np.ndarray
    diag: np.ndarray
    faults: np.ndarray


@dataclass
class Inputs:
    """Packed kernel inputs for lanes of one mechanism, and the oracle's record."""

    const: np.ndarray
    n_legs: int
    dt: float
    x0: np.ndarray
    legs0: np.ndarray
    targets: np.ndarray
    prm: np.ndarray
    memory: np.ndarray
    oracle: Record


@cache
def inputs(mechanism: str) -> Inputs:
    """The lanes of `LANES[mechanism]`: targets as PlatformRig.reset held them, packed
    planners after reset, and the oracle stepped through them."""
    lanes = LANES[mechanism]
    dt = 0.05
    mech = Upu3Up() if mechanism == "upu3up" else Upr4()
    n = 3 if mechanism == "upu3up" else 4
    N = len(lanes)
    x0, legs0 = np.zeros((N, 3)), np.zeros((N, 4))
    targets = np.zeros((N, STEPS, N_TARGET))
    prm, memory = np.zeros((N, N_PARAMETERS)), np.zeros((N, N_MEMORY))
    oracle = Record(
        np.zeros((N, STEPS + 1, 3)),
        np.zeros((N, STEPS + 1, 4)),
        np.zeros((N, STEPS, kernel.N_PLATFORM_DIAGNOSTICS)),
        np.zeros((N, STEPS), dtype=np.int64),
    )
    consts = []
    for i, lane in enumerate(lanes):
        scenario = Scenario(mechanism=mechanism, planner=lane.law, duration=STEPS * dt, **lane.sea)
        base = BaseMotion.of(scenario).sample(np.arange(STEPS + 1) * dt)
        for k in lane.nan:
            base.transform[k] = np.nan
        state = np.array(mech.working_state if lane.initial_state is None else lane.initial_state)
        planner = platform_builder(lane.law)(mech, scenario.parameters(), state)
        model = PlatformModel(mech, z_hold=float(state[0]))
        legs = model.leg_lengths(state) if lane.legs is None else np.array(lane.legs)
        # PlatformRig.reset: hold the top's inertial position, level, with the base's heading
        top = base.transform[0] @ model.transform(state)
        held = pose_to_transform(np.r_[top[:3, 3], 0.0, 0.0, base.pose[0, 5]])
        planner.reset(legs, held_target(held, base, 0, dt))
        prm[i], memory[i] = kernel.pack_platform(planner, hold=True)
        consts.append(kernel.platform_constants(model))
        x0[i], legs0[i, :n] = state, legs
        oracle.xs[i, 0], oracle.legs[i, 0, :n] = state, legs
        for k in range(STEPS):
            target = held_target(held, base, k, dt)
            targets[i, k] = pack_target(target)
            state, legs, diagnostics, fault = platform_advance(
                planner, model, state, legs, target, dt
            )
            oracle.xs[i, k + 1], oracle.legs[i, k + 1, :n] = state, legs
            oracle.diag[i, k, kernel.D_CLIPPED] = diagnostics["clipped"]
            oracle.diag[i, k, kernel.D_SATURATED] = diagnostics["saturated"]
            oracle.faults[i, k] = fault
    for const in consts[1:]:  # one const per mechanism, whatever the lane's start
        np.testing.assert_array_equal(const, consts[0])
    return Inputs(consts[0], n, dt, x0, legs0, targets, prm, memory, oracle)


@cache
def run(mechanism: str, engine: str) -> Record:
    """The lanes stepped by the kernel in `CHUNKS`: engine "python", "serial" or "parallel"."""
    data = inputs(mechanism)
    runner = {
        "python": kernel.run_platform,
        "serial": kernel.compiled_platform(False),
        "parallel": kernel.compiled_platform(True),
    }[engine]
    N = data.x0.shape[0]
    out = Record(
        np.zeros((N, STEPS + 1, 3)),
        np.zeros((N, STEPS + 1, 4)),
        np.zeros((N, STEPS, kernel.N_PLATFORM_DIAGNOSTICS)),
        np.zeros((N, STEPS), dtype=np.int64),
    )
    out.xs[:, 0], out.legs[:, 0] = data.x0, data.legs0
    memory = data.memory.copy()
    start = 0
    for B in CHUNKS:
        xs, legs = np.zeros((N, B + 1, 3)), np.zeros((N, B + 1, 4))
        xs[:, 0], legs[:, 0] = out.xs[:, start], out.legs[:, start]
        diag = np.full((N, B + 1, kernel.N_PLATFORM_DIAGNOSTICS), np.nan)
        faults = np.full((N, B), -1, dtype=np.int64)
        targets = np.ascontiguousarray(data.targets[:, start : start + B])
        runner(xs, legs, targets, data.prm, memory, data.const, data.dt, diag, faults)
        out.xs[:, start + 1 : start + B + 1] = xs[:, 1:]
        out.legs[:, start + 1 : start + B + 1] = legs[:, 1:]
        assert np.isnan(diag[:, 0]).all()  # row 0, the chunk's start, is left alone
        out.diag[:, start : start + B], out.faults[:, start : start + B] = diag[:, 1:], faults
        start += B
    assert start == STEPS
    return out


def assert_records_close(a: Record, b: Record, n_legs: int) -> None:
    """States, legs (the first n_legs), diagnostics to TOL; fault bits equal; every step."""
    np.testing.assert_allclose(a.xs, b.xs, rtol=0.0, atol=TOL)
    np.testing.assert_allclose(a.legs[..., :n_legs], b.legs[..., :n_legs], rtol=0.0, atol=TOL)
    np.testing.assert_allclose(a.diag, b.diag, rtol=0.0, atol=TOL)
    np.testing.assert_array_equal(a.faults, b.faults)


@pytest.mark.parametrize("engine", ["python", "serial"])
@pytest.mark.parametrize("mechanism", ["upu3up", "upr4"])
def test_kernel_steps_as_the_rig_did(mechanism: str, engine: str) -> None:
    """Every step of every lane: states, legs, clipped/saturated and fault bits as the oracle's,
    across chunk boundaries (the PID's memory carried in `memory`)."""
    data = inputs(mechanism)
    assert_records_close(run(mechanism, engine), data.oracle, data.n_legs)


@pytest.mark.parametrize("mechanism", ["upu3up", "upr4"])
def test_lanes_cover_limits_and_faults(mechanism: str) -> None:
    """The lanes exercise what they are meant to: the speed limit binding (both laws), clipping,
    JOINT_LIMIT (Upr4 near full stroke), PLANNER and KINEMATICS faults holding the platform."""
    oracle, lanes = inputs(mechanism).oracle, LANES[mechanism]
    saturated = oracle.diag[..., kernel.D_SATURATED].sum(axis=1)
    for i, lane in enumerate(lanes):
        if "actuator_speed" in lane.sea or (mechanism == "upu3up" and lane.sea == {"sea_state": 9}):
            assert saturated[i] > 20
    assert oracle.diag[..., kernel.D_CLIPPED].sum() > 100
    held = np.all(oracle.xs[:, 1:] == oracle.xs[:, :-1], axis=-1) & np.all(
        oracle.legs[:, 1:] == oracle.legs[:, :-1], axis=-1
    )
    for i, lane in enumerate(lanes):
        planner = (oracle.faults[i] & FAULT_PLANNER) != 0
        kinematics = (oracle.faults[i] & FAULT_KINEMATICS) != 0
        if lane.nan:  # targets at k − 1 and k use the sample k
            expected = sorted({j for k in lane.nan for j in (k - 1, k)})
            np.testing.assert_array_equal(np.flatnonzero(planner), expected)
        if lane.legs is not None:
            assert kinematics.all()
        assert np.all(held[i, planner | kinematics])
    if mechanism == "upr4":
        assert np.sum((oracle.faults & FAULT_JOINT_LIMIT) != 0) > 20


@pytest.mark.parametrize("mechanism", ["upu3up", "upr4"])
def test_compiled_and_python_agree(mechanism: str) -> None:
    """The compiled runner, serial and parallel over lanes, gives the plain-Python numbers."""
    n_legs = inputs(mechanism).n_legs
    python = run(mechanism, "python")
    assert_records_close(run(mechanism, "serial"), python, n_legs)
    assert_records_close(run(mechanism, "parallel"), python, n_legs)


@pytest.mark.parametrize("mechanism", ["upu3up", "upr4"])
def test_fit_matches_platform_model_fit(mechanism: str, rng: np.random.Generator) -> None:
    """`fit` succeeds where `PlatformModel.fit` does, with the same state, over random lengths
    in the stroke (Upu3Up: converged, no convergence and beyond-the-envelope cases)."""
    mech = Upu3Up() if mechanism == "upu3up" else Upr4()
    model = PlatformModel(mech)
    const = kernel.platform_constants(model)
    n = model.n_legs
    low, high = model.stroke
    guess = mech.working_state
    x, step, o, residual = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(4)
    R, J, M = np.zeros((3, 3)), np.zeros((4, 3)), np.zeros((3, 4))
    outcomes = set()
    for lengths in rng.uniform(low, high, size=(250, n)):
        try:
            expected = model.fit(lengths, guess)
        except TwinError:
            expected = None
        ok = kernel.fit(lengths, guess, const, x, R, o, residual, J, M, step)
        assert ok == (expected is not None), lengths
        if ok:
            np.testing.assert_allclose(x, expected, rtol=0.0, atol=TOL)
        outcomes.add(ok)
    assert outcomes == {True, False}


def test_constants_and_packing() -> None:
    """`platform_constants` and `pack_platform` hold what the oracle objects hold."""
    upu = PlatformModel(Upu3Up())
    const = kernel.platform_constants(upu)
    assert const[kernel.C_MECHANISM] == kernel.MECHANISM_UPU3UP
    assert (const[kernel.C_N_LEGS], const[kernel.C_UNIT]) == (3, 1e-3)
    assert (const[kernel.C_STROKE_LOW], const[kernel.C_STROKE_HIGH]) == (620.0, 1460.0)
    high = const[kernel.C_ENVELOPE_HIGH : kernel.C_ENVELOPE_HIGH + 3]
    np.testing.assert_array_equal(high, [420.0, np.radians(85.0), np.radians(85.0)])
    upr = PlatformModel(Upr4(), z_hold=0.6)
    const = kernel.platform_constants(upr)
    assert const[kernel.C_MECHANISM] == kernel.MECHANISM_UPR4
    assert (const[kernel.C_N_LEGS], const[kernel.C_UNIT]) == (4, 1.0)
    low, high = Upr4().state_limits
    np.testing.assert_array_equal(const[kernel.C_STATE_LOW : kernel.C_STATE_LOW + 3], low)
    np.testing.assert_array_equal(const[kernel.C_STATE_HIGH : kernel.C_STATE_HIGH + 3], high)
    assert const.shape == (kernel.N_PLATFORM_CONSTANTS,)

    planner = PlatformPlanner(upr, "pid", 0.1, kp=8.0, ki=1e-3, kd=0.02)
    prm, memory = kernel.pack_platform(planner, hold=False)
    assert (prm[P_KIND], prm[P_HOLD], prm[kernel.P_LAW]) == (KIND_PLATFORM, 0.0, kernel.LAW_PID)
    assert (prm[kernel.P_KP], prm[kernel.P_KI], prm[kernel.P_KD]) == (8.0, 1e-3, 0.02)
    assert (prm[kernel.P_SPEED_LIMIT], prm[kernel.P_Z_HOLD]) == (0.1, 0.6)
    assert memory[kernel.M_HAS_PREVIOUS] == 0.0  # no reset yet: the derivative starts from e
    planner.integral = np.array([1.0, 2.0, 3.0, 4.0])
    planner._previous_error = np.array([5.0, 6.0, 7.0, 8.0])
    prm, memory = kernel.pack_platform(planner, hold=True)
    np.testing.assert_array_equal(memory[kernel.M_INTEGRAL : kernel.M_INTEGRAL + 4], [1, 2, 3, 4])
    np.testing.assert_array_equal(memory[kernel.M_PREVIOUS : kernel.M_PREVIOUS + 4], [5, 6, 7, 8])
    assert (memory[kernel.M_HAS_PREVIOUS], prm[P_HOLD]) == (1.0, 1.0)
    ik = PlatformPlanner(PlatformModel(Upu3Up()), "ik", 0.1)
    prm, _ = kernel.pack_platform(ik, hold=True)
    assert (prm[kernel.P_LAW], prm[kernel.P_SPEED_LIMIT]) == (kernel.LAW_IK, 100.0)


def test_tolerances_are_the_oracles() -> None:
    """The kernel's Newton-Raphson stops as `Upu3Up.forward` (called with its defaults by
    `PlatformModel.fit`); the Gauss-Newton constants are imported from the planner."""
    defaults = inspect.signature(Upu3Up.forward).parameters
    assert kernel.FORWARD_TOL == defaults["tol"].default
    assert kernel.FORWARD_MAX_ITER == defaults["max_iter"].default
    assert (FIT_TOL, FIT_MAX_ITER) == (1e-8, 30)

"""The small platforms' runner (twin/sim/kernels/platform.py), judged step by step.

The planner and model objects run the same lane functions as the runner (`twin.planners.
platform`, `twin.mechanisms.platforms`, held to the papers and to finite differences in their
own tests), so they are no oracle of it. What is checked here is the runner's own part, from
its outcome (`tests.sim.oracle.assert_platform_steps`): the lengths stopped at the stroke
(JOINT_LIMIT ends on a stroke end), the state the least-squares fit of the lengths, held
steps (PLANNER, KINEMATICS) moving nothing; the faults where the lanes put them; the PID's
memory carried across chunks (chunked equals one chunk); the lanes in parallel; the
plain-Python runner equals the compiled one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache

import numpy as np
import pytest

from tests.sim.oracle import assert_platform_steps, held_target, pack_target
from twin.mechanisms import Upr4, Upu3Up
from twin.mechanisms.platforms import MECHANISM_UPR4, MECHANISM_UPU3UP
from twin.planners.parameters import as_records
from twin.planners.platform import PlatformPlanner, platform_builder
from twin.planners.platform_model import PlatformModel
from twin.planners.platform_step import LAW_IK, LAW_PID, PLATFORM_PARAMETERS, memory_record
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
    """Packed kernel inputs for lanes of one mechanism, and each lane's model."""

    const: np.ndarray
    n_legs: int
    dt: float
    x0: np.ndarray
    legs0: np.ndarray
    targets: np.ndarray
    prm: np.ndarray
    memory: np.ndarray
    models: list[PlatformModel]


@cache
def inputs(mechanism: str) -> Inputs:
    """The lanes of `LANES[mechanism]`: targets as PlatformRig.reset held them, packed
    planners after reset."""
    lanes = LANES[mechanism]
    dt = 0.05
    mech = Upu3Up() if mechanism == "upu3up" else Upr4()
    n = 3 if mechanism == "upu3up" else 4
    N = len(lanes)
    x0, legs0 = np.zeros((N, 3)), np.zeros((N, 4))
    targets = np.zeros((N, STEPS, N_TARGET))
    prm, memory = np.zeros((N, N_PARAMETERS)), np.zeros((N, N_MEMORY))
    consts, models = [], []
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
        models.append(model)
        x0[i], legs0[i, :n] = state, legs
        targets[i] = [pack_target(held_target(held, base, k, dt)) for k in range(STEPS)]
    for const in consts[1:]:  # one const per mechanism, whatever the lane's start
        np.testing.assert_array_equal(const, consts[0])
    return Inputs(consts[0], n, dt, x0, legs0, targets, prm, memory, models)


@cache
def run(mechanism: str, engine: str, chunks: tuple[int, ...] = CHUNKS) -> Record:
    """The lanes stepped by the kernel in `chunks`: engine "python", "serial" or "parallel"."""
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
    for B in chunks:
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
def test_steps_keep_the_actuators_contract(mechanism: str, engine: str) -> None:
    """Every step of every lane as the actuators and the rigid top allow
    (`assert_platform_steps`: stroke, fit, held steps still, JOINT_LIMIT on an end stop)."""
    data, out = inputs(mechanism), run(mechanism, engine)
    n = data.n_legs
    for i, model in enumerate(data.models):
        faults = out.faults[i]
        held = (faults & (FAULT_PLANNER | FAULT_KINEMATICS)) != 0
        limited = ((faults & FAULT_JOINT_LIMIT) != 0) & ~held
        assert_platform_steps(model, out.xs[i], out.legs[i, :, :n], held, limited)


@pytest.mark.parametrize("mechanism", ["upu3up", "upr4"])
def test_chunks_carry_the_memory(mechanism: str) -> None:
    """The lanes stepped in `CHUNKS` (the PID's integral and previous error, the lengths and
    the states carried across) equal the lanes stepped in one chunk."""
    n_legs = inputs(mechanism).n_legs
    assert_records_close(run(mechanism, "python"), run(mechanism, "python", (STEPS,)), n_legs)


@pytest.mark.parametrize("mechanism", ["upu3up", "upr4"])
def test_lanes_cover_limits_and_faults(mechanism: str) -> None:
    """The lanes exercise what they are meant to: the speed limit binding (both laws), clipping,
    JOINT_LIMIT (Upr4 near full stroke), PLANNER and KINEMATICS faults holding the platform."""
    out, lanes = run(mechanism, "python"), LANES[mechanism]
    diagnostics = as_records(out.diag, kernel.PLATFORM_DIAGNOSTICS)
    saturated = diagnostics["saturated"].sum(axis=1)
    for i, lane in enumerate(lanes):
        if "actuator_speed" in lane.sea or (mechanism == "upu3up" and lane.sea == {"sea_state": 9}):
            assert saturated[i] > 20
    assert diagnostics["clipped"].sum() > 100
    for i, lane in enumerate(lanes):
        planner = (out.faults[i] & FAULT_PLANNER) != 0
        kinematics = (out.faults[i] & FAULT_KINEMATICS) != 0
        if lane.nan:  # targets at k − 1 and k use the sample k
            expected = sorted({j for k in lane.nan for j in (k - 1, k)})
            np.testing.assert_array_equal(np.flatnonzero(planner), expected)
        else:
            assert not planner.any()
        if lane.legs is not None:
            assert kinematics.all()
        else:
            assert not kinematics.any()
    if mechanism == "upr4":
        assert np.sum((out.faults & FAULT_JOINT_LIMIT) != 0) > 20


@pytest.mark.parametrize("mechanism", ["upu3up", "upr4"])
def test_compiled_and_python_agree(mechanism: str) -> None:
    """The compiled runner, serial and parallel over lanes, gives the plain-Python numbers."""
    n_legs = inputs(mechanism).n_legs
    python = run(mechanism, "python")
    assert_records_close(run(mechanism, "serial"), python, n_legs)
    assert_records_close(run(mechanism, "parallel"), python, n_legs)


def test_constants_and_packing() -> None:
    """`PlatformModel.pack` and `PlatformPlanner.pack` / `pack_memory` hold, by name, what the
    objects hold."""
    g = PlatformModel(Upu3Up()).pack()[0]
    assert g["mechanism"] == MECHANISM_UPU3UP
    assert (g["n_legs"], g["unit"], g["l"]) == (3, 1e-3, 1040.0)
    assert (g["stroke_low"], g["stroke_high"]) == (620.0, 1460.0)
    np.testing.assert_array_equal(g["envelope_high"], [420.0, np.radians(85.0), np.radians(85.0)])
    np.testing.assert_array_equal(g["base_hinges"][:9], Upu3Up().layout_mm.base_hinges[:3].ravel())
    np.testing.assert_array_equal(g["base_hinges"][9:], 0.0)  # no fourth actuated limb
    g = PlatformModel(Upr4(), z_hold=0.6).pack()[0]
    assert g["mechanism"] == MECHANISM_UPR4
    assert (g["n_legs"], g["unit"]) == (4, 1.0)
    low, high = Upr4().state_limits
    np.testing.assert_array_equal(g["state_low"], low)
    np.testing.assert_array_equal(g["state_high"], high)
    assert np.all(np.isinf(g["envelope_high"]))

    upr = PlatformModel(Upr4(), z_hold=0.6)
    planner = PlatformPlanner(upr, "pid", 0.1, kp=8.0, ki=1e-3, kd=0.02)
    prm = planner.pack(hold=False)
    assert prm.shape == (N_PARAMETERS,)
    p = prm.view(PLATFORM_PARAMETERS)[0]
    assert (p["kind"], p["hold"], p["law"]) == (KIND_PLATFORM, 0.0, LAW_PID)
    assert (p["kp"], p["ki"], p["kd"]) == (8.0, 1e-3, 0.02)
    assert (p["speed_limit"], p["z_hold"]) == (0.1, 0.6)
    memory = np.zeros(N_MEMORY)
    planner.pack_memory(memory)
    assert memory_record(memory)["has_previous"] == 0.0  # no reset: the derivative starts from e
    planner.integral = np.array([1.0, 2.0, 3.0, 4.0])
    planner.previous_error = np.array([5.0, 6.0, 7.0, 8.0])
    prm, memory = kernel.pack_platform(planner, hold=True)
    m = memory_record(memory)
    np.testing.assert_array_equal(m["integral"], [1, 2, 3, 4])
    np.testing.assert_array_equal(m["previous"], [5, 6, 7, 8])
    assert (m["has_previous"], prm.view(PLATFORM_PARAMETERS)[0]["hold"]) == (1.0, 1.0)
    ik = PlatformPlanner(PlatformModel(Upu3Up()), "ik", 0.1)
    p = ik.pack(hold=True).view(PLATFORM_PARAMETERS)[0]
    assert (p["law"], p["speed_limit"]) == (LAW_IK, 100.0)

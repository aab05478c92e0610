"""The one-lane allocation kernel (conv1, conv2, dwa): its packing, its fault on a target that
is not finite (compiled by numba and as plain Python) and its primitives against the twin's
numpy functions.

Its steps are `AllocationPlanner.step`'s own (the object runs this lane over its batch), held
to seed 004's split typed in numpy, step after step on a real sea from these starts, in
tests/planners/test_allocation.py (`test_steps_on_a_sea_split_as_seed_004_says`).
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable

import numpy as np
import pytest

from tests.conftest import random_hybrid_states
from tests.sim.oracle import held_target, pack_target
from twin.mechanisms.gangway import gangway_inverse_lane
from twin.mechanisms.hybrid import HybridBoardingSystem
from twin.mechanisms.legs import leg_vectors_lane, manipulability_lane
from twin.planners import HYBRID_RATE_LIMITS
from twin.planners import allocation_step as ak
from twin.planners.allocation import AllocationPlanner, reachable_range
from twin.planners.allocation_step import reachable_range_lane
from twin.planners.families import ALLOCATION_METHODS, ALLOCATION_PARAMETERS
from twin.planners.parameters import as_record
from twin.planners.target import TipTarget
from twin.sim.base_motion import BaseMotion, BaseSamples
from twin.sim.kernels import layout as lay
from twin.sim.kernels.hybrid import hybrid_constants
from twin.sim.scenario import Scenario
from twin.spatial import (
    invert_transform,
    pose_to_transform,
    rpy_to_matrix_lane,
    se3_log,
    se3_log_lane,
    so3_exp,
    so3_exp_lane,
)

DT = 0.05  # [s]
N_STEPS = 100
MECHANISM = HybridBoardingSystem()
STEWART, GANGWAY = MECHANISM.stewart, MECHANISM.gangway
BASE = MECHANISM.layout.base_hinges.ravel()
PLATFORM = MECHANISM.layout.platform_hinges.ravel()

#: starts: the working state, off-centre, a low platform near the leg minimum (small reach,
#: clipped shares) and one whose legs are outside their stroke (reach and shares zero)
STARTS = {
    "working": MECHANISM.working_state,
    "off_centre": np.array([0.1, -0.1, 2.6, 0.02, -0.03, 0.05, 0.1, 0.05, 12.0]),
    "low": np.array([0.0, 0.0, 1.6, 0.0, 0.0, 0.0, 0.0, 0.0, 13.0]),
    "legs_outside": np.array([0.6, 0.4, 3.0, 0.1, -0.1, 0.2, -0.2, 0.1, 14.0]),
}

ENGINES = ["python", pytest.param("numba", marks=pytest.mark.skipif(
    importlib.util.find_spec("numba") is None, reason="numba not installed"))]  # fmt: skip

#: step(x, target, prm, memory, const, dt, v_out, diag_out) -> int (`allocation_step`)
Step = Callable[..., int]

CONST = hybrid_constants(MECHANISM, HYBRID_RATE_LIMITS)


@pytest.fixture(scope="module")
def base() -> BaseSamples:
    """Sea state 6 on the hybrid mount, N_STEPS + 1 samples at DT."""
    scenario = Scenario(planner="dwa", sea_state=6, seed=3)
    return BaseMotion.of(scenario).sample(np.arange(N_STEPS + 1) * DT)


def allocation_step(
    x: np.ndarray, target: np.ndarray, prm: np.ndarray, memory: np.ndarray, const: np.ndarray,
    dt: float, v_out: np.ndarray, diag_out: np.ndarray,
) -> int:  # fmt: skip
    """allocation_velocity as the runner calls it, with x's ᴮR_P and the scratch made here."""
    R = np.empty((3, 3))
    rpy_to_matrix_lane(x[3], x[4], x[5], R)
    work = ak.allocation_work()
    record = prm.view(ALLOCATION_PARAMETERS)[0]  # the row by name, as the runner reads it
    return ak.allocation_velocity(x, R, target, record, memory, const, dt, work, v_out, diag_out)


@pytest.fixture(scope="module")
def compiled() -> Step:
    """`allocation_step` compiled (the runner's call)."""
    import numba

    return numba.njit(error_model="numpy")(allocation_step)


def stepper(engine: str, request: pytest.FixtureRequest) -> Step:
    return request.getfixturevalue("compiled") if engine == "numba" else allocation_step


@pytest.mark.parametrize("hold", [False, True])
@pytest.mark.parametrize("method", ["conv1", "conv2", "dwa"])
def test_pack_round_trip(method: str, hold: bool, base: BaseSamples) -> None:
    """pack_allocation's rows give back the planner's reset state."""
    xi = STARTS["off_centre"]
    planner = AllocationPlanner(MECHANISM, method)
    planner.reset(xi, held_target(base.transform[0] @ MECHANISM.end_effector(xi), base, 0, DT))
    prm, memory = ak.pack_allocation(planner, hold)
    assert prm.shape == (lay.N_PARAMETERS,) and memory.shape == (lay.N_MEMORY,)
    common = as_record(prm, lay.COMMON_PARAMETERS)
    assert common.kind == lay.KIND_ALLOCATION
    assert common.hold == (1.0 if hold else 0.0)
    record = prm.view(ALLOCATION_PARAMETERS)[0]
    assert record["method"] == ALLOCATION_METHODS[method]
    manip_mid, range_mid = planner.start.manip_mid, planner.start.range_mid
    assert record["manip_mid"] == manip_mid
    np.testing.assert_array_equal(record["range_mid"], range_mid)
    np.testing.assert_array_equal(record["T_P0"].reshape(3, 4), planner.start.T_P0[:3])
    np.testing.assert_array_equal(record["T_E0_inv"].reshape(3, 4), planner.start.T_E0_inv[:3])
    assert record["yaw0"] == pytest.approx(xi[5], abs=1e-12)
    np.testing.assert_array_equal(record["q0"], xi[6:])
    np.testing.assert_array_equal(as_record(memory, ak.ALLOCATION_MEMORY).share, planner._share)
    used = sum(ALLOCATION_PARAMETERS[name].itemsize for name in ALLOCATION_PARAMETERS.names) // 8
    assert not np.any(prm[used:]) and not np.any(memory[3:])


def test_pack_refuses_unreset_or_unknown() -> None:
    """Packing an allocation planner that was not reset, or of a method the kernel lacks, raises
    ValueError naming it."""
    with pytest.raises(ValueError, match="reset"):
        ak.pack_allocation(AllocationPlanner(MECHANISM, "dwa"), hold=False)
    planner = AllocationPlanner(MECHANISM, "conv3")
    xi = MECHANISM.working_state
    planner.reset(xi, TipTarget(MECHANISM.end_effector(xi), np.zeros(6)))
    with pytest.raises(ValueError, match="conv3"):
        ak.pack_allocation(planner, hold=False)


@pytest.mark.parametrize("engine", ENGINES)
def test_non_finite_target_is_a_planner_fault(engine: str, request: pytest.FixtureRequest) -> None:
    """A NaN target makes the allocation kernel step return the planner fault."""
    step = stepper(engine, request)
    xi = MECHANISM.working_state
    planner = AllocationPlanner(MECHANISM, "dwa")
    planner.reset(xi, TipTarget(MECHANISM.end_effector(xi), np.zeros(6)))
    prm, memory = ak.pack_allocation(planner, hold=False)
    target = pack_target(TipTarget(MECHANISM.end_effector(xi), np.zeros(6)))
    as_record(target, lay.TARGET).p_d[0] = np.nan
    v, diag = np.empty(9), np.zeros(lay.N_HYBRID_DIAGNOSTICS)
    assert step(xi, target, prm, memory, CONST, DT, v, diag) == lay.FAULT_PLANNER


def test_primitives_match_twin(rng: np.random.Generator) -> None:
    """Legs, manipulability, reachable range, gangway inverse, so3_exp and se3_log of one lane
    equal the batched twin functions, inside and outside the leg stroke."""
    states = np.concatenate([random_hybrid_states(rng, 20), random_hybrid_states(rng, 10, 1.0)])
    states = np.concatenate([states, np.array(list(STARTS.values()))])
    vectors, lengths, R, reach, q = np.empty((6, 3)), np.empty(6), np.empty((3, 3)), *(
        np.empty(3) for _ in range(2))  # fmt: skip
    J = np.empty((6, 6))
    for xi in states:
        T = pose_to_transform(xi[:6])
        legs = MECHANISM.stewart.legs(xi[:6])
        leg_vectors_lane(T[:3, :3], T[:3, 3], BASE, PLATFORM, vectors, lengths)
        np.testing.assert_allclose(vectors, legs.vectors, atol=1e-12)
        np.testing.assert_allclose(lengths, legs.lengths, atol=1e-12)
        manip = manipulability_lane(T[:3, :3], vectors, lengths, PLATFORM, J)
        assert manip == pytest.approx(MECHANISM.manipulability(xi), rel=1e-12)
        reachable_range_lane(vectors, lengths, STEWART.leg_min, STEWART.leg_max, reach)
        np.testing.assert_allclose(reach, reachable_range(MECHANISM, xi[:6]), atol=1e-12)
        tip = MECHANISM.gangway.forward(xi[6:])[:3, 3]
        gangway_inverse_lane(*tip, GANGWAY.d1, GANGWAY.a1, q)
        np.testing.assert_allclose(q, xi[6:], atol=1e-12)
        so3_exp_lane(*xi[3:6], R)
        np.testing.assert_allclose(R, so3_exp(xi[3:6]), atol=1e-14)
        relative = invert_transform(pose_to_transform(states[0, :6])) @ T
        twist = np.empty(6)
        se3_log_lane(relative[:3, :3], relative[:3, 3], twist)
        np.testing.assert_allclose(twist, se3_log(relative), atol=1e-12)
    so3_exp_lane(1e-10, -2e-10, 3e-10, R)  # the small-angle branch
    np.testing.assert_allclose(R, so3_exp(np.array([1e-10, -2e-10, 3e-10])), atol=1e-15)

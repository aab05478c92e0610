"""The qp lane step (twin.planners.qp_step), which the planner object runs (its matrices are
judged against independent checks in tests/planners/test_qp.py): compiled and interpreted it
writes the same QP, packs only what it assembles, and its lanes step in the hybrid runner as
an independent solver (DAQP) of the same QP says, integrated on SE(3) by scipy's `expm`."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tests.conftest import random_hybrid_states
from tests.sim.oracle import integrate, pack_target
from twin.errors import TwinError
from twin.mechanisms import HybridBoardingSystem
from twin.planners import HYBRID_RATE_LIMITS, PlannerParameters, TipTarget, get_planner
from twin.planners import qp_step as kq
from twin.planners.families import QP_PARAMETERS
from twin.planners.parameters import as_record, as_records, parameter_record
from twin.planners.qp import (
    JointLimit,
    LegStrokeLimit,
    QPPlanner,
    RateLimit,
)
from twin.planners.tasks import JointPostureTask, PlatformYawTask, TipPoseTask
from twin.sim.faults import Fault
from twin.sim.kernels import layout
from twin.sim.kernels.hybrid import hybrid_constants
from twin.sim.kernels.hybrid_runner import compiled_hybrid_qp, run_hybrid_qp
from twin.sim.kernels.records import N_TIP
from twin.spatial import so3_exp

H = HybridBoardingSystem()
CONST = hybrid_constants(H, HYBRID_RATE_LIMITS)
N = kq.N_QP_ROWS


def build(parameters: PlannerParameters, xi0: np.ndarray) -> QPPlanner:
    return get_planner("qp", "hybrid").build(H, parameters, xi0)


def random_parameters(rng: np.random.Generator) -> PlannerParameters:
    return PlannerParameters(
        k_e=rng.uniform(0, 50), w_orientation=rng.uniform(0, 100),
        w_secondary=rng.uniform(0, 1), limit_gain=rng.uniform(0.05, 1),
        qp_damping=rng.uniform(1e-4, 1), beta=rng.uniform(0, 1), l=rng.uniform(0, 4),
        k_a2=rng.uniform(0, 50), yaw_hold=rng.uniform(0, 1),
    )  # fmt: skip


def random_target(xi: np.ndarray, rng: np.random.Generator) -> TipTarget:
    T = H.end_effector(xi)
    T[:3, 3] += rng.uniform(-0.3, 0.3, 3)
    T[:3, :3] = so3_exp(rng.uniform(-0.3, 0.3, 3)) @ T[:3, :3]
    return TipTarget(T, rng.uniform(-1, 1, 6))


def kernel_problem(
    xi: np.ndarray, row: np.ndarray, prm: np.ndarray, dt: float
) -> tuple[np.ndarray, ...]:
    """(H, f, A, lower, upper) of one lane from `qp_problem_lane` (interpreted: the compiled
    one is held to it by the chunk test below)."""
    Hk, f = np.empty((9, 9)), np.empty(9)
    A, lower, upper = np.empty((N, 9)), np.empty(9 + N), np.empty(9 + N)
    kq.qp_problem_lane(xi, row, prm, CONST, dt, Hk, f, A, lower, upper, kq.problem_work())
    return Hk, f, A, lower, upper


def test_the_object_runs_the_lane_compiled_as_interpreted(rng: np.random.Generator) -> None:
    """`QPPlanner.problem` (the compiled lane over a batch, `QP_PROBLEM`) gives the H, f, A and
    bounds `qp_problem_lane` writes interpreted (the fallback without numba) to 1e-12 (relative
    to their size) on random states (in and out of the limits), targets, knobs and control
    periods; a batch of states gives each state's problem."""
    states = np.concatenate([random_hybrid_states(rng, 30), random_hybrid_states(rng, 10, 1.3)])
    for xi in states:
        p = random_parameters(rng)
        planner = build(p, rng.uniform(H.lower, H.upper))
        target = random_target(xi, rng)
        dt = float(rng.choice([0.005, 0.05, 0.2]))
        want = planner.problem(xi, target, dt)
        prm = kq.pack_qp(planner, False)
        got = kernel_problem(xi, pack_target(target), prm, dt)
        for name, a, b in zip(("H", "f", "A", "lower", "upper"), got, want[:5], strict=True):
            scale = max(1.0, float(np.max(np.abs(b))))
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * scale, err_msg=name)
        assert parameter_record(prm, QP_PARAMETERS).position == want.position_weight
    planner = build(PlannerParameters(), H.working_state)
    target = random_target(H.working_state, rng)
    batch = planner.problem(states, target, 0.05)
    for k in (0, len(states) - 1):
        one = planner.problem(states[k], target, 0.05)
        for a, b in zip(batch[:5], one[:5], strict=True):
            np.testing.assert_array_equal(a[k], b)


def run_lanes(
    xi0: np.ndarray, targets: np.ndarray, prm: np.ndarray, dt: float, compiled: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(xs, diag, faults) of the qp runner (compiled serial, or the plain `run_hybrid_qp`)
    over lanes prm (N, N_PARAMETERS) from xi0 through targets (N, B, N_TARGET)."""
    N, B = targets.shape[:2]
    xs = np.empty((N, B + 1, 9))
    xs[:, 0] = xi0
    diag = np.zeros((N, B + 1, layout.N_HYBRID_DIAGNOSTICS))  # row k + 1: step k's
    faults = np.zeros((N, B), dtype=np.int64)
    run = compiled_hybrid_qp(False) if compiled else run_hybrid_qp
    run(xs, targets, prm, np.zeros((N, layout.N_MEMORY)), CONST, dt, diag, faults, 1,
        np.zeros((N, B + 1, 6)), np.zeros((N, B + 1, N_TIP)))  # fmt: skip
    return xs, diag, faults


def test_a_chunk_steps_as_daqp_solves(rng: np.random.Generator) -> None:
    """The hybrid runner (compiled and plain: the same numbers) over 40 steps of a moving
    target, two qp lanes (record and hold): each step from the runner's state is the rate
    the planner object with DAQP as its solver (a library, the engine's solver before issue
    29) finds for that state, integrated for dt (scipy's `expm`), to 1e-7, at DAQP's level;
    never shortened (its limits are its own), INFEASIBLE exactly on level 2."""
    xi0 = H.working_state + 0.6 * np.r_[0, 0, 0, 0, 0, 1, 1, 1, 0] * (H.upper - H.working_state)
    n, dt = 40, 0.05
    targets = np.empty((2, n, layout.N_TARGET))
    tips = []
    T = H.end_effector(xi0)
    for k in range(n):
        moved = T.copy()
        moved[:3, 3] += [0.6 * np.sin(0.3 * k), 0.4 * np.cos(0.2 * k), 0.3 * np.sin(0.25 * k)]
        turn = np.array([0.1 * np.sin(0.2 * k), 0.08 * np.cos(0.3 * k), 0.0])
        moved[:3, :3] = so3_exp(turn) @ T[:3, :3]
        tips.append(TipTarget(moved, np.r_[0.3, -0.2, 0.1, 0.05, 0.0, 0.02]))
        targets[:, k] = pack_target(tips[-1])
    planner = build(PlannerParameters(), xi0)
    daqp = replace(planner, solver="daqp")
    prm = np.stack([kq.pack_qp(planner, False), kq.pack_qp(planner, True)])
    xs, diag, faults = run_lanes(xi0, targets, prm, dt, True)
    for got, want in zip(run_lanes(xi0, targets, prm, dt, False), (xs, diag, faults),
                         strict=True):  # fmt: skip
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    assert not diag[:, 0].any()  # row 0, the chunk's start, is left alone
    diag = as_records(diag[:, 1:], layout.HYBRID_DIAGNOSTICS)  # by name
    assert np.all(diag["limit_scale"] == 1.0)
    for lane in range(2):
        for k in range(n):
            x, out = xs[lane, k], daqp.step(xs[lane, k], tips[k], dt)
            want = integrate(x, out.velocity, dt)
            np.testing.assert_allclose(xs[lane, k + 1], want, rtol=0, atol=1e-7, err_msg=f"k={k}")
            level = out.diagnostics["qp_level"]
            assert diag["qp_level"][lane, k] == level
            assert faults[lane, k] == (Fault.INFEASIBLE if level == 2 else 0)
    assert diag["qp_active"].max() > 0  # the limits did bind
    np.testing.assert_array_equal(xs[0], xs[1])  # `hold` has nothing to hold


def test_the_lanes_faults() -> None:
    """In the runner, a qp lane with a NaN target is held (PLANNER, scale 0, no active rows)
    and one started 0.2-0.3 m past the stroke solves level 2 (INFEASIBLE) and still moves."""
    past = H.working_state.copy()
    past[2], past[3] = 3.595, 0.3
    planner = build(PlannerParameters(), H.working_state)
    prm = kq.pack_qp(planner, False)[None]
    nan = np.full((1, 2, layout.N_TARGET), np.nan)
    xs, diag, faults = run_lanes(H.working_state, nan, prm, 0.05, False)
    assert np.all(faults == Fault.PLANNER)
    np.testing.assert_array_equal(xs[0, 2], H.working_state)
    named = as_records(diag[0, 1:], layout.HYBRID_DIAGNOSTICS)
    assert not named["limit_scale"].any() and not named["qp_active"].any()
    held = pack_target(TipTarget(H.end_effector(past), np.zeros(6)))
    xs, diag, faults = run_lanes(past, np.tile(held, (1, 2, 1)), prm, 0.05, False)
    assert faults[0, 0] == Fault.INFEASIBLE
    assert as_record(diag[0, 1], layout.HYBRID_DIAGNOSTICS).qp_level == 2
    assert H.leg_lengths(xs[0, 1]).max() < H.leg_lengths(past).max()


def test_the_fault_bit_and_rows() -> None:
    """The QP kernel's fault code, parameter size, diagnostic row and kind agree with the layout and
    are distinct."""
    assert layout.FAULT_INFEASIBLE == Fault.INFEASIBLE
    assert QP_PARAMETERS.itemsize == 8 * layout.N_PARAMETERS
    assert {"qp_level", "qp_active"} <= set(layout.HYBRID_DIAGNOSTICS.names)
    assert layout.HYBRID_DIAGNOSTICS.itemsize == 8 * layout.N_HYBRID_DIAGNOSTICS
    assert layout.KIND_QP not in (layout.KIND_DIFFERENTIAL, layout.KIND_ALLOCATION,
                                  layout.KIND_PLATFORM)  # fmt: skip


def test_packing_refuses_what_the_kernel_cannot_assemble() -> None:
    """TwinError for a planner the kernel would assemble wrongly, instead of wrong numbers."""
    good = build(PlannerParameters(), H.working_state)
    legs, joints = good.limits
    rate = RateLimit(HYBRID_RATE_LIMITS)
    tip = good.tip
    posture, yaw = good.secondary
    other = HybridBoardingSystem(working_state=H.working_state + 0.1)
    refused = [
        QPPlanner(tip, (joints, legs), rate),
        QPPlanner(tip, (legs,), rate),
        QPPlanner(tip, (legs, JointLimit(other.lower, other.upper, HYBRID_RATE_LIMITS)), rate),
        QPPlanner(tip, (legs, joints), RateLimit(HYBRID_RATE_LIMITS * 2)),
        QPPlanner(tip, (LegStrokeLimit(H, HYBRID_RATE_LIMITS, gain=0.0), joints), rate),
        QPPlanner(tip, (legs, joints), RateLimit(np.r_[np.ones(8), 0.0])),
        QPPlanner(tip, (legs, joints), rate, secondary=(yaw, posture)),
        QPPlanner(tip, (legs, joints), rate, secondary=(posture, posture)),
        QPPlanner(tip, (legs, joints), rate, secondary=(JointPostureTask(index=9, setpoint=0),)),
        QPPlanner(tip, (legs, joints), rate, orientation_weight=-1.0),
        QPPlanner(TipPoseTask(other), (legs, joints), rate),
        get_planner("mtmp", "hybrid").build(H, PlannerParameters(), H.working_state),
        QPPlanner(tip, (legs, joints), rate, solver="daqp"),  # a library: not in a lane
        QPPlanner(tip, (legs, joints), rate, damping=0.0),  # not strictly convex
    ]
    for planner in refused:
        with pytest.raises(TwinError):
            kq.pack_qp(planner, False)
    kq.pack_qp(QPPlanner(tip, (legs, joints), rate, secondary=(PlatformYawTask(0.0),)), False)
    kq.pack_qp(QPPlanner(tip, (legs, joints), rate), True)


def test_the_limits_rows_are_the_lanes() -> None:
    """`LegStrokeLimit.rows` and `JointLimit.rows` are the rows `qp_problem_lane` writes for
    the planner (its A's rows 3-8 and 9-17 and their bounds), exactly: one statement."""
    planner = build(PlannerParameters(limit_gain=0.3), H.working_state)
    xi = H.working_state + 0.05
    target = random_target(xi, np.random.default_rng(3))
    problem = planner.problem(xi, target, 0.05)
    legs, joints = (limit.rows(xi, 0.05) for limit in planner.limits)
    for got, rows in ((legs, slice(3, 9)), (joints, slice(9, N))):
        np.testing.assert_array_equal(got.C, problem.A[rows])
        np.testing.assert_array_equal(got.lower, problem.lower[9:][rows])
        np.testing.assert_array_equal(got.upper, problem.upper[9:][rows])

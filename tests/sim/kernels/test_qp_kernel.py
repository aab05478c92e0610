"""The qp kernel (twin.sim.kernels.qp) assembles the planner object's QP to 1e-9, packs only
what it assembles, and guards its steps as `run_hybrid` does."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import random_hybrid_states
from tests.sim.oracle import hybrid_advance, pack_target
from twin.errors import TwinError
from twin.mechanisms import HybridBoardingSystem
from twin.planners import HYBRID_RATE_LIMITS, PlannerParameters, TipTarget, get_planner
from twin.planners.qp import JointLimit, LegStrokeLimit, QPPlanner, RateLimit, solve_levels
from twin.planners.tasks import JointPostureTask, PlatformYawTask, TipPoseTask
from twin.sim.faults import Fault
from twin.sim.kernels import layout
from twin.sim.kernels import qp as kq
from twin.sim.kernels.hybrid import hybrid_constants
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
    prepare: object, xi: np.ndarray, row: np.ndarray, prm: np.ndarray, dt: float
) -> tuple[np.ndarray, ...]:
    """(H, f, A, lower, upper) of one lane from `qp_prepare` (compiled or plain)."""
    xs = np.array([[xi, xi]])
    Hk, f = np.empty((1, 9, 9)), np.empty((1, 9))
    A, lower, upper = np.empty((1, N, 9)), np.empty((1, 9 + N)), np.empty((1, 9 + N))
    prepare(xs, 0, row[None, None], prm[None], CONST, dt, Hk, f, A, lower, upper)
    return Hk[0], f[0], A[0], lower[0], upper[0]


@pytest.fixture(params=["compiled", "plain"])
def prepare(request: pytest.FixtureRequest) -> object:
    return kq.compiled_qp()[0] if request.param == "compiled" else kq.qp_prepare


def test_the_kernel_assembles_the_planners_qp(
    prepare: object, rng: np.random.Generator
) -> None:
    """H, f, A and the bounds equal `QPPlanner.problem`'s to 1e-9 (relative to their size) on
    random states (in and out of the limits), targets, knobs and control periods."""
    states = np.concatenate([random_hybrid_states(rng, 30), random_hybrid_states(rng, 10, 1.3)])
    for xi in states:
        p = random_parameters(rng)
        planner = build(p, rng.uniform(H.lower, H.upper))
        target = random_target(xi, rng)
        dt = float(rng.choice([0.005, 0.05, 0.2]))
        want = planner.problem(xi, target, dt)
        prm = kq.pack_qp(planner, False)
        got = kernel_problem(prepare, xi, pack_target(target), prm, dt)
        for name, a, b in zip(("H", "f", "A", "lower", "upper"), got, want[:5], strict=True):
            scale = max(1.0, float(np.max(np.abs(b))))
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * scale, err_msg=name)
        assert prm[kq.P_QP_POSITION] == want.position_weight


def test_a_chunk_equals_the_planner_stepped(rng: np.random.Generator) -> None:
    """`run_qp` (compiled and plain) over 40 steps of a moving target, two lanes (record and
    hold), equals `hybrid_advance` of the planner object step by step: states to 1e-9, the
    level, the active count, the limit scale, the fault bits."""
    xi0 = H.working_state + 0.6 * np.r_[0, 0, 0, 0, 0, 1, 1, 1, 0] * (H.upper - H.working_state)
    n, dt = 40, 0.05
    targets = np.empty((2, n, layout.N_TARGET))
    T = H.end_effector(xi0)
    for k in range(n):
        moved = T.copy()
        moved[:3, 3] += [0.6 * np.sin(0.3 * k), 0.4 * np.cos(0.2 * k), 0.3 * np.sin(0.25 * k)]
        turn = np.array([0.1 * np.sin(0.2 * k), 0.08 * np.cos(0.3 * k), 0.0])
        moved[:3, :3] = so3_exp(turn) @ T[:3, :3]
        targets[:, k] = pack_target(TipTarget(moved, np.r_[0.3, -0.2, 0.1, 0.05, 0.0, 0.02]))
    planner = build(PlannerParameters(), xi0)
    prm = np.stack([kq.pack_qp(planner, False), kq.pack_qp(planner, True)])
    for compiled in (True, False):
        xs = np.empty((2, n + 1, 9))
        xs[:, 0] = xi0
        diag = np.zeros((2, n + 1, layout.N_HYBRID_DIAGNOSTICS))  # row k + 1: step k's
        faults = np.zeros((2, n), dtype=np.int64)
        kq.run_qp(xs, targets, prm, CONST, dt, diag, faults, compiled)
        assert not diag[:, 0].any()  # row 0, the chunk's start, is left alone
        diag = diag[:, 1:]
        for lane, hold in enumerate((False, True)):
            x = xi0.copy()
            for k in range(n):
                target = TipTarget(np.eye(4), np.zeros(6))
                target.transform[:3, :3] = targets[lane, k, :9].reshape(3, 3)
                target.transform[:3, 3] = targets[lane, k, 9:12]
                target.twist[:] = targets[lane, k, 12:]
                out = hybrid_advance(planner, H, x, target, dt, hold)
                x = out.x
                np.testing.assert_allclose(xs[lane, k + 1], x, rtol=0, atol=1e-9)
                assert diag[lane, k, layout.D_QP_LEVEL] == out.diagnostics["qp_level"]
                assert diag[lane, k, layout.D_QP_ACTIVE] == out.diagnostics["qp_active"]
                assert diag[lane, k, layout.D_LIMIT_SCALE] == out.scale
                assert faults[lane, k] == out.faults
        assert diag[:, :, layout.D_QP_ACTIVE].max() > 0  # the limits did bind


def test_the_guard() -> None:
    """`qp_finish_lane`: a NaN rate holds the state (PLANNER, scale 0, no active rows); level 2
    sets INFEASIBLE; in hold mode a step past a limit is shortened (JOINT_LIMIT), as
    `run_hybrid`'s guard does."""
    xi = H.working_state.copy()
    A, lower, upper = np.zeros((N, 9)), np.full(9 + N, -1.0), np.full(9 + N, 1.0)
    d = np.zeros(layout.N_HYBRID_DIAGNOSTICS)
    x_next = np.empty(9)
    bits = kq.qp_finish_lane(xi, np.full(9, np.nan), 2, False, CONST, 0.05, A, lower, upper,
                             x_next, d)  # fmt: skip
    assert bits == Fault.PLANNER | Fault.INFEASIBLE
    np.testing.assert_array_equal(x_next, xi)
    assert d[layout.D_LIMIT_SCALE] == 0.0 and d[layout.D_QP_LEVEL] == 2
    at_top = xi.copy()
    at_top[8] = H.upper[8] - 1e-3
    v = np.r_[np.zeros(8), 1.0]  # 5 cm further out in one step
    bits = kq.qp_finish_lane(at_top, v, 0, True, CONST, 0.05, A, lower, upper, x_next, d)
    assert bits == Fault.JOINT_LIMIT and 0 < d[layout.D_LIMIT_SCALE] < 0.03
    assert x_next[8] <= H.upper[8]
    bits = kq.qp_finish_lane(at_top, v, 1, False, CONST, 0.05, A, lower, upper, x_next, d)
    assert bits == 0 and x_next[8] == pytest.approx(H.upper[8] + 0.049)


def test_the_fault_bit_and_rows() -> None:
    assert layout.FAULT_INFEASIBLE == Fault.INFEASIBLE
    assert kq.P_QP_END <= layout.N_PARAMETERS
    assert layout.D_QP_ACTIVE < layout.N_HYBRID_DIAGNOSTICS
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
    ]
    for planner in refused:
        with pytest.raises(TwinError):
            kq.pack_qp(planner, False)
    kq.pack_qp(QPPlanner(tip, (legs, joints), rate, secondary=(PlatformYawTask(0.0),)), False)
    kq.pack_qp(QPPlanner(tip, (legs, joints), rate), True)


def test_solve_levels_reads_the_kernels_arrays() -> None:
    """The arrays `run_qp` hands `solve_levels` are a `QPProblem` (views of one lane): the same
    rates as the planner's own problem."""
    planner = build(PlannerParameters(), H.working_state)
    target = random_target(H.working_state, np.random.default_rng(3))
    prm = kq.pack_qp(planner, False)
    arrays = kernel_problem(kq.qp_prepare, H.working_state, pack_target(target), prm, 0.05)
    from twin.planners.qp import QPProblem

    got = solve_levels(QPProblem(*arrays, prm[kq.P_QP_POSITION]))
    want = solve_levels(planner.problem(H.working_state, target, 0.05))
    assert got.level == want.level
    np.testing.assert_allclose(got.velocity, want.velocity, rtol=0, atol=1e-9)

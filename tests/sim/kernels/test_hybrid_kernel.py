"""The hybrid runner (`twin.sim.kernels.hybrid_runner`) and its primitives, judged on their own.

The planner objects run the same lane functions as the runner (issue 29), so they are no
oracle of it; the planners' velocities are held to the papers on the engine path in
tests/planners. Here each step's outcome is held to independent statements
(`tests.sim.oracle`): the joint-limit guard's contract (`Guard`: the step within the limits,
the longest that fits to the resolution measured from the outcomes, a non-finite velocity
held), the integration on SE(3) by scipy's `expm`, the rotations by scipy's `Rotation`, the
legs by seed 000 eq (5) from Table 1's hinges. The numba runner equals the plain-Python one
(the fallback without numba), serial and parallel, chunked and step by step.
"""

from __future__ import annotations

import itertools
from functools import cache

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tests.sim.oracle import (
    FIT_TOL,
    Guard,
    held_target,
    integrate,
    leg_lengths,
    limit_excess,
    pack_target,
    resolution_of,
    rotation,
)
from twin import spatial
from twin.errors import TwinError
from twin.mechanisms.hybrid import (
    HYBRID_CONSTANTS,
    HybridBoardingSystem,
    integrate_hybrid,
    tip_transform,
)
from twin.mechanisms.legs import leg_lengths_lane
from twin.planners import PlannerParameters, get_planner
from twin.planners import differential_step as ds
from twin.planners.differential import DifferentialPlanner
from twin.planners.families import DIFFERENTIAL_PARAMETERS
from twin.planners.limits import SlewPriority, VelocityLimit
from twin.planners.linalg import cholesky_lane, smallest_eigenvalue_bound
from twin.planners.parameters import as_record, as_records
from twin.planners.registry import HYBRID_RATE_LIMITS
from twin.planners.tasks import JointPostureTask, TipPoseTask
from twin.planners.weights import BetaSplit
from twin.sim.base_motion import BaseSamples
from twin.sim.faults import Fault
from twin.sim.kernels import hybrid as hk
from twin.sim.kernels import hybrid_runner, layout
from twin.sim.kernels.records import N_TIP
from twin.sim.target import held_targets
from twin.spatial import pose_to_transform

numba = pytest.importorskip("numba")

H = HybridBoardingSystem()
CONST = hk.hybrid_constants(H, HYBRID_RATE_LIMITS)
DT = 0.01
TOL = 1e-9
PLANNERS = ("pi", "wpi", "mtmp")
GUARD = Guard(H, DT)


def step_chunk(
    runner: object, xs: np.ndarray, targets: np.ndarray, prm: np.ndarray, memory: np.ndarray,
    diag: np.ndarray, faults: np.ndarray,
) -> None:  # fmt: skip
    """`runner` (`run_hybrid`'s signature) over the chunk, with the test's constants (the tips
    and errors it hands to the records are checked in tests/sim/kernels/test_hybrid_runner.py)."""
    N, S = xs.shape[:2]
    runner(xs, np.ascontiguousarray(targets), prm, memory, CONST, DT, diag, faults, 1,
           np.empty((N, S, 6)), np.empty((N, S, N_TIP)))  # fmt: skip


def base_samples(n: int, amplitude: float = 1.0) -> BaseSamples:
    """A smooth multi-axis base motion, n samples at DT [s] (heave up to 0.6 m, roll 3°)."""
    t = np.arange(n) * DT
    pose = amplitude * np.stack(
        [
            0.3 * np.sin(1.1 * t),
            0.2 * np.sin(0.9 * t + 0.3),
            0.6 * np.sin(0.8 * t + 1.0),
            0.05 * np.sin(0.7 * t),
            0.04 * np.sin(0.6 * t + 0.5),
            0.03 * np.sin(0.5 * t + 0.2),
        ],
        -1,
    )
    return BaseSamples(t, pose, pose_to_transform(pose))


def build(name: str, parameters: PlannerParameters, xi0: np.ndarray) -> DifferentialPlanner:
    return get_planner(name, "hybrid").build(H, parameters, xi0)


#: states (9,) [m, rad]: the working state, off-centre ones, next to joint limits (q1 inside
#: Algorithm 1's band, q2, d3 and the platform yaw near theirs, legs near their stroke's
#: ends), and one with legs beyond their stroke (the platform low and tilted: two legs shorter
#: than Table 1's 2.58 m, every joint inside Table 6)
STATES = {
    "working": H.working_state,
    "off_centre": H.working_state + np.array([0.3, -0.2, 0.25, 0.08, -0.1, 0.15, 0.2, -0.15, 2.0]),
    "off_centre_2": H.working_state
    + np.array([-0.5, 0.4, -0.3, -0.2, 0.12, -0.3, -0.35, 0.3, -1.5]),
    "near_joint_limit": np.r_[0, 0, 2.475, 0, 0, H.upper[5:8] - [0.01, 0.02, 1e-3], 16.5],
    "beyond_leg_limit": H.working_state + np.array([0, 0, -0.9, 0.1, 0.05, 0, 0.1, 0.05, -1.0]),
}


def helds(x: np.ndarray, base: BaseSamples) -> list[np.ndarray]:
    """Held tip poses ᴵT_E* for a run from x: the working state's tip, and the tip of x pushed
    20 % further from the working state (past the limits x is near: the planner then drives
    the joints and legs into them)."""
    pushed = x + 0.2 * (x - H.working_state)
    return [base.transform[0] @ H.end_effector(y) for y in (H.working_state, pushed)]


def differential(
    x: np.ndarray, target: np.ndarray, prm: np.ndarray, const: np.ndarray, v: np.ndarray,
    diag: np.ndarray,
) -> int:  # fmt: skip
    """`differential_velocity` in plain Python, with x's ᴮR_P and its scratch, finished by
    `damped_differential_velocity` where it needs the SVD (as `run_hybrid` does)."""
    R, work = np.empty((3, 3)), ds.differential_work()
    spatial.rpy_to_matrix_lane(x[3], x[4], x[5], R)
    record = prm.view(DIFFERENTIAL_PARAMETERS)[0]  # the row by name, as the runner reads it
    bits = ds.differential_velocity(x, R, target, record, const, DT, work, v, diag)
    if bits == ds.NEEDS_SVD:
        bits = ds.damped_differential_velocity(x, record, work, v, diag)
    return bits


def run_one(
    runner: object, x: np.ndarray, target: np.ndarray, prm: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, int]:
    """One step of `runner` (`run_hybrid`'s signature) on one lane; for the plain runner also
    the velocity of `differential` (the step's velocity, which the runner does not hand out).

    The compiled runner's velocity is not taken: a compiled copy of `differential_velocity`
    outside the runner would compile its whole inlined step again (48 s on a test worker, the
    suite's costliest compile). The compiled runner is held to the plain one by its next
    state (the velocity integrated over DT), diagnostics and fault bits; the velocity by the
    plain runner, which runs the same source.

    Returns:
        (next xi (9,), the runner's diag (16,), the velocity (9,) or None, the fault bits).
    """
    xs = np.empty((1, 2, 9))
    xs[0, 0] = x
    diag = np.zeros((1, 2, layout.N_HYBRID_DIAGNOSTICS))  # row 1: the step's
    faults = np.full((1, 1), -1, dtype=np.int64)
    memory = np.zeros((1, layout.N_MEMORY))
    step_chunk(runner, xs, target[None, None], prm[None], memory, diag, faults)
    assert not diag[0, 0].any()  # row 0, the chunk's start, is left alone
    if runner is not hybrid_runner.run_hybrid:
        return xs[0, 1], diag[0, 1], None, int(faults[0, 0])
    v, d = np.empty(9), np.zeros(layout.N_HYBRID_DIAGNOSTICS)
    bits = differential(x, target, prm, CONST, v, d)
    assert bits == faults[0, 0] & layout.FAULT_SINGULAR
    step = as_record(d, layout.HYBRID_DIAGNOSTICS)
    runner_diag = as_record(diag[0, 1], layout.HYBRID_DIAGNOSTICS)
    for name in ("weights", "null_space_share", "damping", "velocity_scale", "position_share"):
        np.testing.assert_array_equal(step[name], runner_diag[name])  # the planner's fields
    return xs[0, 1], diag[0, 1], v, int(faults[0, 0])


@cache
def guard_resolution() -> float:
    """The guard's resolution, measured from outcomes of `limit_scale_lane` (plain Python) on
    random states and fast velocities (`resolution_of`; not the package's bisection count)."""
    rng = np.random.default_rng(29)
    spread = np.r_[0.4, 0.4, 0.4, 0.3, 0.3, 0.3, 0.3, 0.3, 2.0]
    scales, R = [], np.empty((3, 3))
    for _ in range(60):
        x, v = H.working_state + rng.normal(size=9) * spread, rng.normal(size=9) * 30.0
        spatial.rpy_to_matrix_lane(x[3], x[4], x[5], R)
        scales.append(hk.limit_scale_lane(x, R, v, DT, CONST, hk.limit_work()))
    return resolution_of(np.array(scales))


def assert_step(
    compiled: object, x: np.ndarray, target: object, prm: np.ndarray, hold: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """One step of the compiled and of the plain runner from x towards `target` (a `TipTarget`
    or a kernel row): the two agree (next state, diagnostics to TOL, fault bits), and the
    plain runner's step keeps the guard's contract for its velocity (`Guard.check`).

    Returns:
        The plain runner's (next xi (9,), diag, velocity (9,), fault bits).
    """
    row = target if isinstance(target, np.ndarray) else pack_target(target)
    x1, d1, _, bits1 = run_one(compiled, x, row, prm)
    x2, d2, v, bits2 = run_one(hybrid_runner.run_hybrid, x, row, prm)
    np.testing.assert_allclose(x1, x2, rtol=0, atol=TOL)
    np.testing.assert_allclose(d1, d2, rtol=0, atol=TOL)
    assert bits1 == bits2
    assert v is not None
    s = float(as_record(d2, layout.HYBRID_DIAGNOSTICS).limit_scale)
    GUARD.check(x, x2, s, bits2, hold, v=v.copy(), resolution=guard_resolution())
    return x2, d2, v, bits2


@pytest.fixture(scope="module")
def compiled() -> object:
    return hybrid_runner.compiled_hybrid(False)


@pytest.mark.parametrize("hold", [False, True], ids=["record", "hold"])
@pytest.mark.parametrize("name", PLANNERS)
@pytest.mark.parametrize("state", list(STATES))
def test_one_step_keeps_the_guard(name: str, hold: bool, state: str, compiled: object) -> None:
    """One step from each state, for targets from the simulation's held target at several
    samples of a base motion: the compiled runner gives the plain one's numbers, and the step
    is the planner's velocity integrated on SE(3), shortened in `hold` mode to the longest
    that fits (`assert_step`)."""
    x = STATES[state]
    base = base_samples(400)
    prm = ds.pack_differential(build(name, PlannerParameters(), x), hold)
    for held, k in itertools.product(helds(x, base), (0, 57, 211, 398)):
        assert_step(compiled, x, held_target(held, base, k, DT), prm, hold)


def test_the_states_cover_the_limit_cases(compiled: object) -> None:
    """The test states are what their names say: legs beyond their stroke, joints near limits,
    and the hold mode shortens steps from both for the pushed held pose."""
    legs = leg_lengths(H, STATES["beyond_leg_limit"])
    assert np.any(legs < H.stewart.leg_min)
    assert np.all(limit_excess(H, STATES["beyond_leg_limit"])[:9] == 0)
    assert np.all(limit_excess(H, STATES["near_joint_limit"]) == 0)
    assert np.any(H.upper - STATES["near_joint_limit"] < 0.03)
    base = base_samples(3)
    shortened = {
        state: [
            as_record(assert_step(
                compiled, x, held_target(held, base, 0, DT),
                ds.pack_differential(build(name, PlannerParameters(), x), True), True,
            )[1], layout.HYBRID_DIAGNOSTICS).limit_scale < 1
            for name in PLANNERS
            for held in helds(x, base)
        ]
        for state, x in STATES.items()
    }  # fmt: skip
    assert any(shortened["near_joint_limit"])
    assert any(shortened["beyond_leg_limit"])


def run_chunk(
    runner: object, x0: np.ndarray, targets: np.ndarray, prm: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One lane through the target rows (m, 18) in one chunk: xs (m + 1, 9), the steps' diag
    (m, N_HYBRID_DIAGNOSTICS), fault bits (m,)."""
    m = targets.shape[0]
    xs = np.empty((1, m + 1, 9))
    xs[0, 0] = x0
    diag = np.zeros((1, m + 1, layout.N_HYBRID_DIAGNOSTICS))  # as the engine hands it in
    faults = np.empty((1, m), dtype=np.int64)
    step_chunk(runner, xs, targets[None], prm[None], np.zeros((1, layout.N_MEMORY)), diag, faults)
    return xs[0], diag[0, 1:], faults[0]


def assert_chunk_guarded(xs: np.ndarray, diag: np.ndarray, faults: np.ndarray, hold: bool) -> None:
    """Every step of a chunk keeps the guard's contract, its velocity read from the outcome."""
    scale = as_records(diag, layout.HYBRID_DIAGNOSTICS)["limit_scale"]
    for k in range(faults.size):
        s = float(scale[k])
        GUARD.check(xs[k], xs[k + 1], s, int(faults[k]), hold, resolution=guard_resolution())


@pytest.mark.parametrize("hold", [False, True], ids=["record", "hold"])
@pytest.mark.parametrize("name", PLANNERS)
def test_chunk_keeps_the_guard(name: str, hold: bool, compiled: object) -> None:
    """A 60-step chunk from next to the joint limits towards a held pose beyond them: every
    step keeps the guard's contract (`hold`: shortened to the longest that fits; `record`:
    never), the rate limit and the limits are met, and the plain-Python runner gives the
    same numbers."""
    n = 60
    base = base_samples(n + 1, amplitude=4.0)  # rough enough for the rate limit and Algorithm 1
    start = STATES["near_joint_limit"]
    held = helds(start, base)[1]  # ᴵT_E*, fixed at reset: beyond the limits start is near
    planner = build(name, PlannerParameters(), start)
    planner.reset(start, held_target(held, base, 0, DT))
    targets = np.stack([pack_target(held_target(held, base, k, DT)) for k in range(n)])
    engine = held_targets(held[None], base.pose[None], DT)[0]  # the engine's, batched
    np.testing.assert_allclose(engine, targets, rtol=0, atol=1e-10)  # twists: rounding / dt
    prm = ds.pack_differential(planner, hold)
    xs, diag, faults = run_chunk(compiled, start, targets, prm)
    assert_chunk_guarded(xs, diag, faults, hold)
    assert hold == bool(np.bitwise_or.reduce(faults) & Fault.JOINT_LIMIT)  # a limit is met
    assert np.any(as_records(diag, layout.HYBRID_DIAGNOSTICS)["velocity_scale"] < 1)  # rate limit
    passed = np.any([limit_excess(H, x) > FIT_TOL for x in xs])
    assert passed != hold
    for got, want in zip(run_chunk(hybrid_runner.run_hybrid, start, targets, prm),
                         (xs, diag, faults), strict=True):  # fmt: skip
        np.testing.assert_allclose(got, want, rtol=0, atol=TOL)


@pytest.mark.parametrize("name", PLANNERS)
def test_damping_zero_with_rank_deficient_weights(name: str, compiled: object) -> None:
    """β = 0 leaves only the gangway (J_W of rank 3); with λ_max = 0 `weighted_pinv` drops the
    lost singular values (its SVD form): a finite step, no SINGULAR, the platform still (but
    for the yaw, which Algorithm 1 hands beyond the slew's rate limit), the same numbers
    compiled and plain."""
    parameters = PlannerParameters(beta=0.0, damping=0.0)
    base = base_samples(100)
    held = base.transform[0] @ H.end_effector(H.working_state)
    for x in (STATES["working"], STATES["off_centre"]):
        prm = ds.pack_differential(build(name, parameters, x), False)
        for k in (3, 80):
            _, _, v, bits = assert_step(compiled, x, held_target(held, base, k, DT), prm, False)
            assert np.all(np.isfinite(v)) and not bits & Fault.SINGULAR
            if name != "pi":  # β reaches the weights
                assert np.all(v[:5] == 0)
            else:
                assert np.any(v[:5] != 0)


def test_chunk_in_and_out_of_the_damped_branch(compiled: object) -> None:
    """A chunk whose steps go in and out of the SVD branch (β = 0.036 by the joint limits: the
    damping test fails for steps 0-7, passes for 8-17, fails again after) keeps the guard's
    contract every step, and equals the same steps taken one chunk of one step at a time: the
    runner resumes a lane's loop after each damped step exactly where it left it."""
    n, parameters = 40, PlannerParameters(beta=0.036)
    base = base_samples(n + 1, amplitude=4.0)
    start = STATES["near_joint_limit"]
    held = helds(start, base)[0]
    planner = build("mtmp", parameters, start)
    planner.reset(start, held_target(held, base, 0, DT))
    targets = held_targets(held[None], base.pose[None], DT)[0]
    prm = ds.pack_differential(planner, True)
    for runner in (compiled, hybrid_runner.run_hybrid):
        xs, diag, faults = run_chunk(runner, start, targets, prm)
        singular = (faults & layout.FAULT_SINGULAR) > 0
        assert singular[:8].all() and not singular[8:18].any() and singular[18:].all()
        assert_chunk_guarded(xs, diag, faults, True)
        for k in range(n):
            one = run_chunk(runner, xs[k], targets[k : k + 1], prm)
            np.testing.assert_array_equal(one[0][1], xs[k + 1])
            np.testing.assert_array_equal(one[1][0], diag[k])
            assert one[2][0] == faults[k]


@pytest.mark.parametrize(("beta", "damping"), [(0.0, 0.05), (2e-5, 0.05), (2e-5, 0.0)])
@pytest.mark.parametrize("name", ["wpi", "mtmp"])
def test_damping_engages_near_a_singularity(
    name: str, beta: float, damping: float, compiled: object
) -> None:
    """σ_min(J_W) < ε (β → 0 starves the platform; J_W from the step's own weights and the
    task Jacobian, seed 000 eq (24)): λ > 0 and the SINGULAR bit; at β = 2e-5 λ lies strictly
    between 0 and λ_max (the smooth part of the filter); with λ_max = 0 the near-singular
    solve is undamped (no SINGULAR); compiled and plain agree, the guard holds."""
    parameters = PlannerParameters(beta=beta, damping=damping)
    base = base_samples(50)
    held = base.transform[0] @ H.end_effector(H.working_state)
    x = STATES["off_centre"]
    prm = ds.pack_differential(build(name, parameters, x), True)
    _, diag, v, bits = assert_step(compiled, x, held_target(held, base, 20, DT), prm, True)
    named = as_record(diag, layout.HYBRID_DIAGNOSTICS)
    sqrt_w = np.sqrt(named.weights)
    sigma_min = np.linalg.svd(H.task_jacobian(x) * sqrt_w, compute_uv=False)[-1]
    assert sigma_min < 0.01  # ε: the planner's filter is on
    assert bool(bits & Fault.SINGULAR) == (damping > 0)
    lam = named.damping
    assert 0 < lam <= damping or lam == damping == 0
    if beta > 0:
        assert lam < damping or damping == 0
    assert np.all(np.isfinite(v))


@pytest.mark.parametrize("field", [("R_d", 4), ("p_d", 1), ("twist", 5)], ids=str)
@pytest.mark.parametrize("name", PLANNERS)
def test_nan_target_holds_the_state(name: str, field: tuple[str, int], compiled: object) -> None:
    """A NaN in the target: the planner's velocity is not finite, so the lane is held (same
    xi), FAULT_PLANNER, limit scale 0, and the planner's weights (a function of the state
    alone) still reported: those of the same step towards the finite target."""
    base = base_samples(10)
    held = base.transform[0] @ H.end_effector(H.working_state)
    x = STATES["off_centre"]
    target = pack_target(held_target(held, base, 2, DT))
    prm = ds.pack_differential(build(name, PlannerParameters(), x), True)
    clean = assert_step(compiled, x, target, prm, True)[1]
    as_record(target, layout.TARGET)[field[0]][field[1]] = np.nan
    got_x, diag, v, bits = assert_step(compiled, x, target, prm, True)
    assert not np.all(np.isfinite(v))
    assert np.array_equal(got_x, x)
    assert bits & layout.FAULT_PLANNER and not bits & layout.FAULT_JOINT_LIMIT
    named = as_record(diag, layout.HYBRID_DIAGNOSTICS)
    clean_named = as_record(clean, layout.HYBRID_DIAGNOSTICS)
    assert named.limit_scale == 0.0
    assert np.all(np.isfinite(named.weights))
    np.testing.assert_array_equal(named.weights, clean_named.weights)


def test_lanes_are_independent_in_the_parallel_runner(compiled: object) -> None:
    """Six lanes (three planners × record/hold, different starts) in one parallel call equal
    each lane run alone by the serial runner."""
    parallel = hybrid_runner.compiled_hybrid(True)
    n, lanes = 25, [(name, hold) for name in PLANNERS for hold in (False, True)]
    base = base_samples(n + 1, amplitude=3.0)
    starts = list(STATES.values())
    xs = np.empty((len(lanes), n + 1, 9))
    targets = np.empty((len(lanes), n, layout.N_TARGET))
    prm = np.empty((len(lanes), layout.N_PARAMETERS))
    for i, (name, hold) in enumerate(lanes):
        xs[i, 0] = starts[i % len(starts)]
        held = base.transform[0] @ H.end_effector(xs[i, 0])
        targets[i] = [pack_target(held_target(held, base, k, DT)) for k in range(n)]
        prm[i] = ds.pack_differential(build(name, PlannerParameters(), xs[i, 0]), hold)
    memory = np.zeros((len(lanes), layout.N_MEMORY))
    diag = np.empty((len(lanes), n + 1, layout.N_HYBRID_DIAGNOSTICS))
    faults = np.empty((len(lanes), n), dtype=np.int64)
    step_chunk(parallel, xs, targets, prm, memory, diag, faults)
    for i in range(len(lanes)):
        one_xs, one_diag = xs[i : i + 1].copy(), np.empty_like(diag[i : i + 1])
        one_faults = np.empty_like(faults[i : i + 1])
        step_chunk(compiled, one_xs, targets[i : i + 1], prm[i : i + 1], memory[i : i + 1],
                   one_diag, one_faults)  # fmt: skip
        np.testing.assert_allclose(one_xs[0], xs[i], rtol=0, atol=TOL)
        np.testing.assert_allclose(one_diag[0, 1:, :12], diag[i, 1:, :12], rtol=0, atol=TOL)
        assert np.array_equal(one_faults[0], faults[i])


# ------------------------------------------------------------------------- shared primitives


@numba.njit(error_model="numpy")  # not cached: numba would not see an edit of the kernel
def _primitives(
    x: np.ndarray, v: np.ndarray, R: np.ndarray, dt: float, const: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
           float]:  # fmt: skip
    """Every shared primitive compiled, on one input."""
    T, G, w, rpy = np.empty((4, 4)), np.empty((4, 4)), np.empty(3), np.empty(3)
    R_out, x_next, legs, excess = np.empty((3, 3)), np.empty(9), np.empty(6), np.empty(15)
    spatial.so3_log_lane(R, w)
    spatial.matrix_to_rpy_lane(R, rpy)
    spatial.rpy_to_matrix_lane(x[3], x[4], x[5], R_out)  # x's ᴮR_P, which the others take
    c = const.view(HYBRID_CONSTANTS)[0]  # the constants by name
    tip_transform(x, R_out, c.d1, c.a1, G, T)
    integrate_hybrid(x, R_out, v, dt, x_next)
    leg_lengths_lane(R_out, x, c.base_hinges, c.platform_hinges, legs)
    hk.limit_excess_lane(x, R_out, const, excess)
    scale = hk.limit_scale_lane(x, R_out, v, dt, const, hk.limit_work())
    return T, w, rpy, R_out, x_next, legs, excess, scale


def _primitives_python(
    x: np.ndarray, v: np.ndarray, R: np.ndarray, dt: float, const: np.ndarray
) -> tuple:
    return _primitives.py_func(x, v, R, dt, const)


@pytest.mark.parametrize("run", [_primitives, _primitives_python], ids=["compiled", "python"])
def test_primitives_match_independent_statements(run: object, rng: np.random.Generator) -> None:
    """tip_transform (ᴮT_P from scipy's rotation, times the gangway's ᴾT_E), so3_log_lane
    (small, generic and near-π angles) and matrix_to_rpy_lane / rpy_to_matrix_lane against
    scipy's `Rotation`, integrate_hybrid against scipy's `expm`, leg_lengths_lane and
    limit_excess_lane against seed 000 eq (5) and Tables 1 and 6, and limit_scale_lane's
    outcome against the guard's contract (the step fits, the full one and one a resolution
    longer do not)."""
    spread = np.r_[0.4, 0.4, 0.4, 0.3, 0.3, 0.3, 0.3, 0.3, 2.0]
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    rotations = [1e-9 * axis, 1e-7 * axis, 0.3 * axis, 2.0 * axis, (np.pi - 1e-6) * axis]
    rotations += [np.pi * np.array([0.0, 0.0, 1.0]), (np.pi - 5e-5) * np.array([0.6, -0.8, 0])]
    shortened = 0
    for i in range(40):
        x = H.working_state + rng.normal(size=9) * spread
        v = rng.normal(size=9) * (30.0 if i % 2 else 0.3)
        rotvec = rotations[i % len(rotations)] if i < 14 else rng.normal(size=3)
        R = Rotation.from_rotvec(rotvec).as_matrix()
        T, w, rpy, R_out, x_next, legs, excess, scale = run(x, v, R, DT, CONST)
        T_BP = np.eye(4)
        T_BP[:3, :3], T_BP[:3, 3] = rotation(x[3:6]), x[:3]
        np.testing.assert_allclose(T, T_BP @ H.gangway.forward(x[6:]), rtol=0, atol=1e-12)
        want = Rotation.from_matrix(R).as_rotvec()
        near_pi = np.linalg.norm(want) > np.pi - 1e-3  # the logarithm's condition ~ 1/sin θ
        if near_pi:  # ±ω name the same rotation at π
            want = want if np.dot(want, w) >= 0 else -want
        np.testing.assert_allclose(w, want, rtol=0, atol=1e-8 if near_pi else 1e-12)
        np.testing.assert_allclose(rotation(rpy), R, rtol=0, atol=1e-12)
        np.testing.assert_allclose(R_out, rotation(x[3:6]), rtol=0, atol=1e-15)
        np.testing.assert_allclose(x_next, integrate(x, v, DT), rtol=0, atol=1e-12)
        np.testing.assert_allclose(legs, leg_lengths(H, x), rtol=0, atol=1e-12)
        np.testing.assert_allclose(excess, limit_excess(H, x), rtol=0, atol=1e-12)
        GUARD.check(x, integrate(x, scale * v, DT), scale, None, True, v=v,
                    resolution=guard_resolution())  # fmt: skip
        shortened += scale < 1
    assert shortened > 3  # the bisection ran


def test_constants_and_fault_bits() -> None:
    """`hybrid_constants` fields, read by name (Tables 1 and 6, the registry's rate limits),
    the fault bits equal `Fault`'s."""
    assert CONST.shape == (layout.N_HYBRID_CONSTANTS,)
    c = CONST.view(HYBRID_CONSTANTS)[0]
    np.testing.assert_array_equal(c.lower, H.lower)
    np.testing.assert_array_equal(c.upper, H.upper)
    np.testing.assert_array_equal(c.rate, HYBRID_RATE_LIMITS)
    assert (c.d1, c.a1) == (H.gangway.d1, H.gangway.a1)
    np.testing.assert_array_equal(c.base_hinges.reshape(6, 3), H.layout.base_hinges)
    np.testing.assert_array_equal(c.platform_hinges.reshape(6, 3), H.layout.platform_hinges)
    assert (c.leg_min, c.leg_max) == (2.58, 4.18)
    assert layout.FAULT_BASE_MOTION == Fault.BASE_MOTION
    assert layout.FAULT_PLANNER == Fault.PLANNER
    assert layout.FAULT_KINEMATICS == Fault.KINEMATICS
    assert layout.FAULT_JOINT_LIMIT == Fault.JOINT_LIMIT
    assert layout.FAULT_SINGULAR == Fault.SINGULAR


# ------------------------------------------------------------------------------------ packing


def test_every_registry_planner_packs(rng: np.random.Generator) -> None:
    """PI, WPI and MTMP pack for defaults, the range ends and random parameters in range; the
    row holds the knobs where the kernel reads them."""
    fields = PlannerParameters.model_fields
    corners = [PlannerParameters(), PlannerParameters(damping=0.0, beta=0.0),
               PlannerParameters(beta=1.0, l=0.0, k_e=0.0, k_a2=0.0)]  # fmt: skip
    for _ in range(20):
        values = {}
        for key in ("k_e", "beta", "l", "k_c", "sigma", "q1_rate_max", "k_a2", "damping"):
            low = max(m.ge for m in fields[key].metadata if hasattr(m, "ge")) if any(
                hasattr(m, "ge") for m in fields[key].metadata) else 1e-3  # fmt: skip
            high = next(m.le for m in fields[key].metadata if hasattr(m, "le"))
            values[key] = float(rng.uniform(low, high))
        corners.append(PlannerParameters(**values))
    for parameters in corners:
        for name in PLANNERS:
            planner = build(name, parameters, H.working_state)
            prm = ds.pack_differential(planner, name == "mtmp")
            assert prm.shape == (layout.N_PARAMETERS,)
            assert np.all(np.isfinite(prm))
            common = as_record(prm, layout.COMMON_PARAMETERS)
            assert common.kind == layout.KIND_DIFFERENTIAL
            assert common.hold == (name == "mtmp")
            record = prm.view(DIFFERENTIAL_PARAMETERS)[0]
            assert record["gain"] == parameters.k_e
            assert record["damping"] == parameters.damping
            assert record["joint_limits"] == record["slew"] == (name == "mtmp")
            assert record["posture_index"] == (7 if name == "mtmp" else -1)
            np.testing.assert_array_equal(record["rate"], HYBRID_RATE_LIMITS)


def test_packing_refuses_what_the_kernel_cannot_run() -> None:
    """TwinError for parts the kernel does not implement, instead of wrong numbers."""
    mtmp = build("mtmp", PlannerParameters(), H.working_state)
    tip = TipPoseTask(H)
    task = JointPostureTask(index=7, setpoint=0.0)
    refused = [
        DifferentialPlanner(tip, secondary=(task, task)),
        DifferentialPlanner(tip, weights=lambda q: np.ones(q.shape)),
        DifferentialPlanner(tip, epsilon=0.0),
        get_planner("dwa", "hybrid").build(H, PlannerParameters(), H.working_state),
        DifferentialPlanner(
            tip, weights=type(mtmp.weights)((mtmp.weights.parts[1], mtmp.weights.parts[1]))
        ),
        DifferentialPlanner(tip, weights=BetaSplit(-0.5)),
        DifferentialPlanner(tip, velocity_limit=VelocityLimit(np.r_[np.ones(8), 0.0])),
        DifferentialPlanner(tip, slew_priority=SlewPriority(-0.5, 0.5, 0.0, 0.2)),
        DifferentialPlanner(tip, slew_priority=SlewPriority(-0.5, 0.5, 0.1, 0.2, yaw_index=4)),
    ]
    for planner in refused:
        with pytest.raises(TwinError):
            ds.pack_differential(planner, False)


@numba.njit(error_model="numpy")  # not cached: numba would not see an edit of the kernel
def _factor_and_bound(A: np.ndarray, shift: float) -> tuple[bool, float, bool]:
    """`cholesky_lane` of A into a new L (whether it succeeded), the bound of L, and whether
    factoring a copy of A in place gave the same."""
    L, inplace = np.zeros((6, 6)), A.copy()
    ok = cholesky_lane(A, 6, shift, L)
    same = cholesky_lane(inplace, 6, shift, inplace) == ok
    for i in range(6):
        for j in range(i + 1):
            same = same and (not ok or inplace[i, j] == L[i, j])
    return ok, smallest_eigenvalue_bound(L) if ok else 0.0, same


@pytest.mark.parametrize("conditioning", [1.0, 1e3, 1e8])
def test_the_eigenvalue_bound_is_below_the_smallest_eigenvalue(conditioning: float) -> None:
    """`smallest_eigenvalue_bound` lies in [λ_min / 6, λ_min] (so a test it passes the shifted
    factorisation passes too), and the factorisation gives the same factor in place."""
    rng = np.random.default_rng(int(conditioning))
    for _ in range(50):
        Q = np.linalg.qr(rng.normal(size=(6, 6)))[0]
        eigenvalues = np.geomspace(1.0, conditioning, 6) * rng.uniform(0.5, 2.0)
        A = (Q * eigenvalues) @ Q.T
        A = (A + A.T) / 2
        ok, bound, same = _factor_and_bound(A, 0.0)
        lowest = np.linalg.eigvalsh(A)[0]
        assert ok and same
        assert lowest / 6 * (1 - 1e-9) <= bound <= lowest * (1 + 1e-9)
        assert _factor_and_bound(A, 0.5 * bound)[0]  # the shift the kernel skips at 2× clears
        assert not _factor_and_bound(A, 1.5 * lowest)[0]  # past λ_min the shifted one fails

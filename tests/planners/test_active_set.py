"""The compiled Goldfarb-Idnani solver (twin.planners.active_set) and the levels it solves
(`twin.planners.qp_levels.solve_levels_lane`) give DAQP's solutions and levels: on the `qp`
planner's own problems recorded from 200 s runs (as scripts/qp_solvers.py records them), and on
random strictly convex QPs; it reports infeasible constraints and a Hessian that is not
convex."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from tests.figures import record
from twin.planners import get_planner
from twin.planners.active_set import (
    INFEASIBLE,
    NOT_CONVEX,
    OPTIMAL,
    cholesky,
    equality_minimum,
    qp_work,
    solve_dense_qp,
)
from twin.planners.qp import QPProblem, solve_daqp, solve_levels
from twin.sim import Simulation
from twin.sim.base_motion import BaseMotion
from twin.sim.lanes import tip_target
from twin.sim.target import held_targets

#: the seas of scripts/qp_solvers.py (heading 150° there is the scenario default's sea here)
SEAS = ({"sea_state": 4.0}, {"hs": 3.0, "tp": 8.0}, {"hs": 4.0, "tp": 9.0})
#: every n-th step of a run is recorded (and every step that needed a fallback level)
EVERY = 5
#: the agreement asked of the two methods on x [m/s, rad/s]: both are exact active-set
#: methods on a strictly convex QP, so only rounding (and DAQP's primal tolerance on
#: inactive rows) separates them
TOLERANCE = 1e-7


@cache
def recorded_problems() -> tuple[list[QPProblem], list[QPProblem]]:
    """(the planner's problems along 200 s qp runs in three seas, sea seed 2: every 5th step
    and every step that needed a fallback; states 30-50 cm above one with a leg near its top,
    past the stroke), built deterministically from the engine's runs."""
    along, outside = [], []
    for sea in SEAS:
        sim = Simulation({"planner": "qp", "seed": 2, **sea})
        sim.run()
        series = sim.series()
        xi = series["xi"]
        planner = get_planner("qp", "hybrid").build(
            sim.mechanism, sim.scenario.parameters(), sim.lanes.x0[0]
        )
        t = np.arange(sim.n_steps + 1) * sim.dt
        poses = BaseMotion.of(sim.scenario).poses(t)
        rows = held_targets(sim.held, poses[None], sim.dt)[0]
        levels = series["qp_level"][1:]
        for k in range(sim.n_steps):
            if k % EVERY == 0 or levels[k] > 0:
                along.append(planner.problem(xi[k], tip_target(rows[k]), sim.dt))
        top = int(np.argmax(series["legs"].max(axis=1)))
        for dz in (0.3, 0.4, 0.5):
            moved = xi[top].copy()
            moved[2] += dz
            outside.append(planner.problem(moved, tip_target(rows[top]), sim.dt))
    return along, outside


def test_the_levels_agree_with_daqp_on_the_recorded_problems() -> None:
    """On every recorded problem the compiled solver's levels are DAQP's (`solve_levels` with
    "daqp") and its rates DAQP's to 1e-7; the records include steps whose position the limits
    make infeasible (level 1) and states where no rates meet the limits (level 2)."""
    along, outside = recorded_problems()
    problems = along + outside
    distance, levels = 0.0, np.zeros(3, dtype=int)
    for problem in problems:
        got = solve_levels(problem, "active_set")
        want = solve_levels(problem, "daqp")
        assert got.level == want.level
        np.testing.assert_allclose(got.velocity, want.velocity, rtol=0, atol=TOLERANCE)
        distance = max(distance, float(np.max(np.abs(got.velocity - want.velocity))))
        levels[got.level] += 1
    record("active_set_vs_daqp", problems=len(problems), levels=levels.tolist(),
           largest_distance=distance)  # fmt: skip
    assert len(along) > 2000
    assert levels[2] >= 3  # the states past the stroke reach level 2


def test_level_0_alone_agrees_with_daqp_directly() -> None:
    """`solve_dense_qp` on level 0 of each recorded problem: solved where DAQP solves it (to
    1e-7) and infeasible where DAQP finds it so."""
    along, _ = recorded_problems()
    infeasible = 0
    for H, f, A, lower, upper, _ in along:
        want = solve_daqp(H, f, A, upper, lower, 3)
        x = np.empty(9)
        status = solve_dense_qp(H, f, A, lower[:9], upper[:9], lower[9:], upper[9:], 3,
                                qp_work(9, A.shape[0]), x)  # fmt: skip
        assert (status == OPTIMAL) == (want is not None)
        if want is None:
            infeasible += 1
            assert status == INFEASIBLE
        else:
            np.testing.assert_allclose(x, want, rtol=0, atol=TOLERANCE)
    record("active_set_level_0", problems=len(along), infeasible=infeasible)


def test_random_strictly_convex_qps(rng: np.random.Generator) -> None:
    """Random QPs of 9 variables, a box, 0 or 3 equalities and 15 two-sided rows: the same
    verdict (solved or infeasible) and solution as DAQP, and the solution meets its
    constraints and is stationary (∇ = H x + f is a combination of the active normals)."""
    n, m = 9, 18
    solved = infeasible = 0
    for trial in range(200):
        M = rng.normal(size=(n, n))
        H = M @ M.T + 1e-2 * np.eye(n)
        f = 3 * rng.normal(size=n)
        A = rng.normal(size=(m, n))
        n_equal = 3 * (trial % 2)
        lower = np.r_[-np.ones(n), rng.uniform(-2, 0, m)]
        upper = np.r_[np.ones(n), rng.uniform(0, 2, m)]
        lower[n : n + n_equal] = upper[n : n + n_equal] = rng.normal(size=n_equal)
        want = solve_daqp(H, f, A, upper, lower, n_equal)
        x = np.empty(n)
        status = solve_dense_qp(H, f, A, lower[:n], upper[:n], lower[n:], upper[n:], n_equal,
                                qp_work(n, m), x)  # fmt: skip
        assert (status == OPTIMAL) == (want is not None)
        if want is None:
            infeasible += 1
            continue
        solved += 1
        np.testing.assert_allclose(x, want, rtol=0, atol=1e-8)
        z = np.r_[x, A @ x]
        assert np.all(z >= lower - 1e-9) and np.all(z <= upper + 1e-9)
        near = (np.abs(z - lower) < 1e-9) | (np.abs(z - upper) < 1e-9)
        normals = np.r_[np.eye(n), A][near]
        gradient = H @ x + f
        if normals.size:
            gradient -= normals.T @ np.linalg.lstsq(normals.T, gradient, rcond=None)[0]
        np.testing.assert_allclose(gradient, 0.0, atol=1e-8)
    assert solved > 50 and infeasible > 0


def test_inconsistent_constraints_and_a_nonconvex_hessian() -> None:
    """x₀ ≥ 1 by a row and x₀ ≤ 0.5 by the box: INFEASIBLE; two contradictory equalities:
    INFEASIBLE; an indefinite H: NOT_CONVEX."""
    H, f, x = np.eye(2), np.zeros(2), np.empty(2)
    box = np.full(2, -1.0), np.full(2, 0.5)
    A = np.array([[1.0, 0.0]])
    status = solve_dense_qp(H, f, A, *box, np.array([1.0]), np.array([np.inf]), 0,
                            qp_work(2, 1), x)  # fmt: skip
    assert status == INFEASIBLE
    A2 = np.array([[1.0, 1.0], [2.0, 2.0]])
    status = solve_dense_qp(H, f, A2, *box, np.array([0.2, 0.6]), np.array([0.2, 0.6]), 2,
                            qp_work(2, 2), x)  # fmt: skip
    assert status == INFEASIBLE
    status = solve_dense_qp(np.diag([1.0, -1.0]), f, A, *box, np.array([-1.0]),
                            np.array([1.0]), 0, qp_work(2, 1), x)  # fmt: skip
    assert status == NOT_CONVEX


@pytest.mark.parametrize("dependent", [True, False])
def test_a_redundant_equality_is_skipped(dependent: bool) -> None:
    """An equality that repeats another (consistent) is met and skipped; a repeated one that
    contradicts it is infeasible."""
    H, f, x = np.eye(2), np.array([1.0, -2.0]), np.empty(2)
    A = np.array([[1.0, 1.0], [2.0, 2.0]])
    b = np.array([0.3, 0.6 if dependent else 0.7])
    status = solve_dense_qp(H, f, A, np.full(2, -10.0), np.full(2, 10.0), b, b, 2,
                            qp_work(2, 2), x)  # fmt: skip
    if dependent:
        assert status == OPTIMAL and x.sum() == pytest.approx(0.3, abs=1e-12)
    else:
        assert status == INFEASIBLE


def test_the_equalities_shortcut_is_their_kkt_point(rng: np.random.Generator) -> None:
    """`equality_minimum` (the step where only the equalities bind) gives the minimum on the
    equalities alone, the KKT system's solution [H Aₑᵀ; Aₑ 0] [x; λ] = [−f; b], to 1e-9; it
    leaves an equality nearly a combination of the others to the method, which still meets it."""
    n, m = 9, 18
    for _ in range(50):
        M = rng.normal(size=(n, n))
        H = M @ M.T + 1e-2 * np.eye(n)
        f, A, b = rng.normal(size=n), rng.normal(size=(m, n)), rng.normal(size=m)
        kkt = np.block([[H, A[:3].T], [A[:3], np.zeros((3, 3))]])
        want = np.linalg.solve(kkt, np.r_[-f, b[:3]])[:n]
        work, x = qp_work(n, m), np.empty(n)
        assert cholesky(H, n, work[1], work[7])
        assert equality_minimum(A, f, b, n, 3, work, x)
        np.testing.assert_allclose(x, want, rtol=0, atol=1e-9 * (1 + np.abs(want).max()))
        # the third equality nearly the others' combination: its part outside their span
        # (in the metric of H) 1e-5 of it, 1e-10 squared: between DEPENDENT_TOL and SHORTCUT_TOL
        Y = np.linalg.solve(np.linalg.cholesky(H), np.c_[A[:2].T, A[0] - 2 * A[1], A[2]])
        span = Y[:, :2] @ np.linalg.lstsq(Y[:, :2], Y[:, 3], rcond=None)[0]
        away = (Y[:, 3] - span) / np.linalg.norm(Y[:, 3] - span)
        A[2] = A[0] - 2 * A[1] + 1e-5 * np.linalg.norm(Y[:, 2]) * (np.linalg.cholesky(H) @ away)
        b[:3] = A[:3] @ rng.uniform(-0.1, 0.1, n)  # consistent
        assert cholesky(H, n, work[1], work[7])
        assert not equality_minimum(A, f, b, n, 3, work, x)
        far = np.full(n, 1e3)
        rows = np.full(m, 1e3)
        rows[:3] = b[:3]
        status = solve_dense_qp(H, f, A, -far, far, np.r_[b[:3], -rows[3:]], rows, 3, work, x)
        assert status == OPTIMAL
        np.testing.assert_allclose(A[:3] @ x, b[:3], rtol=0, atol=1e-8)

"""Which QP library solves the `qp` planner's step: DAQP, ProxQP or quadprog, measured.

    python scripts/qp_solvers.py          # about a minute; prints markdown tables

The problems are the planner's own (`twin.planners.qp.QPPlanner.problem`) at the states of
200 s `qp` runs in three seas (WMO sea state 4; Hs 3 m, Tp 8 s; Hs 4 m, Tp 9 s; heading 150°,
sea seed 2), every 5th step and every step that needed a fallback, plus states moved 30-50 cm
past a leg's stroke, where no rates within the box meet every limit. Each library is called through
qpsolvers (the same wrapper for all: one-sided rows G v ≤ h, equalities, a box), DAQP also
directly (`twin.planners.qp.solve_daqp`, what the engine calls). Reported per library:

- time per solve on the feasible problems (median and 99th percentile);
- how often it returned no solution where DAQP found one, and its largest distance to DAQP's
  solution and largest constraint violation (a strictly convex QP has one solution);
- on the problems whose position equality the limits make infeasible (level 0 fails), and on
  those whose limits no rates in the box meet (level 1 fails too), how often it said so, and
  the time it took;
- the engine: `simulate()` of 200 s at WMO 4 (end to end, per step), which solves with the
  compiled "active_set" in the lane (issue 29).

docs/decisions.md ("The qp planner's solver") quotes the tables.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from twin.planners import get_planner
from twin.planners.qp import INF, SOLVERS, QPProblem, solve_daqp, solve_qpsolvers
from twin.sim.base_motion import BaseMotion
from twin.sim.engine import Simulation
from twin.sim.lanes import tip_target
from twin.sim.target import held_targets

SEAS = {
    "WMO 4": {"sea_state": 4.0},
    "Hs 3, Tp 8": {"hs": 3.0, "tp": 8.0},
    "Hs 4, Tp 9": {"hs": 4.0, "tp": 9.0},
}
#: every n-th step of a run becomes a test problem
EVERY = 5


def problems() -> tuple[list[QPProblem], list[QPProblem], list[QPProblem]]:
    """(problems whose level 0 is feasible for DAQP, those whose level 0 is not, those whose
    limits are not: level 1 infeasible)."""
    feasible, infeasible, outside = [], [], []
    for sea in SEAS.values():
        sim = Simulation({"planner": "qp", "seed": 2, **sea})
        sim.run()
        xi = sim.series()["xi"]
        planner = get_planner("qp", "hybrid").build(
            sim.mechanism, sim.scenario.parameters(), sim.lanes.x0[0]
        )
        t = np.arange(sim.n_steps + 1) * sim.dt
        poses = BaseMotion.of(sim.scenario).poses(t)
        rows = held_targets(sim.held, poses[None], sim.dt)[0]
        levels = sim.series()["qp_level"][1:]
        for k in range(sim.n_steps):
            if k % EVERY and levels[k] == 0:
                continue
            problem = planner.problem(xi[k], tip_target(rows[k]), sim.dt)
            if level0(problem, "daqp") is None:
                infeasible.append(problem)
            else:
                feasible.append(problem)
        # past the stroke: the platform 30-50 cm higher than a state with a leg near its top
        top = np.argmax(sim.series()["legs"].max(axis=1))
        for dz in (0.3, 0.4, 0.5):
            moved = xi[top].copy()
            moved[2] += dz
            problem = planner.problem(moved, tip_target(rows[top]), sim.dt)
            if level1(problem, "daqp-direct") is None:
                outside.append(problem)
    return feasible, infeasible, outside


def level0(problem: QPProblem, solver: str) -> np.ndarray | None:
    """Level 0 of `solve_levels` (the position an equality) with `solver` ("daqp-direct":
    DAQP called directly)."""
    H, f, A, lower, upper, _ = problem
    if solver == "daqp-direct":
        return solve_daqp(H, f, A, upper, lower, 3)
    return solve_qpsolvers(H, f, A, upper, lower, 3, solver)


def level1(problem: QPProblem, solver: str) -> np.ndarray | None:
    """Level 1 of `solve_levels` (the position a term, the limits hard) with `solver`."""
    H, f, A, lower, upper, rho = problem
    n = f.size
    J_p, b_p = A[:3], upper[n : n + 3]
    H1, f1 = H + rho * J_p.T @ J_p, f - rho * J_p.T @ b_p
    low, high = np.r_[lower[:n], lower[n + 3 :]], np.r_[upper[:n], upper[n + 3 :]]
    if solver == "daqp-direct":
        return solve_daqp(H1, f1, A[3:], high, low, 0)
    return solve_qpsolvers(H1, f1, A[3:], high, low, 0, solver)


def violation(problem: QPProblem, v: np.ndarray) -> float:
    """Largest constraint violation of v (box, equalities, rows)."""
    z = np.r_[v, problem.A @ v]
    low = np.where(problem.lower > -INF / 2, problem.lower, -np.inf)
    high = np.where(problem.upper < INF / 2, problem.upper, np.inf)
    return float(max(np.max(low - z), np.max(z - high), 0.0))


def timed(function: Callable[[], object], repeat: int = 3) -> tuple[float, object]:
    """(best wall time [s] of `repeat` calls, the last result)."""
    best, out = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        out = function()
        best = min(best, time.perf_counter() - start)
    return best, out


def main() -> None:
    feasible, infeasible, outside = problems()
    print(f"{len(feasible)} feasible problems, {len(infeasible)} with an infeasible level 0, "
          f"{len(outside)} with infeasible limits\n")
    reference = [level0(p, "daqp-direct") for p in feasible]
    names = ["daqp-direct", *(s for s in SOLVERS if s != "active_set")]
    print("| library (call) | time per solve, median / p99 | no solution | largest distance "
          "to DAQP | largest violation | infeasible level 0 reported | time to report it "
          "| infeasible limits reported |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in names:
        times, missed, distance, worst = [], 0, 0.0, 0.0
        for problem, ref in zip(feasible, reference, strict=True):
            t, v = timed(lambda p=problem, s=name: level0(p, s))
            times.append(t)
            if v is None:
                missed += 1
                continue
            distance = max(distance, float(np.max(np.abs(v - ref))))
            worst = max(worst, violation(problem, v))
        said, times_inf = 0, []
        for problem in infeasible:
            t, v = timed(lambda p=problem, s=name: level0(p, s))
            times_inf.append(t)
            said += v is None
        found = sum(level1(p, name) is None for p in outside)
        label = "DAQP (direct)" if name == "daqp-direct" else f"{name} (qpsolvers)"
        print(
            f"| {label} | {1e6 * np.median(times):.1f} / {1e6 * np.percentile(times, 99):.1f} µs "
            f"| {missed} of {len(feasible)} | {distance:.1e} | {worst:.1e} "
            f"| {said} of {len(infeasible)} | {1e6 * np.median(times_inf):.1f} µs "
            f"| {found} of {len(outside)} |"
        )
    # the engine solves in the compiled lane with "active_set" only (issue 29 item 7; the
    # libraries through `QPPlanner.step`): its time per step end to end
    print("\n| engine: simulate(), qp, WMO 4, 200 s, solver | per step (end to end) |")
    print("| --- | --- |")

    def run() -> Simulation:
        sim = Simulation({"planner": "qp", "sea_state": 4.0})
        sim.run()
        return sim

    t, sim = timed(run, 3)
    print(f"| active_set (compiled, in the lane) | {1e6 * t / sim.n_steps:.1f} µs |")


if __name__ == "__main__":
    main()

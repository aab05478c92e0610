"""The qp planner's lexicographic solve on one lane: the position rows an equality (level 0),
else a heavy term (level 1), else every limit row softened by a slack (level 2), each level by
the compiled Goldfarb-Idnani method (`twin.planners.active_set`). The engine's qp step
(`twin.planners.qp_step`) and `twin.planners.qp.solve_levels` both run it.
"""

from __future__ import annotations

import math

import numpy as np

from twin.compiled import register_borrowing, register_jitable
from twin.planners.active_set import INF, OPTIMAL, qp_work, solve_dense_qp

#: weight of the limit slacks of level 2 (against the task terms, of order 1)
SLACK_WEIGHT = 1e6

#: the position rows of a `QPProblem` (its first rows, equalities at level 0)
N_POSITION = 3


@register_jitable
def levels_work(n: int, m: int) -> tuple:
    """Scratch for `solve_levels_lane` on n rates and m limit rows: H₁ (n, n), f₁ (n,), level
    2's H₂ (n + m, n + m), f₂ (n + m,), A₂ (2m, n + m), box (2, n + m), row bounds (2, 2m),
    z (n + m,), and the solver's (`qp_work`)."""
    n2 = n + m
    return (
        np.empty((n, n)), np.empty(n), np.empty((n2, n2)), np.empty(n2),
        np.empty((2 * m, n2)), np.empty((2, n2)), np.empty((2, 2 * m)), np.empty(n2),
        qp_work(n2, 2 * m),
    )  # fmt: skip


@register_borrowing
def solve_levels_lane(
    H: np.ndarray, f: np.ndarray, A: np.ndarray, lower: np.ndarray, upper: np.ndarray,
    rho: float, work: tuple, v: np.ndarray,
) -> int:  # fmt: skip
    """`solve_levels` on one problem's arrays (`QPProblem`'s layout: A (3 + m, n), lower and
    upper (n + 3 + m,)) with the compiled Goldfarb-Idnani method (`solve_dense_qp`): writes v
    (n,) (NaN when no level is solved or the problem is not finite) and returns the level.
    `work` from `levels_work(n, m)`."""
    n, p = f.shape[0], N_POSITION
    m = A.shape[0] - p
    H1, f1, H2, f2, A2, box2, rows2, z, solver = work
    finite = True
    for j in range(n):
        finite = finite and math.isfinite(f[j])
    for j in range(lower.shape[0]):
        finite = finite and math.isfinite(lower[j]) and math.isfinite(upper[j])
    if not finite:
        for j in range(n):
            v[j] = math.nan
        return 0
    # level 0: the rate box, the position rows (equalities), the limit rows
    status = solve_dense_qp(H, f, A, lower[:n], upper[:n], lower[n:], upper[n:], p, solver, v)
    if status == OPTIMAL:
        return 0
    # level 1: the position a term of weight rho, H₁ = H + rho J_pᵀJ_p, f₁ = f − rho J_pᵀb_p
    for i in range(n):
        s = 0.0
        for a in range(p):
            s += A[a, i] * upper[n + a]
        f1[i] = f[i] - rho * s
        for j in range(n):
            s = 0.0
            for a in range(p):
                s += A[a, i] * A[a, j]
            H1[i, j] = H[i, j] + rho * s
    status = solve_dense_qp(H1, f1, A[p:], lower[:n], upper[:n], lower[n + p :],
                            upper[n + p :], 0, solver, v)  # fmt: skip
    if status == OPTIMAL:
        return 1
    # level 2: z = [v; s], low − s ≤ C v ≤ high + s, s ≥ 0, cost + SLACK_WEIGHT |s|²
    n2 = n + m
    for i in range(n2):
        f2[i] = f1[i] if i < n else 0.0
        for j in range(n2):
            H2[i, j] = H1[i, j] if i < n and j < n else 0.0
        if i >= n:
            H2[i, i] = SLACK_WEIGHT
            box2[0, i], box2[1, i] = 0.0, INF
        else:
            box2[0, i], box2[1, i] = lower[i], upper[i]
    for i in range(m):
        for j in range(n2):
            c = A[p + i, j] if j < n else 0.0
            A2[i, j] = c
            A2[m + i, j] = c
        A2[i, n + i] = 1.0  # C v + s ≥ low
        A2[m + i, n + i] = -1.0  # C v − s ≤ high
        rows2[0, i], rows2[1, i] = lower[n + p + i], INF
        rows2[0, m + i], rows2[1, m + i] = -INF, upper[n + p + i]
    status = solve_dense_qp(H2, f2, A2, box2[0], box2[1], rows2[0], rows2[1], 0, solver, z)
    for j in range(n):
        v[j] = z[j] if status == OPTIMAL else math.nan
    return 2

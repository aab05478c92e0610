r"""The dual active-set method of Goldfarb and Idnani (1983) for a small dense strictly convex
quadratic program, as compiled lane functions (`register_jitable`: numba compiles them into
its callers; without numba they run as plain Python, the same numbers).

    minimise   ½ xᵀ H x + fᵀ x
    subject to lower_j ≤ x_j ≤ upper_j                  (the box, j < n)
               lower_i ≤ A_i x ≤ upper_i                (the rows; the first `n_equal` equal)

H (n, n) symmetric positive definite. A bound whose size is at least `INF` / 2 is absent.

The method (Goldfarb & Idnani 1983, "A numerically stable dual method for solving strictly
convex quadratic programs", Math. Programming 27, §3; the same method as quadprog's, and the
dual view DAQP builds on) starts from the unconstrained minimum x = −H⁻¹f, which is dual
feasible (no constraint active), and keeps it dual feasible while it adds violated constraints:

1. take the most violated constraint p, as nᵀx ≥ b (a row's upper side as −A_i x ≥ −upper_i);
2. with H = LLᵀ, J = L⁻ᵀ and the active normals N factored as Jᵀ N = [R; 0] (J = [J₁ J₂]),
   the primal step direction is z = J₂ J₂ᵀ n and the dual one r = R⁻¹ J₁ᵀ n (§3, eqs (3.4),
   (3.5));
3. the full step t₂ = −s_p(x) / zᵀn reaches the constraint; the partial step t₁ = min u_j / r_j
   over the active inequalities with r_j > 0 keeps the multipliers u ≥ 0. Step by t = min(t₁,
   t₂): x ← x + t z, u ← u − t r, u_p ← u_p + t. If t = t₂, p joins the active set (J and R
   updated by Givens rotations); else the constraint that reached u_j = 0 leaves it, and step
   2 is taken again for the same p;
4. no primal step (z = 0) and no partial step (no r_j > 0): the constraints are inconsistent,
   the problem infeasible (§3, step 2(c)(i)).

The equalities are added first, each with the sign that makes it violated and without sign
conditions on its multiplier. Where that point, the minimum on the equalities alone, meets
every other constraint it is the solution: `equality_minimum` computes it without J and the
rotations (most of the `qp` planner's steps; issue 29 item 7), else the method runs as above.
A strictly convex QP has one solution, so this method and DAQP (Arnström et al. 2022) agree on
it to rounding (tests/planners/test_active_set.py on the `qp` planner's recorded problems).
"""

from __future__ import annotations

import math

import numpy as np

from twin.compiled import register_borrowing, register_inline, register_jitable
from twin.planners.linalg import cholesky_lane

#: what `solve_dense_qp` returns
OPTIMAL, INFEASIBLE, NOT_CONVEX, ITERATION_LIMIT = 0, 1, 2, 3
#: a bound at least INF / 2 in size is absent (DAQP's convention; `twin.planners.qp` uses it)
INF = 1e30
#: primal tolerance: a constraint violated by at most this (relative to 1 + |bound|) is met
PRIMAL_TOL = 1e-10
#: a step direction this small against the normal's (relative) is no step: the new normal is
#: a combination of the active ones
DEPENDENT_TOL = 1e-12
#: `equality_minimum` leaves a row whose part outside the others' span is below this fraction
#: (squared, as DEPENDENT_TOL) to the method itself: far from DEPENDENT_TOL, so both agree
SHORTCUT_TOL = 1e-8


@register_jitable
def qp_work(n_max: int, m_max: int) -> tuple:
    """Scratch for `solve_dense_qp` on at most n_max variables and m_max rows: J, R (n_max,
    n_max), d, z, r (n_max,), u (n_max + 1,), the active constraints' indices and signs
    (n_max,) and an activity flag per constraint (n_max + m_max,)."""
    return (
        np.empty((n_max, n_max)),
        np.empty((n_max, n_max)),
        np.empty(n_max),
        np.empty(n_max),
        np.empty(n_max),
        np.empty(n_max + 1),
        np.empty(n_max, dtype=np.int64),
        np.empty(n_max),
        np.zeros(n_max + m_max),
    )


@register_inline
def normal_times(A: np.ndarray, n: int, c: int, x: np.ndarray) -> float:
    """a_c · x for constraint c: the unit vector e_c for c < n (the box), else row c − n of A."""
    if c < n:
        return x[c]
    s = 0.0
    for k in range(n):
        s += A[c - n, k] * x[k]
    return s


@register_inline
def directions(
    A: np.ndarray, n: int, q: int, c: int, sign: float, J: np.ndarray, R: np.ndarray,
    d: np.ndarray, z: np.ndarray, r: np.ndarray,
) -> float:  # fmt: skip
    """d = Jᵀ n_p, z = J₂ d₂ and r = R⁻¹ d₁ for the normal n_p = sign · a_c (module doc, step
    2); returns |d₂|² / |d|² (0: n_p is a combination of the active normals)."""
    for i in range(n):
        s = 0.0
        if c < n:
            s = J[c, i]
        else:
            for k in range(n):
                s += J[k, i] * A[c - n, k]
        d[i] = sign * s
    total, free = 0.0, 0.0
    for i in range(n):
        total += d[i] * d[i]
        if i >= q:
            free += d[i] * d[i]
    for k in range(n):
        s = 0.0
        for i in range(q, n):
            s += J[k, i] * d[i]
        z[k] = s
    for i in range(q - 1, -1, -1):  # R r = d₁, R upper triangular
        s = d[i]
        for j in range(i + 1, q):
            s -= R[i, j] * r[j]
        r[i] = s / R[i, i]
    return free / total if total > 0.0 else 0.0


@register_inline
def rotate_columns(J: np.ndarray, n: int, i: int, j: int, cos: float, sin: float) -> None:
    """J's columns i, j ← (cos J_i + sin J_j, −sin J_i + cos J_j): a Givens rotation of the rows
    i, j of Jᵀ N."""
    for k in range(n):
        a, b = J[k, i], J[k, j]
        J[k, i] = cos * a + sin * b
        J[k, j] = -sin * a + cos * b


@register_inline
def add_constraint(n: int, q: int, J: np.ndarray, R: np.ndarray, d: np.ndarray) -> None:
    """Make d = Jᵀ n_p's entries q + 1 … n − 1 zero by rotations of J's columns and write d's
    first q + 1 entries as R's column q: the normal joins the factorisation."""
    for i in range(n - 1, q, -1):
        a, b = d[i - 1], d[i]
        if b == 0.0:
            continue
        h = math.hypot(a, b)
        cos, sin = a / h, b / h
        d[i - 1], d[i] = h, 0.0
        rotate_columns(J, n, i - 1, i, cos, sin)
    for i in range(q + 1):
        R[i, q] = d[i]
    for i in range(q + 1, n):
        R[i, q] = 0.0


@register_borrowing
def drop_constraint(
    n: int, q: int, k: int, J: np.ndarray, R: np.ndarray, u: np.ndarray, active: np.ndarray,
    signs: np.ndarray,
) -> None:  # fmt: skip
    """Remove the k-th of the q active constraints: R's column k goes, the Hessenberg part
    left behind is made triangular again by rotations (applied to J's columns too)."""
    for j in range(k, q - 1):
        for i in range(q):
            R[i, j] = R[i, j + 1]
        u[j], active[j], signs[j] = u[j + 1], active[j + 1], signs[j + 1]
    u[q - 1] = u[q]  # the multiplier of the constraint being added, if any
    for j in range(k, q - 1):
        a, b = R[j, j], R[j + 1, j]
        if b == 0.0:
            continue
        h = math.hypot(a, b)
        cos, sin = a / h, b / h
        for col in range(j, q - 1):
            x0, x1 = R[j, col], R[j + 1, col]
            R[j, col] = cos * x0 + sin * x1
            R[j + 1, col] = -sin * x0 + cos * x1
        R[j + 1, j] = 0.0
        rotate_columns(J, n, j, j + 1, cos, sin)


@register_inline
def cholesky(H: np.ndarray, n: int, R: np.ndarray, inverse: np.ndarray) -> bool:
    """H = L Lᵀ (`twin.planners.linalg.cholesky_lane`; L in R's lower triangle: R is free
    until a constraint is active), inverse (n,) = 1 / L's diagonal; False where H is not
    positive definite."""
    if not cholesky_lane(H, n, 0.0, R):
        return False
    for j in range(n):
        inverse[j] = R[j, j]  # cholesky_lane keeps the diagonal inverted
    return True


@register_inline
def invert_factor(n: int, J: np.ndarray, R: np.ndarray, inverse: np.ndarray) -> None:
    """J = L⁻ᵀ (module doc, step 2) from L in R's lower triangle and `inverse` (`cholesky`)."""
    for j in range(n):  # row j of J is L⁻¹ e_j
        for i in range(n):
            if i < j:
                J[j, i] = 0.0
                continue
            s = 1.0 if i == j else 0.0
            for k in range(j, i):
                s -= R[i, k] * J[j, k]
            J[j, i] = s * inverse[i]


@register_inline
def unconstrained_minimum(f: np.ndarray, n: int, J: np.ndarray, d: np.ndarray,
                          x: np.ndarray) -> None:  # fmt: skip
    """x = −H⁻¹ f = −J Jᵀ f, the start (dual feasible, no constraint active); d scratch."""
    for i in range(n):
        s = 0.0
        for k in range(n):
            s += J[k, i] * f[k]
        d[i] = s
    for k in range(n):
        s = 0.0
        for i in range(n):
            s += J[k, i] * d[i]
        x[k] = -s


@register_inline
def step_by(n: int, q: int, t: float, move: bool, z: np.ndarray, r: np.ndarray, u: np.ndarray,
            x: np.ndarray) -> None:  # fmt: skip
    """The step of length t (module doc, step 3): x ← x + t z where the primal moves (`move`),
    the active multipliers u ← u − t r."""
    if move:
        for i in range(n):
            x[i] += t * z[i]
    for j in range(q):
        u[j] -= t * r[j]


@register_inline
def add_equalities(A: np.ndarray, row_upper: np.ndarray, n: int, n_equal: int, work: tuple,
                   x: np.ndarray) -> int:  # fmt: skip
    """The first n_equal rows made active, each in the sense it is violated and its multiplier
    free of sign (module doc): the number of active constraints after them, or −1 where one
    is a combination of the others that it contradicts (infeasible)."""
    J, R, d, z, r, u, active, signs, flags = work
    q = 0
    for e in range(n_equal):
        c = n + e
        b = row_upper[e]
        slack = normal_times(A, n, c, x) - b
        sign = 1.0 if slack <= 0.0 else -1.0
        slack *= sign
        if directions(A, n, q, c, sign, J, R, d, z, r) <= DEPENDENT_TOL:
            if -slack > PRIMAL_TOL * (1.0 + abs(b)):
                return -1
            continue
        zn = 0.0
        for i in range(q, n):
            zn += d[i] * d[i]  # zᵀ n_p = |d₂|²
        t = -slack / zn
        step_by(n, q, t, True, z, r, u, x)
        add_constraint(n, q, J, R, d)
        u[q], active[q], signs[q] = t, c, sign
        flags[c] = 1.0
        q += 1
    return q


@register_inline
def most_violated(
    A: np.ndarray, n: int, box_lower: np.ndarray, box_upper: np.ndarray, row_lower: np.ndarray,
    row_upper: np.ndarray, n_equal: int, flags: np.ndarray, x: np.ndarray,
) -> tuple[int, float, float]:  # fmt: skip
    """The most violated inactive constraint of the n + m (module doc, step 1; each side of a
    row is one, violations relative to 1 + |bound|, beyond PRIMAL_TOL): (p, its sign, its
    bound b) as p_sign · a_p x ≥ p_sign · b, or p = −1 where none is (x is optimal)."""
    m = A.shape[0]
    p, p_sign, worst = -1, 0.0, 0.0
    for c in range(n + m):
        if flags[c] != 0.0 or (n <= c < n + n_equal):
            continue
        if c < n:
            low, high = box_lower[c], box_upper[c]
        else:
            low, high = row_lower[c - n], row_upper[c - n]
        value = normal_times(A, n, c, x)
        # the division only where the constraint may be violated (half the tolerance: the
        # same constraints as dividing always, which costs more than the rest of the scan)
        if high < INF / 2 and value - high > 0.5 * PRIMAL_TOL * (1.0 + abs(high)):
            over = (value - high) / (1.0 + abs(high))
            if over > PRIMAL_TOL and over > worst:
                p, p_sign, worst = c, -1.0, over
        if low > -INF / 2 and low - value > 0.5 * PRIMAL_TOL * (1.0 + abs(low)):
            under = (low - value) / (1.0 + abs(low))
            if under > PRIMAL_TOL and under > worst:
                p, p_sign, worst = c, 1.0, under
    if p < 0:
        return p, p_sign, 0.0
    if p < n:
        b = box_upper[p] if p_sign < 0 else box_lower[p]
    else:
        b = row_upper[p - n] if p_sign < 0 else row_lower[p - n]
    return p, p_sign, b


@register_inline
def step_lengths(n: int, q_equal: int, q: int, free: float, slack: float, d: np.ndarray,
                 r: np.ndarray, u: np.ndarray) -> tuple[float, int, float]:  # fmt: skip
    """(t₁, k, t₂) of module doc step 3: the partial step t₁ = min u_j / r_j over the active
    inequalities j with r_j > 0 (k the first reaching it, −1: none, t₁ = inf) and the full
    step t₂ = max(−slack / zᵀn, 0) (inf where n_p depends on the active normals, `free`)."""
    t1, k = math.inf, -1
    for j in range(q_equal, q):
        if r[j] > 0.0:
            ratio = u[j] / r[j]
            if ratio < t1:
                t1, k = ratio, j
    if free > DEPENDENT_TOL:
        zn = 0.0
        for i in range(q, n):
            zn += d[i] * d[i]
        t2 = max(-slack / zn, 0.0)
    else:
        t2 = math.inf
    return t1, k, t2


@register_inline
def forward_solve(R: np.ndarray, inverse: np.ndarray, n: int, b: np.ndarray,
                  y: np.ndarray) -> None:  # fmt: skip
    """y = L⁻¹ b, L in R's lower triangle (`cholesky`), `inverse` (n,) its diagonal's
    reciprocals; b (n,) may be a row of A."""
    for i in range(n):
        s = b[i]
        for k in range(i):
            s -= R[i, k] * y[k]
        y[i] = s * inverse[i]


@register_inline
def equality_minimum(
    A: np.ndarray, f: np.ndarray, row_upper: np.ndarray, n: int, n_equal: int, work: tuple,
    x: np.ndarray,
) -> bool:  # fmt: skip
    """x = the minimum of the cost on the first n_equal rows alone, the point the method
    reaches once the equalities are active (`add_equalities`), computed without J: in
    y = Lᵀx the cost is ½|y|² + wᵀy (w = L⁻¹f), the rows Yᵀy = b (Y = L⁻¹A_eᵀ = J₁R
    of module doc step 2, here Q Rq by Gram-Schmidt twice), so y = −w + Q(Qᵀw + Rq⁻ᵀb).
    L from `cholesky` in R's lower triangle; Q in J's first n_equal columns, Rq in R's upper
    triangle and r. False where a row is (nearly, `SHORTCUT_TOL`) a combination of the others
    or not finite: the method itself decides those (`solve_dense_qp`)."""
    J, R, d, z, r, u, _, signs, _ = work
    if n_equal > n:
        return False
    inverse = signs  # L's diagonal's reciprocals (`cholesky`; signs is written later)
    for e in range(n_equal):
        forward_solve(R, inverse, n, A[e], u)
        total = 0.0
        for k in range(n):
            J[k, e] = u[k]
            total += u[k] * u[k]
        for i in range(e):
            R[i, e] = 0.0
        for _ in range(2):  # Gram-Schmidt twice: Q's columns orthonormal to rounding
            for i in range(e):
                c = 0.0
                for k in range(n):
                    c += J[k, i] * J[k, e]
                for k in range(n):
                    J[k, e] -= c * J[k, i]
                R[i, e] += c
        free = 0.0
        for k in range(n):
            free += J[k, e] * J[k, e]
        if not free > SHORTCUT_TOL * total:  # the fraction GI's DEPENDENT_TOL tests, or NaN
            return False
        r[e] = math.sqrt(free)
        for k in range(n):
            J[k, e] /= r[e]
    forward_solve(R, inverse, n, f, d)  # w
    for e in range(n_equal):  # z = Rq⁻ᵀ b + Qᵀw
        s = row_upper[e]
        for i in range(e):
            s -= R[i, e] * u[i]
        u[e] = s / r[e]  # (Rq⁻ᵀ b)_e
    for e in range(n_equal):
        s = u[e]
        for k in range(n):
            s += J[k, e] * d[k]
        z[e] = s
    for k in range(n):  # y = −w + Q z, then x = L⁻ᵀ y
        s = -d[k]
        for e in range(n_equal):
            s += J[k, e] * z[e]
        d[k] = s
    for i in range(n - 1, -1, -1):
        s = d[i]
        for k in range(i + 1, n):
            s -= R[k, i] * x[k]
        x[i] = s * inverse[i]
    return True


@register_borrowing
def solve_dense_qp(
    H: np.ndarray, f: np.ndarray, A: np.ndarray, box_lower: np.ndarray, box_upper: np.ndarray,
    row_lower: np.ndarray, row_upper: np.ndarray, n_equal: int, work: tuple, x: np.ndarray,
) -> int:  # fmt: skip
    """Solve the module doc's QP: H (n, n), f (n,), the box (n,), the rows A (m, n) with their
    bounds (m,), the first n_equal rows equalities (row_lower = row_upper). Writes x (n,);
    returns OPTIMAL, INFEASIBLE (the constraints admit no x), NOT_CONVEX (H not positive
    definite) or ITERATION_LIMIT. `work` from `qp_work`."""
    n, m = f.shape[0], A.shape[0]
    J, R, d, z, r, u, active, signs, flags = work
    if not cholesky(H, n, R, signs):  # 1 / L's diagonal in signs, until `add_equalities`
        return NOT_CONVEX
    for c in range(n + m):
        flags[c] = 0.0
    # most steps activate the equalities only: their minimum, if it meets every other
    # constraint, is the solution (strictly convex: one), with no J and no rotation
    if equality_minimum(A, f, row_upper, n, n_equal, work, x):
        p = most_violated(A, n, box_lower, box_upper, row_lower, row_upper, n_equal, flags, x)[0]
        if p < 0:
            return OPTIMAL
    invert_factor(n, J, R, signs)
    unconstrained_minimum(f, n, J, d, x)
    q = add_equalities(A, row_upper, n, n_equal, work, x)
    if q < 0:
        return INFEASIBLE  # an equality is a combination of the others, which it contradicts
    q_equal = q

    for _ in range(10 * (n + m) + 100):
        p, p_sign, b = most_violated(A, n, box_lower, box_upper, row_lower, row_upper, n_equal,
                                     flags, x)  # fmt: skip
        if p < 0:
            return OPTIMAL
        u[q] = 0.0  # u_p
        while True:  # steps towards p until it is reached (joins) or it is infeasible
            slack = p_sign * (normal_times(A, n, p, x) - b)
            free = directions(A, n, q, p, p_sign, J, R, d, z, r)
            t1, k, t2 = step_lengths(n, q_equal, q, free, slack, d, r, u)
            if k < 0 and t2 == math.inf:
                return INFEASIBLE
            t = min(t1, t2)
            step_by(n, q, t, t2 < math.inf, z, r, u, x)
            u[q] += t
            if t2 <= t1:  # the constraint is reached: it joins the active set
                add_constraint(n, q, J, R, d)
                active[q], signs[q] = p, p_sign
                flags[p] = 1.0
                q += 1
                break
            flags[active[k]] = 0.0  # a multiplier reached 0: its constraint leaves
            drop_constraint(n, q, k, J, R, u, active, signs)
            q -= 1
    return ITERATION_LIMIT

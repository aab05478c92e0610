"""Newton-Raphson forward kinematics shared by the three parallel mechanisms, one lane at a time.

Seed 000 (Stewart), seed 001 eqs (20)-(24) (3UPU_UP) and the 4-UPR all solve the leg equations
l(x) = L for the state x; with more legs than unknowns (4-UPR) the step is Gauss-Newton's
least-squares one. The loop, its step, their linear algebra and stopping test are written once
here (`newton_loop`, `newton_step_lane`), as lane functions (floats and small arrays; compiled
by numba into the kernels and batch loops that call them, `twin.compiled`; plain Python without
numba). Each mechanism hands the loop its own leg equations (`twin.mechanisms.platforms.
platform_newton`, `twin.mechanisms.stewart.stewart_newton`), which the engine and the objects'
`forward` both run; the objects wrap the loop's outcome (`NewtonResult`) with their own checks
and error messages.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twin.compiled import register_jitable
from twin.errors import TwinError
from twin.validation import as_array

#: `newton_step_lane`'s outcomes: a step taken (not yet converged), converged (the step taken
#: too), stopped on a non-finite residual, stopped on a singular J (no step exists)
STEPPED, CONVERGED, NOT_FINITE, SINGULAR = 0, 1, 2, 3


@dataclass(frozen=True)
class NewtonResult:
    """A batch of Newton-Raphson solves, lane by lane.

    Attributes:
        x: (..., n) each lane's last iterate (after its final step when it converged).
        residual: (..., m) l(x) − L at each lane's last evaluation.
        step: (..., n) each lane's last step.
        iterations: the most steps a lane took.
        converged: whether every lane met the tolerances.
        solved: (...) bool, which lanes met them.
    """

    x: np.ndarray
    residual: np.ndarray
    step: np.ndarray
    iterations: int
    converged: bool
    solved: np.ndarray

    @property
    def worst(self) -> float:
        """Largest |residual| (inf for NaN)."""
        return float(np.max(np.abs(np.nan_to_num(self.residual, nan=np.inf))))

    @classmethod
    def of(
        cls, x: np.ndarray, residual: np.ndarray, step: np.ndarray, outcome: np.ndarray
    ) -> NewtonResult:
        """The result of a batch loop's outputs: outcome (..., 2) holds each lane's
        `newton_step_lane` outcome and its number of steps (floats, as `LaneBatch` gives)."""
        solved = outcome[..., 0] == CONVERGED
        iterations = int(np.max(outcome[..., 1], initial=0))
        return cls(x, residual, step, iterations, bool(np.all(solved)), solved)


def start(guess: ArrayLike | None, default: np.ndarray, batch: tuple[int, ...]) -> np.ndarray:
    """The starting iterate (*batch, n): `guess` broadcast to the batch, or `default`."""
    if guess is None:
        return np.broadcast_to(default, batch).copy()
    guess = as_array(guess, "guess", default.shape[-1:])
    try:
        return np.broadcast_to(guess, batch).copy()
    except ValueError as exc:
        raise TwinError(f"guess of shape {guess.shape} does not broadcast to {batch}") from exc


def check_tolerances(tol: float, max_iter: int) -> None:
    """TwinError unless tol > 0 and max_iter ≥ 0 (a `forward`'s arguments)."""
    if not (tol > 0 and max_iter >= 0):
        raise TwinError(f"forward needs tol > 0 and max_iter >= 0, got {tol}, {max_iter}")


@register_jitable
def solve_lane(M: np.ndarray, x: np.ndarray) -> bool:
    """Solve the n × n system of the augmented M (n, n + 1) = [A | b] into x (n,), destroying M.

    Gaussian elimination with partial pivoting (`np.linalg.solve` to rounding); False (x
    untouched) on an exactly zero pivot, where `np.linalg.solve` raises LinAlgError.
    """
    n = x.shape[0]
    for c in range(n):
        pivot = c
        for r in range(c + 1, n):
            if abs(M[r, c]) > abs(M[pivot, c]):
                pivot = r
        if M[pivot, c] == 0.0:
            return False
        if pivot != c:
            for j in range(n + 1):
                M[c, j], M[pivot, j] = M[pivot, j], M[c, j]
        for r in range(c + 1, n):
            f = M[r, c] / M[c, c]
            for j in range(c, n + 1):
                M[r, j] = M[r, j] - f * M[c, j]
    for i in range(n - 1, -1, -1):  # back substitution, left to right within a row
        s = M[i, n]
        for j in range(i + 1, n):
            s = s - M[i, j] * M[j, n]
        M[i, n] = s / M[i, i]
    for i in range(n):
        x[i] = M[i, n]
    return True


@register_jitable
def least_squares_lane(J: np.ndarray, r: np.ndarray, m: int, M: np.ndarray, x: np.ndarray) -> bool:
    """x (n,) minimising |J x − r| for the first m rows of J (≥ m, n) and r: the solve itself
    for m = n, the normal equations JᵀJ x = Jᵀr for m > n (the Gauss-Newton step;
    `np.linalg.lstsq` to rounding where J has full column rank, a failure where it has not);
    M (n, n + 1) scratch. False where the system is singular."""
    n = x.shape[0]
    if m == n:
        for i in range(n):
            for j in range(n):
                M[i, j] = J[i, j]
            M[i, n] = r[i]
    else:
        for i in range(n):
            for j in range(n):
                s = 0.0
                for k in range(m):
                    s += J[k, i] * J[k, j]
                M[i, j] = s
            s = 0.0
            for k in range(m):
                s += J[k, i] * r[k]
            M[i, n] = s
    return solve_lane(M, x)


@register_jitable
def newton_step_lane(
    residual: np.ndarray,
    J: np.ndarray,
    m: int,
    tol: float,
    step_tol: float,
    M: np.ndarray,
    step: np.ndarray,
    x: np.ndarray,
) -> int:
    """One Newton-Raphson step x ← x − Δ with J Δ = r (m = n) or JᵀJ Δ = Jᵀr (m > n, Gauss-
    Newton), and its stopping test; returns the outcome (`STEPPED`, `CONVERGED`, ...).

    Args:
        residual: (≥ m,) r = l(x) − L at x; J: (≥ m, n) ∂l/∂x there (m equations).
        tol: every |r_i| must be at most this to converge (inf: no test on r).
        step_tol: every |Δ_j| must be at most this too (inf: no test on Δ): where ∂l/∂x is
            small a tiny residual can hide a larger state error.
        M: (n, n + 1) scratch; step: (n,) Δ written; x: (n,) the iterate, stepped in place
            unless r is not finite or J singular (then NOT_FINITE, SINGULAR, x untouched).
    """
    small = True
    for i in range(m):
        if not np.isfinite(residual[i]):
            return NOT_FINITE
        small = small and abs(residual[i]) <= tol
    if not least_squares_lane(J, residual, m, M, step):
        return SINGULAR
    for j in range(x.shape[0]):
        small = small and abs(step[j]) <= step_tol
        x[j] = x[j] - step[j]
    return CONVERGED if small else STEPPED


@register_jitable
def newton_loop(
    evaluate: Callable[..., None],
    data: tuple,
    lengths: np.ndarray,
    m: int,
    tol: float,
    step_tol: float,
    max_iter: int,
    x: np.ndarray,
    residual: np.ndarray,
    J: np.ndarray,
    M: np.ndarray,
    step: np.ndarray,
) -> tuple[int, int]:
    """Newton-Raphson on l(x) − L from the start x (n,), in place: at most max_iter + 1
    evaluations of a mechanism's leg equations, `evaluate(x, data, residual, J)` (a lane
    function writing l(x) into residual (≥ m,) and ∂l/∂x into J (≥ m, n); data its own
    arguments), each followed by `newton_step_lane` (tol, step_tol, M and step as there) on
    l(x) − L for the lengths L (m,). Returns (the last step's outcome, `STEPPED` if max_iter
    ran out; the steps taken before it); residual and step are the last evaluation's."""
    for iteration in range(max_iter + 1):
        evaluate(x, data, residual, J)
        for i in range(m):
            residual[i] = residual[i] - lengths[i]
        outcome = newton_step_lane(residual, J, m, tol, step_tol, M, step, x)
        if outcome != STEPPED:
            return outcome, iteration
    return STEPPED, max_iter

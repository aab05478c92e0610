"""Newton-Raphson forward kinematics shared by the three parallel mechanisms.

Seed 000 (Stewart), seed 001 eqs (20)-(24) (3UPU_UP) and the 4-UPR all solve the leg equations
l(x) = L for the state x; with more legs than unknowns (4-UPR) the step is Gauss-Newton's
least-squares one. Each mechanism wraps this with its own checks and error messages.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twin.compiled import register_jitable
from twin.errors import TwinError
from twin.validation import as_array


@dataclass(frozen=True)
class NewtonResult:
    """Attributes:
    x: (..., n) the last iterate (after the final step when converged).
    residual: (..., m) l(x) − L at the last evaluation.
    step: (..., n) the last step (inf before the first).
    iterations: steps taken.
    converged: whether every batch entry met the tolerances.
    """

    x: np.ndarray
    residual: np.ndarray
    step: np.ndarray
    iterations: int
    converged: bool

    @property
    def worst(self) -> float:
        """Largest |residual| (inf for NaN)."""
        return float(np.max(np.abs(np.nan_to_num(self.residual, nan=np.inf))))


def start(guess: ArrayLike | None, default: np.ndarray, batch: tuple[int, ...]) -> np.ndarray:
    """The starting iterate (*batch, n): `guess` broadcast to the batch, or `default`."""
    if guess is None:
        return np.broadcast_to(default, batch).copy()
    guess = as_array(guess, "guess", default.shape[-1:])
    try:
        return np.broadcast_to(guess, batch).copy()
    except ValueError as exc:
        raise TwinError(f"guess of shape {guess.shape} does not broadcast to {batch}") from exc


def newton(
    equations: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    x: np.ndarray,
    *,
    tol: float,
    max_iter: int,
    step_tol: float | None = None,
) -> NewtonResult:
    """Iterate x ← x − Δ with J Δ = r (square) or JᵀJ Δ = Jᵀ r (more equations than unknowns).

    Args:
        equations: x (..., n) → (residual r = l(x) − L (..., m), Jacobian ∂l/∂x (..., m, n)).
        x: (..., n) starting iterate (not modified).
        tol: every |r| must be at most this.
        max_iter: steps before giving up.
        step_tol: if set, every |Δ| must be at most this too — where ∂l/∂x is small a tiny
            residual can hide a larger state error.

    Returns:
        The result; `converged` False on running out of steps, NaN, or a singular J.
    """
    if not (tol > 0 and max_iter >= 0):
        raise TwinError(f"forward needs tol > 0 and max_iter >= 0, got {tol}, {max_iter}")
    x = np.array(x, dtype=float)
    step = np.full(x.shape, np.inf)
    residual = np.full(x.shape, np.nan)
    for iteration in range(max_iter + 1):
        residual, J = equations(x)
        if not np.all(np.isfinite(residual)):
            break
        try:
            if J.shape[-2] == J.shape[-1]:
                step = np.linalg.solve(J, residual[..., None])[..., 0]
            else:
                Jt = np.swapaxes(J, -1, -2)
                step = np.linalg.solve(Jt @ J, Jt @ residual[..., None])[..., 0]
        except np.linalg.LinAlgError:
            break  # singular configuration: no Newton step exists
        if np.all(np.abs(residual) <= tol) and (
            step_tol is None or np.all(np.abs(step) <= step_tol)
        ):
            return NewtonResult(x - step, residual, step, iteration, True)
        if iteration == max_iter:
            break
        x = x - step
    return NewtonResult(x, residual, step, iteration, False)


# One lane (floats and small arrays; compiled by numba into the kernels and batch loops that
# call them, `twin.compiled`; plain Python without numba): the Newton step's linear algebra.


@register_jitable
def solve3_lane(M: np.ndarray, x: np.ndarray) -> bool:
    """Solve the 3 × 3 system of the augmented M (3, 4) = [A | b] into x (3,), destroying M.

    Gaussian elimination with partial pivoting (`np.linalg.solve` to rounding); False (x
    untouched) on an exactly zero pivot, where `np.linalg.solve` raises LinAlgError.
    """
    for c in range(3):
        pivot = c
        for r in range(c + 1, 3):
            if abs(M[r, c]) > abs(M[pivot, c]):
                pivot = r
        if M[pivot, c] == 0.0:
            return False
        if pivot != c:
            for j in range(4):
                M[c, j], M[pivot, j] = M[pivot, j], M[c, j]
        for r in range(c + 1, 3):
            f = M[r, c] / M[c, c]
            for j in range(c, 4):
                M[r, j] = M[r, j] - f * M[c, j]
    x2 = M[2, 3] / M[2, 2]
    x1 = (M[1, 3] - M[1, 2] * x2) / M[1, 1]
    x0 = (M[0, 3] - M[0, 1] * x1 - M[0, 2] * x2) / M[0, 0]
    x[0], x[1], x[2] = x0, x1, x2
    return True


@register_jitable
def least_squares_lane(J: np.ndarray, r: np.ndarray, n: int, M: np.ndarray, x: np.ndarray) -> bool:
    """x (3,) minimising |J x − r| for the first n rows of J (≥ n, 3) and r: the solve itself
    for n = 3, the normal equations JᵀJ x = Jᵀr for n > 3 (`newton`'s Gauss-Newton step;
    `np.linalg.lstsq` to rounding where J has full column rank, a failure where it has not);
    M (3, 4) scratch. False where the system is singular."""
    if n == 3:
        for i in range(3):
            for j in range(3):
                M[i, j] = J[i, j]
            M[i, 3] = r[i]
    else:
        for i in range(3):
            for j in range(3):
                s = 0.0
                for k in range(n):
                    s += J[k, i] * J[k, j]
                M[i, j] = s
            s = 0.0
            for k in range(n):
                s += J[k, i] * r[k]
            M[i, 3] = s
    return solve3_lane(M, x)

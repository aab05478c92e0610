"""Newton-Raphson forward kinematics shared by the three parallel mechanisms.

Seed 000 (Stewart), seed 001 eqs (20)-(24) (3UPU_UP) and the 4-UPR all solve the leg equations
l(x) = L for the state x; with more legs than unknowns (4-UPR) the step is Gauss-Newton's
least-squares one. Each mechanism wraps this with its own checks and error messages.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

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


def start(guess: np.ndarray | None, default: np.ndarray, batch: tuple[int, ...]) -> np.ndarray:
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

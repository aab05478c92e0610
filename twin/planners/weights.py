r"""Weights: the diagonal of W⁻¹ in the weighted pseudo-inverse, one object per idea.

A weight is called with the virtual-joint state and returns (..., n) factors ≥ 0; weights
compose by multiplication (`ProductWeights`), so seed 000 eq (37) is
`ProductWeights(BetaSplit(beta), JointLimitWeights(...))`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.compiled import LaneUfunc, register_inline
from twin.planners.parameters import pack_part, refuse


@dataclass(frozen=True)
class BetaSplit:
    r"""Seed 000 eq (28) raised to the index l of eq (30): β on the six platform joints,
    1 − β on the three gangway joints, each to the power l (l = 0: no weighting, eq (26);
    l = 1: eq (31)).

    Attributes:
        beta: [-] share given to the parallel part, in [0, 1].
        index: l ≥ 0, the weighting index of eq (27).
        n_parallel: number of leading (parallel) joints.
    """

    beta: float
    index: float = 1.0
    n_parallel: int = 6

    def __call__(self, q: np.ndarray) -> np.ndarray:
        n = q.shape[-1]
        w = np.where(np.arange(n) < self.n_parallel, self.beta, 1.0 - self.beta)
        return np.broadcast_to(w**self.index, q.shape)

    def pack(self, record: np.void) -> None:
        """Multiply a differential parameter record's `split` (9,) by β^l | (1 − β)^l."""
        record["split"] = record["split"] * self(np.zeros(9))


@dataclass(frozen=True)
class JointLimitWeights:
    r"""Chan & Dubey (1995) joint-limit weights, seed 000 eqs (35)-(37), SPEC erratum 4.

    ∂H/∂q_i = (q_max − q_min)² (2q_i − q_max − q_min) / (c_i (q_max − q_i)(q_i − q_min)),
    w_i = 1 / (1 + |∂H/∂q_i|): 1 at mid-range, → 0 at a limit; eq (37) multiplies the last
    (telescopic) weight by k_c. A joint at or beyond a limit is evaluated 0.1 % of its span
    inside it, so its weight is small (≈ 1e-3) but not zero and it can move back in.

    c_i is "a constant factor" in the paper; we take c_i = q_max − q_min, which makes
    ∂H/∂q dimensionless, so metres and radians are weighted alike (docs/planners.md).

    Attributes:
        lower, upper: (n,) limits of the virtual joints [m | rad].
        scale: (n,) factor per joint (k_c on the telescope, 1 elsewhere; eq (37)).
    """

    lower: np.ndarray
    upper: np.ndarray
    scale: np.ndarray

    def gradient(self, q: np.ndarray) -> np.ndarray:
        """∂H/∂q (..., n), eq (36) with c_i = q_max − q_min (`joint_limit_gradient_lane`)."""
        return np.asarray(JOINT_LIMIT_GRADIENT(q, self.lower, self.upper))

    def __call__(self, q: np.ndarray) -> np.ndarray:
        """The weights (..., n) (`joint_limit_weight_lane`)."""
        return np.asarray(JOINT_LIMIT_WEIGHT(q, self.lower, self.upper, self.scale))

    def pack(self, record: np.void) -> None:
        """Write the limits and the scale into a differential parameter record (`lower`,
        `upper`, `scale`, each (9,)) and switch its `joint_limits` on.

        Raises:
            TwinError: the record has joint-limit weights already, or a shape is not (9,).
        """
        if record["joint_limits"] > 0.0:
            raise refuse("more than one set of joint-limit weights")
        if any(np.shape(a) != (9,) for a in (self.lower, self.upper, self.scale)):
            raise refuse(f"joint-limit weights {self!r:.80} not of the nine joints")
        record["lower"], record["upper"], record["scale"] = self.lower, self.upper, self.scale
        record["joint_limits"] = 1.0


@dataclass(frozen=True)
class ProductWeights:
    """Element-wise product of several weights (eq (37) = eq (28) × joint-limit weights)."""

    parts: tuple

    def __call__(self, q: np.ndarray) -> np.ndarray:
        w = np.ones(q.shape)
        for part in self.parts:
            w = w * part(q)
        return w

    def pack(self, record: np.void) -> None:
        """Each part's `pack` in turn (the kernel multiplies what they write)."""
        for part in self.parts:
            pack_part(part, record, "weight")


@register_inline
def joint_limit_gradient_lane(q: float, lower: float, upper: float) -> float:
    """∂H/∂q of one joint, seed 000 eq (36) with c = q_max − q_min (SPEC erratum 4), q [m | rad]
    clipped 0.1 % of the span inside [lower, upper] (one lane, compiled by numba into the
    engine's kernel and into `JOINT_LIMIT_GRADIENT`, `twin.compiled`)."""
    span = upper - lower
    q = min(max(q, lower + 1e-3 * span), upper - 1e-3 * span)
    return span * (2 * q - upper - lower) / ((upper - q) * (q - lower))


@register_inline
def joint_limit_weight_lane(q: float, lower: float, upper: float, scale: float) -> float:
    """`JointLimitWeights` of one joint: scale / (1 + |∂H/∂q|) [-] (eq (37) below)."""
    return scale / (1.0 + abs(joint_limit_gradient_lane(q, lower, upper)))


#: the lanes as ufuncs over broadcast arrays: what `JointLimitWeights` calls
JOINT_LIMIT_GRADIENT = LaneUfunc(joint_limit_gradient_lane, 3)
JOINT_LIMIT_WEIGHT = LaneUfunc(joint_limit_weight_lane, 4)

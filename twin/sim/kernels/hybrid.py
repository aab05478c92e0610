r"""The hybrid boarding system's step guard, one lane at a time: the engine's part of a step.

Every planner family's step gives a velocity (`twin.planners.differential_step`,
`.allocation_step`, `.qp_step`); the guard here (`guarded_step`, of the former
`HybridRig.advance`) holds the mechanism on a velocity that is not finite, shortens the step to
what keeps every joint and leg from going further past its limit in `hold` mode
(`limit_scale_lane`, restated in numpy as the oracle of tests/sim/kernels/test_hybrid_kernel.py)
and integrates it (`twin.mechanisms.hybrid.integrate_hybrid`). The runners that step N lanes ×
B steps with the planners' steps and this guard are `twin.sim.kernels.hybrid_runner`'s.

Every function here handles ONE lane: floats and small numpy arrays, written in a style numba
compiles and plain Python runs unchanged (the fallback when numba is missing; the same
arithmetic, so the same numbers). Nothing is allocated per step (`limit_work` once per lane);
the functions are `register_borrowing` (no reference counting of their array arguments) and
`guarded_step` `register_inline` too (`twin.compiled`). The hybrid constants `const` are the
float row of `HybridBoardingSystem.pack`, read by name (`HYBRID_CONSTANTS`).
"""

from __future__ import annotations

import math

import numpy as np

from twin.compiled import register_borrowing, register_inline, register_jitable
from twin.mechanisms.hybrid import HYBRID_CONSTANTS, HybridBoardingSystem, integrate_hybrid
from twin.mechanisms.legs import leg_lengths_lane
from twin.sim.kernels.layout import FAULT_JOINT_LIMIT, FAULT_PLANNER, HYBRID_DIAGNOSTICS
from twin.spatial import rpy_to_matrix_lane

#: bisection steps of `limit_scale_lane`: the step is shortened to within 2⁻¹² of the limit
LIMIT_BISECTIONS = 12
#: slack [m, rad] on the limit excess a step may keep
LIMIT_SLACK = 1e-12


def hybrid_constants(mechanism: HybridBoardingSystem, rate_limit: np.ndarray) -> np.ndarray:
    """The hybrid runners' `const` (N_HYBRID_CONSTANTS,): `mechanism.pack(rate_limit)`, the
    `HYBRID_CONSTANTS` record written by name (Table 6 joint limits, the rate limits
    `HYBRID_RATE_LIMITS` [m/s, rad/s], gangway d1 and a1, the Stewart hinges, the leg stroke)."""
    return mechanism.pack(rate_limit)


@register_inline
def positive_part(d: float) -> float:
    """max(d, 0) that keeps a NaN (as `np.maximum`)."""
    return 0.0 if d <= 0.0 else d


@register_borrowing
def limit_excess_lane(x: np.ndarray, R: np.ndarray, const: np.ndarray, out: np.ndarray) -> None:
    """How far each virtual joint (Table 6) and each leg (Table 1) is past its limit, 0 inside
    (`HybridBoardingSystem.limit_excess`), of xi x (9,) with R (3, 3) its ᴮR_P
    (`rpy_to_matrix_lane`): out (15,) [m, rad], the 9 joints then the 6 legs; const the hybrid
    constants."""
    c = const.view(HYBRID_CONSTANTS)[0]  # the constants by name
    lower, upper = c.lower, c.upper
    for i in range(9):
        out[i] = positive_part(lower[i] - x[i]) + positive_part(x[i] - upper[i])
    legs = out[9:]  # the lengths first, turned into their excess in place
    leg_lengths_lane(R, x, c.base_hinges, c.platform_hinges, legs)
    low, high = c.leg_min, c.leg_max
    for i in range(6):
        legs[i] = positive_part(low - legs[i]) + positive_part(legs[i] - high)


@register_jitable
def limit_work() -> tuple[np.ndarray, np.ndarray]:
    """Scratch of `limit_scale_lane`, allocated once per lane (numba puts every array on the
    heap: a malloc per step would cost more than the arithmetic): rows (4, 15) for the excess
    now, the trial step's excess, xi and velocity; (3, 3) for the trial's ᴮR_P."""
    return np.empty((4, 15)), np.empty((3, 3))


@register_borrowing
def step_fits(
    x: np.ndarray,
    R: np.ndarray,
    v: np.ndarray,
    s: float,
    dt: float,
    const: np.ndarray,
    work: tuple[np.ndarray, np.ndarray],
) -> bool:
    """Whether the step s·v·dt carries no joint and no leg past the excess now, work's row 0
    (limit_scale's `fits`); x, R, v, dt, const and work as in `limit_scale_lane`."""
    rows, R_trial = work
    now, excess, trial, scaled = rows[0], rows[1], rows[2, :9], rows[3, :9]
    for j in range(9):
        scaled[j] = s * v[j]
    integrate_hybrid(x, R, scaled, dt, trial)
    rpy_to_matrix_lane(trial[3], trial[4], trial[5], R_trial)
    limit_excess_lane(trial, R_trial, const, excess)
    for i in range(15):
        if not excess[i] <= now[i]:
            return False
    return True


@register_borrowing
def limit_scale_lane(
    x: np.ndarray,
    R: np.ndarray,
    v: np.ndarray,
    dt: float,
    const: np.ndarray,
    work: tuple[np.ndarray, np.ndarray],
) -> float:
    """The largest s in [0, 1] such that the step s·v·dt carries no joint and no leg further
    past its limit than it already is (a joint at its limit stops there; one beyond it, e.g. a
    start outside the limits, may only come back), to within 2⁻¹² by 12 bisections; the limit
    excess may grow by at most 1e-12 (the former `HybridRig`'s `limit_scale`, exactly).

    Args:
        x: (9,) xi [m, rad]; R: (3, 3) its ᴮR_P (`rpy_to_matrix_lane`).
        v: (9,) velocity (`integrate_hybrid`); dt: [s].
        const: hybrid constants.
        work: `limit_work()`, overwritten.
    """
    now = work[0][0]
    limit_excess_lane(x, R, const, now)
    for i in range(15):
        now[i] = now[i] + LIMIT_SLACK
    if step_fits(x, R, v, 1.0, dt, const, work):
        return 1.0
    low, high = 0.0, 1.0
    for _ in range(LIMIT_BISECTIONS):
        mid = 0.5 * (low + high)
        if step_fits(x, R, v, mid, dt, const, work):
            low = mid
        else:
            high = mid
    return low


@register_inline
def guarded_step(
    x: np.ndarray, R: np.ndarray, v: np.ndarray, bits: int, hold: bool, const: np.ndarray,
    dt: float, limit: tuple, d: np.ndarray, x_next: np.ndarray,
) -> int:  # fmt: skip
    """The guard of the former `HybridRig.advance` and the step (module doc): a non-finite
    velocity v (9,) holds xi x (9,) (FAULT_PLANNER, the diagnostics row d's `limit_scale` = 0,
    `HYBRID_DIAGNOSTICS`); else, holding the joint limits, v is shortened to s·v
    (`limit_scale_lane`, FAULT_JOINT_LIMIT when s < 1), `limit_scale` = s, and x_next (9,) = x
    after s·v for dt (`integrate_hybrid`). R is x's ᴮR_P, limit the guard's work; the
    planner's fault bits come in, the step's go out."""
    finite = True
    for j in range(9):
        finite = finite and math.isfinite(v[j])
    diagnostics = d.view(HYBRID_DIAGNOSTICS)[0]  # the row by name
    if not finite:  # a planner fault holds the mechanism still
        diagnostics.limit_scale = 0.0
        for j in range(9):
            x_next[j] = x[j]
        return bits | FAULT_PLANNER
    s = 1.0
    if hold:
        s = limit_scale_lane(x, R, v, dt, const, limit)
        if s < 1.0:
            bits |= FAULT_JOINT_LIMIT
    diagnostics.limit_scale = s
    for j in range(9):
        v[j] = s * v[j]
    integrate_hybrid(x, R, v, dt, x_next)
    return bits

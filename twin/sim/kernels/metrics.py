r"""The numbers a hybrid-system run is judged by, reduced from its series for every lane at once,
compiled.

`twin.sim.metrics.hybrid_metrics` turns one lane's row of reductions into its metrics dict
(units, names, `finite`); this module computes the rows: a few passes per lane, row by row,
over its own first `end` samples (lanes of one Simulation may last differently), parallel over
lanes, reading the history's arrays in place. Everything is in the series' units: m, rad, s.

Per lane, over samples k = 0 … T−1 (T = end), S = min(SETTLE, T − 1) the first one judged:

- violations: samples with a virtual joint on or past its Table 6 limit (to 1e-9; `record`
  mode) or past it (`hold` mode), and samples with a leg past its stroke by more than
  `LEG_TOL`; all samples;
- per joint and over all legs: min and max over k ≥ S;
- drift of each joint and leg: the least-squares slope of x(t) times the run's duration,
  Σ (t_k − t̄)(x_k − x̄) / max(Σ (t_k − t̄)², 1e-300) · (t_{T−1} − t_0), all samples;
- tip error (in B): RMS and max over k ≥ S of |e_p| [m] and |e_R| [rad];
- manipulability min, and φe, θe's signed value of largest magnitude (the first on a tie),
  over k ≥ S;
- seed 002 eq (29) as printed: the mean of (α_bottom − α_top)/α_bottom over samples with
  α_bottom > 1e-9 rad (0 if none); SPEC erratum 11's integral form 1 − Σ|α_top| / Σ|α_bottom|
  (0 if the base never tilts); both as fractions, all samples.

Sums run sample by sample, in order (no fast-math): the compiled and the interpreted runner
give the same bits, and numpy's pairwise sums agree to rounding. The records carry no NaN (the
engine holds non-finite samples), so min, max and the extremes need not order NaN as numpy does.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache
from typing import NamedTuple

import numpy as np

from twin.compiled import compile_runner, prange, register_borrowing

#: samples left out at the start of min/max and error statistics (seed 000 §5.3: "the first 10
#: data points are removed")
SETTLE = 10
#: [m] a leg counts as past its stroke beyond Table 1's millimetre precision (as
#: `StewartPlatform.check_lengths`): the geometry's stowed legs, 2.57986 m, are Table 1's 2.58 m
LEG_TOL = 5e-4
#: [m, rad] a virtual joint within this of its limit is on it
JOINT_TOL = 1e-9
#: [rad] the least base tilt counted by eq (29) as printed
TILTED = 1e-9

N_JOINTS, N_LEGS = 9, 6
#: a row of `run_hybrid_reductions`' output: counts, then per-joint blocks, then scalars
R_VIOLATIONS, R_JOINT_VIOLATIONS, R_LEG_VIOLATIONS = 0, 1, 2
R_JOINT_MIN = 3
R_JOINT_MAX = R_JOINT_MIN + N_JOINTS
R_JOINT_DRIFT = R_JOINT_MAX + N_JOINTS
R_LEG_DRIFT = R_JOINT_DRIFT + N_JOINTS
R_LEGS_MIN = R_LEG_DRIFT + N_LEGS
R_LEGS_MAX = R_LEGS_MIN + 1
R_POSITION_RMS, R_POSITION_MAX = R_LEGS_MAX + 1, R_LEGS_MAX + 2
R_ORIENTATION_RMS, R_ORIENTATION_MAX = R_LEGS_MAX + 3, R_LEGS_MAX + 4
R_MANIPULABILITY_MIN = R_LEGS_MAX + 5
R_PHI_E, R_THETA_E = R_LEGS_MAX + 6, R_LEGS_MAX + 7
R_ETA_PRINTED, R_ETA = R_LEGS_MAX + 8, R_LEGS_MAX + 9
N_ROW = R_ETA + 1

#: the series `run_hybrid_reductions` reads, in its argument order
REDUCED = ("t", "xi", "legs", "tip_error", "manipulability", "phi_e", "theta_e", "alpha_top",
           "alpha_bottom")  # fmt: skip


@register_borrowing
def drift_lane(t: np.ndarray, x: np.ndarray, mean: np.ndarray, out: np.ndarray) -> None:
    """Least-squares trend of each column of x (T, k) over the run, slope × duration, in x's
    unit: Σ (t_i − t̄)(x_i − x̄) / max(Σ (t_i − t̄)², 1e-300) · (t_{T−1} − t_0).

    An oscillation around a steady mean has no drift; PI/WPI's divergence (seed 000 §5.3
    analysis 1) shows as a trend. Row by row, so each sample's k values are read together.

    Args:
        t: (T,) sample times [s]; x: (T, k) samples.
        mean: (≥ k,) scratch, overwritten; out: (k,) the drifts, written.
    """
    T, K = x.shape
    t_mean = 0.0
    for i in range(T):
        t_mean += t[i]
    t_mean /= T
    for j in range(K):
        mean[j], out[j] = 0.0, 0.0
    for i in range(T):
        for j in range(K):
            mean[j] += x[i, j]
    for j in range(K):
        mean[j] /= T
    spread = 0.0
    for i in range(T):
        tc = t[i] - t_mean
        spread += tc * tc
        for j in range(K):
            out[j] += tc * (x[i, j] - mean[j])
    for j in range(K):
        out[j] = out[j] / max(spread, 1e-300) * (t[T - 1] - t[0])


@register_borrowing
def efficacy_sums(alpha_top: np.ndarray, alpha_bottom: np.ndarray) -> tuple[float, float]:
    """Seed 002 eq (29) as printed and SPEC erratum 11's integral form, as fractions (module
    docstring), from the tilts α_top, α_bottom (T,) [rad] (uniform dt)."""
    printed, tilted, top, bottom = 0.0, 0, 0.0, 0.0
    for k in range(alpha_top.shape[0]):
        a, b = alpha_top[k], alpha_bottom[k]
        if b > TILTED:
            printed += (b - a) / b
            tilted += 1
        top += abs(a)
        bottom += abs(b)
    return (printed / tilted if tilted > 0 else 0.0), (1.0 - top / bottom if bottom > 0 else 0.0)


@register_borrowing
def extreme(x: np.ndarray, first: int) -> float:
    """The signed value of x[first:] of largest magnitude, the first on a tie (seed 004 reports
    φe, θe maxima with sign)."""
    best = x[first]
    for k in range(first + 1, x.shape[0]):
        if abs(x[k]) > abs(best):
            best = x[k]
    return best


@register_borrowing
def hybrid_reduction_lane(
    t: np.ndarray,
    xi: np.ndarray,
    legs: np.ndarray,
    tip_error: np.ndarray,
    manipulability: np.ndarray,
    phi_e: np.ndarray,
    theta_e: np.ndarray,
    alpha_top: np.ndarray,
    alpha_bottom: np.ndarray,
    hold: bool,
    lower: np.ndarray,
    upper: np.ndarray,
    leg_min: float,
    leg_max: float,
    out: np.ndarray,
    mean: np.ndarray,
) -> None:
    """One lane's reductions (module docstring) over all the samples it is given.

    Args:
        t: (T,) [s]; xi: (T, 9) [m, rad]; legs: (T, 6) [m]; tip_error: (T, 6) [m, rad] in B;
            manipulability, phi_e, theta_e, alpha_top, alpha_bottom: (T,) [-, rad].
        hold: the lane's `joint_limits` is "hold" (only samples past a limit count).
        lower, upper: (9,) Table 6's joint limits [m, rad]; leg_min, leg_max: stroke [m].
        out: (N_ROW,) written; mean: (≥ 9,) scratch, overwritten.
    """
    T = t.shape[0]
    first = min(SETTLE, T - 1)
    joint_bad, leg_bad, bad = 0, 0, 0
    leg_low, leg_high = leg_min - LEG_TOL, leg_max + LEG_TOL
    for k in range(T):
        joint = False
        for j in range(N_JOINTS):
            x = xi[k, j]
            if hold:
                joint |= (x < lower[j] - JOINT_TOL) | (x > upper[j] + JOINT_TOL)
            else:
                joint |= (x <= lower[j] + JOINT_TOL) | (x >= upper[j] - JOINT_TOL)
        leg = False
        for j in range(N_LEGS):
            leg |= (legs[k, j] < leg_low) | (legs[k, j] > leg_high)
        joint_bad += joint  # `|`, not `or`: no branch per comparison
        leg_bad += leg
        bad += joint | leg
    out[R_VIOLATIONS], out[R_JOINT_VIOLATIONS], out[R_LEG_VIOLATIONS] = bad, joint_bad, leg_bad
    # min and max, errors and the manipulability over the settled samples
    for j in range(N_JOINTS):
        out[R_JOINT_MIN + j], out[R_JOINT_MAX + j] = xi[first, j], xi[first, j]
    legs_low, legs_high = legs[first, 0], legs[first, 0]
    position, position_max, orientation, orientation_max = 0.0, 0.0, 0.0, 0.0
    manipulability_min = manipulability[first]
    e = tip_error
    for k in range(first, T):
        for j in range(N_JOINTS):
            out[R_JOINT_MIN + j] = min(out[R_JOINT_MIN + j], xi[k, j])
            out[R_JOINT_MAX + j] = max(out[R_JOINT_MAX + j], xi[k, j])
        for j in range(N_LEGS):
            legs_low, legs_high = min(legs_low, legs[k, j]), max(legs_high, legs[k, j])
        p = math.sqrt(e[k, 0] * e[k, 0] + e[k, 1] * e[k, 1] + e[k, 2] * e[k, 2])
        r = math.sqrt(e[k, 3] * e[k, 3] + e[k, 4] * e[k, 4] + e[k, 5] * e[k, 5])
        position += p * p
        orientation += r * r
        position_max, orientation_max = max(position_max, p), max(orientation_max, r)
        manipulability_min = min(manipulability_min, manipulability[k])
    out[R_LEGS_MIN], out[R_LEGS_MAX] = legs_low, legs_high
    out[R_POSITION_RMS] = math.sqrt(position / (T - first))
    out[R_ORIENTATION_RMS] = math.sqrt(orientation / (T - first))
    out[R_POSITION_MAX], out[R_ORIENTATION_MAX] = position_max, orientation_max
    out[R_MANIPULABILITY_MIN] = manipulability_min
    out[R_PHI_E], out[R_THETA_E] = extreme(phi_e, first), extreme(theta_e, first)
    out[R_ETA_PRINTED], out[R_ETA] = efficacy_sums(alpha_top, alpha_bottom)
    drift_lane(t, xi, mean, out[R_JOINT_DRIFT : R_JOINT_DRIFT + N_JOINTS])
    drift_lane(t, legs, mean, out[R_LEG_DRIFT : R_LEG_DRIFT + N_LEGS])


def run_hybrid_reductions(
    t: np.ndarray,
    xi: np.ndarray,
    legs: np.ndarray,
    tip_error: np.ndarray,
    manipulability: np.ndarray,
    phi_e: np.ndarray,
    theta_e: np.ndarray,
    alpha_top: np.ndarray,
    alpha_bottom: np.ndarray,
    ends: np.ndarray,
    hold: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    leg_min: float,
    leg_max: float,
    out: np.ndarray,
) -> None:
    """Reductions of N lanes, each over its own first `ends[n]` samples (`hybrid_reduction_lane`).

    Args:
        t .. alpha_bottom: (N, C, ...) the series (`REDUCED`; C ≥ every end), as
            `hybrid_reduction_lane` takes them per lane.
        ends: (N,) int, samples of each lane (≥ 1); hold: (N,) bool, each lane's mode.
        lower, upper, leg_min, leg_max: as `hybrid_reduction_lane`'s.
        out: (N, N_ROW), written.
    """
    for n in prange(ends.shape[0]):
        e = ends[n]
        hybrid_reduction_lane(t[n, :e], xi[n, :e], legs[n, :e], tip_error[n, :e],
                              manipulability[n, :e], phi_e[n, :e], theta_e[n, :e],
                              alpha_top[n, :e], alpha_bottom[n, :e], hold[n], lower, upper,
                              leg_min, leg_max, out[n], np.empty(N_JOINTS))  # fmt: skip


@cache
def compiled_hybrid_reductions(parallel: bool) -> Callable:
    """`run_hybrid_reductions` compiled (`compile_runner`); plain Python without numba."""
    return compile_runner(run_hybrid_reductions, parallel, ("twin.sim.kernels.metrics",))


def run_drift(t: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """`drift_lane` of one series (the small platforms' metrics): t (T,) [s], x (T, k); the
    drifts (k,) written into out."""
    drift_lane(t, x, np.empty(x.shape[1]), out)


def run_efficacy(alpha_top: np.ndarray, alpha_bottom: np.ndarray, out: np.ndarray) -> None:
    """`efficacy_sums` of one run's tilts (T,) [rad]: (printed, integral) written into out (2,)."""
    out[0], out[1] = efficacy_sums(alpha_top, alpha_bottom)


class SeriesReductions(NamedTuple):
    """The one-series runners, compiled (or plain without numba)."""

    drift: Callable
    efficacy: Callable


@cache
def compiled_series_reductions() -> SeriesReductions:
    """`run_drift` and `run_efficacy` compiled (`compile_runner`, serial); plain Python without
    numba."""
    modules = ("twin.sim.kernels.metrics",)
    return SeriesReductions(
        compile_runner(run_drift, False, modules), compile_runner(run_efficacy, False, modules)
    )

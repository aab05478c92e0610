r"""The numbers a hybrid-system run is judged by, reduced from its series for every lane at once,
compiled.

`twin.sim.metrics.hybrid_metrics` turns one lane's row of reductions into its metrics dict
(units, names, `finite`); this module computes the rows: one pass per lane, row by row,
over its own first `end` samples (lanes of one Simulation may last differently), parallel over
lanes, reading the history's arrays in place. Everything is in the series' units: m, rad, s.

Per lane, over samples k = 0 … T−1 (T = end), S = min(SETTLE, T − 1) the first one judged:

- violations: samples with a virtual joint on or past its Table 6 limit (to 1e-9; `record`
  mode) or past it (`hold` mode), and samples with a leg past its stroke by more than
  `LEG_TOL` (`twin.mechanisms.limits`: the same predicates as the objects'); all samples;
- per joint and over all legs: min and max over k ≥ S;
- drift of each joint and leg: the least-squares slope of x(t) times the run's duration,
  Σ (t_k − t̄)(x_k − x̄) / max(Σ (t_k − t̄)², 1e-300) · (t_{T−1} − t_0), all samples, its sums
  updated sample by sample (Welford 1962's running means and co-moments, `trend_add`);
- tip error (in B): RMS and max over k ≥ S of |e_p| [m] and |e_R| [rad];
- manipulability min, and φe, θe's signed value of largest magnitude (the first on a tie),
  over k ≥ S;
- seed 002 eq (29) as printed: the mean of (α_bottom − α_top)/α_bottom over samples with
  α_bottom > 1e-9 rad (0 if none); SPEC erratum 11's integral form 1 − Σ|α_top| / Σ|α_bottom|
  (0 if the base never tilts); both as fractions, all samples;
- the first bound: the time of the first violating sample and the limit it violates
  (`hybrid_first_bound`: of those it violates, the one passed furthest as a share of its
  range), all samples; what a workability row names as its limiting constraint.

Every reduction is a running one: a lane's accumulator row (`HYBRID_ACCUMULATOR`, N_ACC
floats, read by name) takes its
samples in order, one at a time (`hybrid_add_sample`), in as many chunks as come
(`hybrid_add_lane`) or as each is recorded (`twin.sim.kernels.records.run_hybrid_records`), and
`hybrid_finish_lane` turns it into the row of results. A whole series is one chunk
(`hybrid_reduction_lane`); a run that keeps no series (`twin.sim.engine.Simulation`'s
keep="metrics") feeds each chunk as it is stepped, so its memory does not grow with its
length, and it gets the same bits: the sums run sample by sample, in order, whatever the chunks
(no fast-math), so the compiled and the interpreted runner give the same bits too, and numpy's
pairwise sums agree to rounding. The records carry no NaN (the engine holds non-finite
samples), so min, max and the extremes need not order NaN as numpy does.

The small platforms' reductions (`platform_add_lane`, below) run the same way, from the same
running sums (`trend_add`, `efficacy_add`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache
from typing import NamedTuple

import numpy as np

from twin.compiled import compile_runner, prange, register_borrowing, register_inline
from twin.mechanisms.limits import joint_past_lane, leg_past_lane
from twin.planners.parameters import record_dtype, row_size

#: samples left out at the start of min/max and error statistics (seed 000 §5.3: "the first 10
#: data points are removed")
SETTLE = 10
#: [rad] the least base tilt counted by eq (29) as printed
TILTED = 1e-9

N_JOINTS, N_LEGS = 9, 6
#: a row of `run_hybrid_reductions`' output (`record_dtype`, read by name): the counts, the
#: joints' min, max and drift, the legs' drift, min and max, the tip errors' RMS and max, the
#: manipulability's min, φe and θe, seed 002 eq (29) printed and integral, the first violating
#: sample's time [s] and its limit's code (`hybrid_first_bound`; 0: none)
HYBRID_ROW = record_dtype(
    (
        ("violations", 1), ("joint_violations", 1), ("leg_violations", 1),
        ("joint_min", N_JOINTS), ("joint_max", N_JOINTS), ("joint_drift", N_JOINTS),
        ("leg_drift", N_LEGS), ("legs_min", 1), ("legs_max", 1),
        ("position_rms", 1), ("position_max", 1), ("orientation_rms", 1), ("orientation_max", 1),
        ("manipulability_min", 1), ("phi_e", 1), ("theta_e", 1), ("eta_printed", 1), ("eta", 1),
        ("bound_t", 1), ("bound", 1),
    ),
    what="HYBRID_ROW",
)  # fmt: skip
N_ROW = row_size(HYBRID_ROW)

#: the series `run_hybrid_reductions` reads, in its argument order
REDUCED = ("t", "xi", "legs", "tip_error", "manipulability", "phi_e", "theta_e", "alpha_top",
           "alpha_bottom")  # fmt: skip


def trend_dtype(k: int) -> np.dtype:
    """A running least-squares trend of up to k ≥ 2 columns (`trend_add`, 4 + 2k floats): the
    first and last time, the running mean of t and Σ (t − t̄)², then the k running means and
    the k co-moments Σ (t − t̄)(x − x̄)."""
    return record_dtype((("t0", 1), ("t_last", 1), ("t_mean", 1), ("t_spread", 1),
                         ("means", k), ("comoments", k)), what="trend_dtype")  # fmt: skip


#: running tip-error sums (`tip_error_add`): Σ|e_p|² [m²], max |e_p| [m], Σ|e_r|² [rad²],
#: max |e_r| [rad]
TIP_ERRORS = record_dtype(
    (("position", 1), ("position_max", 1), ("orientation", 1), ("orientation_max", 1)),
    what="TIP_ERRORS",
)
#: running efficacy sums (`efficacy_add`): Σ (α_b − α_t)/α_b over tilted samples, their
#: number, Σ|α_t|, Σ|α_b|
EFFICACY = record_dtype((("printed", 1), ("tilted", 1), ("top", 1), ("bottom", 1)),
                        what="EFFICACY")  # fmt: skip
#: a hybrid lane's accumulator row (`hybrid_add_lane`), N_ACC floats read by name: samples
#: seen, the first judged one, the counts, min/max and sums of the module docstring, then the
#: efficacy sums, the joints' and legs' trends and the first bound (its time [s] and code)
HYBRID_ACCUMULATOR = record_dtype(
    (
        ("seen", 1), ("first", 1), ("violations", 1), ("joint_violations", 1),
        ("leg_violations", 1), ("joint_min", N_JOINTS), ("joint_max", N_JOINTS),
        ("legs_min", 1), ("legs_max", 1), ("tip", TIP_ERRORS), ("manipulability_min", 1),
        ("phi_e", 1), ("theta_e", 1), ("efficacy", EFFICACY),
        ("joint_trend", trend_dtype(N_JOINTS)), ("leg_trend", trend_dtype(N_LEGS)),
        ("bound_t", 1), ("bound", 1),
    ),
    what="HYBRID_ACCUMULATOR",
)  # fmt: skip
N_ACC = row_size(HYBRID_ACCUMULATOR)
#: the scratch trend of `drift_lane`, which runs its columns N_JOINTS at a time
DRIFT_TREND = trend_dtype(N_JOINTS)
#: `hybrid_first_bound`'s codes: 1 + 2j + side for joint j (`JOINT_NAMES` order), then
#: 1 + 2 N_JOINTS + 2i + side for leg i; side 0 lower, 1 upper; 0 none
BOUND_LEGS = 1 + 2 * N_JOINTS


@register_borrowing
def trend_add(d: np.record, n: int, t: float, x: np.ndarray) -> None:
    """Add the n-th sample (n ≥ 1, in order) to a running least-squares trend of k columns.

    Welford 1962's update of running means and corrected sums of products: with
    δ = t − t̄_{n−1}, t̄_n = t̄_{n−1} + δ/n, Σ(t − t̄)² += δ (t − t̄_n), and per column
    x̄_n = x̄_{n−1} + (x − x̄_{n−1})/n, Σ(t − t̄)(x − x̄) += δ (x − x̄_n): the two-pass sums
    of `drift_lane`'s formula without knowing the means beforehand, as stable as they.

    Args:
        d: the trend's running sums (`trend_dtype` of k or more columns), zero before the
            first sample.
        n: this sample's count, 1 for the first; t: its time [s]; x: (k,) its values.
    """
    k = x.shape[0]
    if n == 1:
        d.t0 = t
    d.t_last = t
    inverse = 1.0 / n
    delta = t - d.t_mean
    t_mean = d.t_mean + delta * inverse
    d.t_mean = t_mean
    d.t_spread += delta * (t - t_mean)
    means, comoments = d.means, d.comoments
    for j in range(k):
        means[j] += (x[j] - means[j]) * inverse
        comoments[j] += delta * (x[j] - means[j])


@register_borrowing
def trend_finish(d: np.record, out: np.ndarray) -> None:
    """The drifts (k,) of a running trend `d` (`trend_add`) into out: the least-squares slope
    times the duration, Σ (t − t̄)(x − x̄) / max(Σ (t − t̄)², 1e-300) · (t_last − t_0)."""
    k = out.shape[0]
    scale = (d.t_last - d.t0) / max(d.t_spread, 1e-300)
    comoments = d.comoments
    for j in range(k):
        out[j] = comoments[j] * scale


@register_borrowing
def trend_clear(d: np.record) -> None:
    """Zero a running trend `d` (`trend_dtype`) for its first sample."""
    d.t0, d.t_last, d.t_mean, d.t_spread = 0.0, 0.0, 0.0, 0.0
    means, comoments = d.means, d.comoments
    for j in range(means.shape[0]):
        means[j], comoments[j] = 0.0, 0.0


@register_borrowing
def drift_lane(t: np.ndarray, x: np.ndarray, state: np.ndarray, out: np.ndarray) -> None:
    """Least-squares trend of each column of x (T, k) over the run, slope × duration, in x's
    unit (`trend_add` over every sample, then `trend_finish`), as many columns at a time as
    `state` holds (the columns' sums are independent).

    An oscillation around a steady mean has no drift; PI/WPI's divergence (seed 000 §5.3
    analysis 1) shows as a trend.

    Args:
        t: (T,) sample times [s]; x: (T, k) samples.
        state: (1,) a trend (`trend_dtype`), scratch, overwritten (an array, not its record:
            numba's records do not keep their array alive); out: (k,) the drifts, written.
    """
    T, K = x.shape
    d = state[0]
    width = d.means.shape[0]
    for j0 in range(0, K, width):
        j1 = min(j0 + width, K)
        trend_clear(d)
        for i in range(T):
            trend_add(d, i + 1, t[i], x[i, j0:j1])
        trend_finish(d, out[j0:j1])


@register_inline
def tip_error_add(errors: np.record, e: np.ndarray) -> None:
    """Add one settled sample's tip error e (6,) [m, rad] to the running tip-error sums errors
    (`TIP_ERRORS`: the hybrid's and the small platforms' accumulators' `tip`)."""
    p = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    r = math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
    errors.position += p * p
    errors.position_max = max(errors.position_max, p)
    errors.orientation += r * r
    errors.orientation_max = max(errors.orientation_max, r)


@register_inline
def tip_error_rms(errors: np.record, judged: float) -> tuple[float, float]:
    """(position [m], orientation [rad]) RMS of the tip errors of the sums errors
    (`TIP_ERRORS`, `tip_error_add`) over `judged` samples."""
    return math.sqrt(errors.position / judged), math.sqrt(errors.orientation / judged)


@register_borrowing
def efficacy_add(e: np.record, alpha_top: float, alpha_bottom: float) -> None:
    """Add one sample's tilts [rad] to the running efficacy sums e (`EFFICACY`)."""
    if alpha_bottom > TILTED:
        e.printed += (alpha_bottom - alpha_top) / alpha_bottom
        e.tilted += 1.0
    e.top += abs(alpha_top)
    e.bottom += abs(alpha_bottom)


@register_borrowing
def efficacy_finish(e: np.record) -> tuple[float, float]:
    """Seed 002 eq (29) as printed and SPEC erratum 11's integral form, as fractions (module
    docstring), from the running sums e (`EFFICACY`, `efficacy_add`)."""
    printed = e.printed / e.tilted if e.tilted > 0 else 0.0
    return printed, (1.0 - e.top / e.bottom if e.bottom > 0 else 0.0)


@register_borrowing
def efficacy_sums(
    alpha_top: np.ndarray, alpha_bottom: np.ndarray, sums: np.ndarray
) -> tuple[float, float]:
    """Seed 002 eq (29) as printed and SPEC erratum 11's integral form, as fractions (module
    docstring), from the tilts α_top, α_bottom (T,) [rad] (uniform dt); sums (1,) `EFFICACY`
    scratch, overwritten (an array, not its record, as `drift_lane`'s state)."""
    e = sums[0]
    e.printed, e.tilted, e.top, e.bottom = 0.0, 0.0, 0.0, 0.0
    for k in range(alpha_top.shape[0]):
        efficacy_add(e, alpha_top[k], alpha_bottom[k])
    return efficacy_finish(e)


@register_borrowing
def hybrid_begin_lane(acc: np.ndarray, end: int) -> None:
    """Clear a lane's accumulator row acc (N_ACC,) for a series of `end` samples (≥ 1): the
    first judged sample is min(SETTLE, end − 1)."""
    for j in range(acc.shape[0]):
        acc[j] = 0.0
    acc.view(HYBRID_ACCUMULATOR)[0].first = min(SETTLE, end - 1)


#: a lane's samples as the reductions read them, `REDUCED`'s arrays in order, each (S, ...):
#: t [s]; xi (S, 9) [m, rad]; legs (S, 6) [m]; tip_error (S, 6) [m, rad] in B; manipulability,
#: phi_e, theta_e, alpha_top, alpha_bottom (S,) [-, rad]
HybridSamples = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                      np.ndarray, np.ndarray, np.ndarray]  # fmt: skip
#: a lane's limits as the reductions judge them: hold (its `joint_limits` is "hold": only
#: samples past a limit count), lower, upper (9,) Table 6's joint limits [m, rad], leg_min,
#: leg_max the stroke [m]
HybridLimits = tuple[bool, np.ndarray, np.ndarray, float, float]


@register_inline
def hybrid_settled_add(
    a: np.record,
    opening: bool,
    x: np.ndarray,
    legs: np.ndarray,
    e: np.ndarray,
    manipulability: float,
    phi_e: float,
    theta_e: float,
) -> None:
    """A settled sample's (k ≥ the first judged) min and max, tip errors and manipulability
    into a lane's accumulator a (`HYBRID_ACCUMULATOR`) (module docstring); opening: it is the
    first judged sample, which starts the min and max. x (9,) [m, rad], legs (6,) [m], e (6,)
    [m, rad] in B."""
    joint_min, joint_max = a.joint_min, a.joint_max
    if opening:
        for j in range(N_JOINTS):
            joint_min[j], joint_max[j] = x[j], x[j]
        a.legs_min, a.legs_max = legs[0], legs[0]
        a.manipulability_min = manipulability
        a.phi_e, a.theta_e = phi_e, theta_e
    for j in range(N_JOINTS):
        joint_min[j] = min(joint_min[j], x[j])
        joint_max[j] = max(joint_max[j], x[j])
    for j in range(N_LEGS):
        a.legs_min = min(a.legs_min, legs[j])
        a.legs_max = max(a.legs_max, legs[j])
    tip_error_add(a.tip, e)
    a.manipulability_min = min(a.manipulability_min, manipulability)
    # the signed value of largest magnitude, the first on a tie (seed 004 reports φe, θe
    # maxima with sign)
    if abs(phi_e) > abs(a.phi_e):
        a.phi_e = phi_e
    if abs(theta_e) > abs(a.theta_e):
        a.theta_e = theta_e


@register_inline
def hybrid_first_bound(
    x: np.ndarray, legs: np.ndarray, lower: np.ndarray, upper: np.ndarray, leg_min: float,
    leg_max: float, hold: bool,
) -> int:
    """The limit a violating sample violates (`BOUND_LEGS` for the codes): of the joints on or
    past a limit (past one in hold mode; `hybrid_add_sample`'s test) and the legs past their
    stroke, the one passed furthest as a share of its range; the first in code order on a tie.

    Args:
        x: (9,) xi [m, rad]; legs: (6,) [m]; lower, upper: (9,) the joint limits; leg_min,
            leg_max: the stroke [m]; hold: the lane's mode.
    """
    best, code = -math.inf, 0
    for j in range(N_JOINTS):
        side = joint_past_lane(x[j], lower[j], upper[j], 0.0 if hold else 1.0)
        if side != 0.0:  # the flags' own predicate: a flagged sample always has a bound
            past = lower[j] - x[j] if side < 0.0 else x[j] - upper[j]
            if past / (upper[j] - lower[j]) > best:
                best, code = past / (upper[j] - lower[j]), 1 + 2 * j + (side > 0.0)
    span = leg_max - leg_min
    for i in range(N_LEGS):
        side = leg_past_lane(legs[i], leg_min, leg_max)
        if side != 0.0:
            past = leg_min - legs[i] if side < 0.0 else legs[i] - leg_max
            if past / span > best:
                best, code = past / span, BOUND_LEGS + 2 * i + (side > 0.0)
    return code


@register_inline
def hybrid_add_sample(
    a: np.record,
    t: float,
    x: np.ndarray,
    legs: np.ndarray,
    e: np.ndarray,
    scalars: tuple[float, float, float, float, float],
    limits: HybridLimits,
) -> None:
    """Add a lane's next sample to its accumulator a (`HYBRID_ACCUMULATOR`, a row of
    `hybrid_begin_lane` as a record; module docstring): what `hybrid_add_lane` does per
    sample, and the records runner reducing (`twin.sim.kernels.records.hybrid_record_lane`)
    as each sample is recorded.

    Args:
        t: [s]; x: (9,) xi [m, rad]; legs: (6,) [m]; e: (6,) the tip error [m, rad] in B.
        scalars: manipulability, phi_e, theta_e, alpha_top, alpha_bottom [-, rad].
        limits: the lane's (`HybridLimits`).
    """
    hold, lower, upper, leg_min, leg_max = limits
    manipulability, phi_e, theta_e, alpha_top, alpha_bottom = scalars
    k = int(a.seen)
    joint = False
    touching = 0.0 if hold else 1.0
    for j in range(N_JOINTS):  # `|`, not `or`: no branch per joint
        joint |= joint_past_lane(x[j], lower[j], upper[j], touching) != 0.0
    leg = False
    for j in range(N_LEGS):
        leg |= leg_past_lane(legs[j], leg_min, leg_max) != 0.0
    # counts as floats: whole numbers, exact to 2^53
    a.joint_violations += 1.0 if joint else 0.0
    a.leg_violations += 1.0 if leg else 0.0
    a.violations += 1.0 if joint | leg else 0.0
    if (joint | leg) and a.bound == 0.0:
        a.bound_t = t
        a.bound = hybrid_first_bound(x, legs, lower, upper, leg_min, leg_max, hold)
    if k >= int(a.first):
        hybrid_settled_add(a, k == int(a.first), x, legs, e, manipulability, phi_e,
                           theta_e)  # fmt: skip
    efficacy_add(a.efficacy, alpha_top, alpha_bottom)
    trend_add(a.joint_trend, k + 1, t, x)
    trend_add(a.leg_trend, k + 1, t, legs)
    a.seen = k + 1


@register_borrowing
def hybrid_add_lane(samples: HybridSamples, limits: HybridLimits, acc: np.ndarray) -> None:
    """Add a lane's next samples (`HybridSamples`, the samples after those already added), in
    order, to its accumulator row acc (N_ACC,) (`hybrid_begin_lane`), updated, judged by its
    limits (`HybridLimits`): `hybrid_add_sample` of each."""
    t, xi, legs, e, manipulability, phi_e, theta_e, alpha_top, alpha_bottom = samples
    a = acc.view(HYBRID_ACCUMULATOR)[0]  # the row by name
    for i in range(t.shape[0]):
        hybrid_add_sample(a, t[i], xi[i], legs[i], e[i],
                          (manipulability[i], phi_e[i], theta_e[i], alpha_top[i],
                           alpha_bottom[i]), limits)  # fmt: skip


@register_borrowing
def hybrid_finish_lane(acc: np.ndarray, out: np.ndarray) -> None:
    """A lane's row of reductions out (N_ROW,) from its accumulator row acc (N_ACC,), after
    its last sample (`hybrid_add_lane`)."""
    a, r = acc.view(HYBRID_ACCUMULATOR)[0], out.view(HYBRID_ROW)[0]  # the rows by name
    judged = a.seen - a.first
    r.violations = a.violations
    r.joint_violations = a.joint_violations
    r.leg_violations = a.leg_violations
    joint_min, joint_max, out_min, out_max = a.joint_min, a.joint_max, r.joint_min, r.joint_max
    for j in range(N_JOINTS):
        out_min[j], out_max[j] = joint_min[j], joint_max[j]
    r.legs_min, r.legs_max = a.legs_min, a.legs_max
    r.position_rms, r.orientation_rms = tip_error_rms(a.tip, judged)
    r.position_max, r.orientation_max = a.tip.position_max, a.tip.orientation_max
    r.manipulability_min = a.manipulability_min
    r.phi_e, r.theta_e = a.phi_e, a.theta_e
    r.eta_printed, r.eta = efficacy_finish(a.efficacy)
    trend_finish(a.joint_trend, r.joint_drift)
    trend_finish(a.leg_trend, r.leg_drift)
    r.bound_t, r.bound = a.bound_t, a.bound


@register_borrowing
def hybrid_reduction_lane(
    samples: HybridSamples, limits: HybridLimits, out: np.ndarray, acc: np.ndarray
) -> None:
    """One lane's reductions (module docstring) over all the samples it is given: its series as
    one chunk (`hybrid_begin_lane`, `hybrid_add_lane`, `hybrid_finish_lane`).

    Args:
        samples, limits: as `hybrid_add_lane`'s, (T, ...) the whole series.
        out: (N_ROW,) written; acc: (≥ N_ACC,) scratch, overwritten.
    """
    hybrid_begin_lane(acc, samples[0].shape[0])
    hybrid_add_lane(samples, limits, acc)
    hybrid_finish_lane(acc, out)


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
            `HybridSamples` per lane.
        ends: (N,) int, samples of each lane (≥ 1); hold: (N,) bool, each lane's mode.
        lower, upper, leg_min, leg_max: the lanes' `HybridLimits` but hold.
        out: (N, N_ROW), written.
    """
    for n in prange(ends.shape[0]):
        e = ends[n]
        samples = (t[n, :e], xi[n, :e], legs[n, :e], tip_error[n, :e], manipulability[n, :e],
                   phi_e[n, :e], theta_e[n, :e], alpha_top[n, :e], alpha_bottom[n, :e])  # fmt: skip
        hybrid_reduction_lane(samples, (hold[n], lower, upper, leg_min, leg_max), out[n],
                              np.empty(N_ACC))  # fmt: skip


def run_hybrid_add(
    t: np.ndarray,
    xi: np.ndarray,
    legs: np.ndarray,
    tip_error: np.ndarray,
    manipulability: np.ndarray,
    phi_e: np.ndarray,
    theta_e: np.ndarray,
    alpha_top: np.ndarray,
    alpha_bottom: np.ndarray,
    counts: np.ndarray,
    hold: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    leg_min: float,
    leg_max: float,
    acc: np.ndarray,
) -> None:
    """A chunk of N lanes into their accumulator rows (`hybrid_add_lane`), lane n its first
    counts[n] samples (0 … S: a lane past its end adds none).

    Args:
        t .. alpha_bottom: (N, S, ...) the chunk's records (`REDUCED`).
        counts: (N,) int; hold, lower, upper, leg_min, leg_max: as `run_hybrid_reductions`'.
        acc: (N, N_ACC), updated.
    """
    for n in prange(counts.shape[0]):
        c = counts[n]
        if c > 0:
            samples = (t[n, :c], xi[n, :c], legs[n, :c], tip_error[n, :c],
                       manipulability[n, :c], phi_e[n, :c], theta_e[n, :c], alpha_top[n, :c],
                       alpha_bottom[n, :c])  # fmt: skip
            hybrid_add_lane(samples, (hold[n], lower, upper, leg_min, leg_max), acc[n])


@cache
def compiled_hybrid_add(parallel: bool) -> Callable:
    """`run_hybrid_add` compiled (`compile_runner`); plain Python without numba."""
    return compile_runner(run_hybrid_add, parallel, ("twin.sim.kernels.metrics",))


@cache
def compiled_hybrid_reductions(parallel: bool) -> Callable:
    """`run_hybrid_reductions` compiled (`compile_runner`); plain Python without numba."""
    return compile_runner(run_hybrid_reductions, parallel, ("twin.sim.kernels.metrics",))


def run_drift(t: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """`drift_lane` of one series (the small platforms' metrics): t (T,) [s], x (T, k); the
    drifts (k,) written into out."""
    drift_lane(t, x, np.zeros(1, DRIFT_TREND), out)


def run_efficacy(alpha_top: np.ndarray, alpha_bottom: np.ndarray, out: np.ndarray) -> None:
    """`efficacy_sums` of one run's tilts (T,) [rad]: (printed, integral) written into out (2,)."""
    out[0], out[1] = efficacy_sums(alpha_top, alpha_bottom, np.zeros(1, EFFICACY))


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


# ------------------------------------------------------------------ the small platforms' lanes
# The 3UPU_UP's and 4-UPR's metrics (`twin.sim.metrics.platform_metrics`) run the same way: a
# lane's accumulator row (`PLATFORM_ACCUMULATOR`) takes its samples in order, in as many chunks
# as come (`platform_add_lane`), and `platform_finish_lane` gives what needs the last sample.
# Per lane, over samples k = 0 … T−1, S = min(SETTLE, T − 1) the first one judged:
#
# - violations: samples where some limit kind is violated (each kind's flag per sample is
#   `PlatformModel.reached` or `.violations`, computed by the caller in numpy: the limits are
#   the mechanism's, stated once there), and each kind's count; all samples;
# - per state column and over all actuators: min and max over k ≥ S; drifts as the hybrid's
#   (`trend_add`), all samples;
# - the actuators' largest |rate|, and the samples clipped and saturated (diagnostic > 0), all
#   samples;
# - tip error: RMS and max over k ≥ S of |e_p| [m] and |e_R| [rad]; the largest α_top, α_bottom
#   and |coupled displacement| per axis (seed 001 eq (15), the Upu3Up's) over k ≥ S;
# - the two efficacies (`efficacy_add`), all samples;
# - the first bound: the first violating sample's time and the first limit kind it violates
#   (in the kinds' order, the clamped demand last), all samples.

#: most actuators of a small platform (the 4-UPR's four; the 3UPU_UP has three)
MAX_ACTUATORS = 4
#: most limit kinds a small platform's metrics count (`twin.sim.metrics.PlatformReduction`:
#: its mechanism's, then the clamped demand)
MAX_LIMIT_KINDS = 8
#: a small platform lane's accumulator row (`platform_add_lane`), N_PLATFORM_ACC floats read
#: by name: samples seen, the first judged one, violating samples, then min/max, maxima and
#: sums (block comment above), the efficacy sums, the state's and the actuators' trends, the
#: first bound (its time [s] and 1 + its kind's index, 0 none), and last one count per limit
#: kind (the first `kinds` of MAX_LIMIT_KINDS)
PLATFORM_ACCUMULATOR = record_dtype(
    (
        ("seen", 1), ("first", 1), ("violations", 1), ("state_min", 3), ("state_max", 3),
        ("legs_min", 1), ("legs_max", 1), ("rate_max", 1), ("tip", TIP_ERRORS),
        ("alpha_top_max", 1), ("alpha_bottom_max", 1), ("clipped", 1), ("saturated", 1),
        ("coupled_max", 3), ("efficacy", EFFICACY), ("state_trend", trend_dtype(3)),
        ("leg_trend", trend_dtype(MAX_ACTUATORS)), ("bound_t", 1), ("bound", 1),
        ("kinds", MAX_LIMIT_KINDS),
    ),
    what="PLATFORM_ACCUMULATOR",
)  # fmt: skip
N_PLATFORM_ACC = row_size(PLATFORM_ACCUMULATOR)
#: `platform_finish_lane`'s row, read by name: the state's drifts (3), the actuators'
#: (MAX_ACTUATORS, the first n written), the tip errors' RMS, the two efficacies
PLATFORM_ROW = record_dtype(
    (("state_drift", 3), ("leg_drift", MAX_ACTUATORS), ("position_rms", 1),
     ("orientation_rms", 1), ("eta_printed", 1), ("eta", 1)),
    what="PLATFORM_ROW",
)  # fmt: skip
N_PLATFORM_ROW = row_size(PLATFORM_ROW)

#: the series `run_platform_add` reads, in its argument order (then the coupled displacement,
#: the limit flags and the counts)
PLATFORM_REDUCED = ("t", "state", "legs", "leg_rates", "tip_error", "alpha_top", "alpha_bottom",
                    "clipped", "saturated")  # fmt: skip


@register_borrowing
def platform_begin_lane(acc: np.ndarray, end: int) -> None:
    """Clear a small platform lane's accumulator row acc (N_PLATFORM_ACC,) for a series of
    `end` samples (≥ 1): the first judged sample is min(SETTLE, end − 1)."""
    for j in range(acc.shape[0]):
        acc[j] = 0.0
    acc.view(PLATFORM_ACCUMULATOR)[0].first = min(SETTLE, end - 1)


@register_borrowing
def platform_add_lane(
    t: np.ndarray,
    state: np.ndarray,
    legs: np.ndarray,
    rates: np.ndarray,
    tip_error: np.ndarray,
    alpha_top: np.ndarray,
    alpha_bottom: np.ndarray,
    clipped: np.ndarray,
    saturated: np.ndarray,
    coupled: np.ndarray,
    flags: np.ndarray,
    acc: np.ndarray,
) -> None:
    """Add a small platform lane's next samples, in order, to its accumulator row (the block
    comment above `MAX_ACTUATORS`).

    Args:
        t: (S,) [s]; state: (S, 3) [native, rad, rad]; legs, rates: (S, n) actuator lengths
            [native] and rates [native/s], n ≤ MAX_ACTUATORS; tip_error: (S, 6) [m, rad];
            alpha_top, alpha_bottom: (S,) [rad]; clipped, saturated: (S,) the step's
            diagnostics; coupled: (S, 3) seed 001 eq (15) [mm], or (S, 0) for a mechanism
            without; flags: (S, kinds) bool, each limit kind violated at each sample: the
            samples after those already added (kinds ≤ MAX_LIMIT_KINDS).
        acc: (N_PLATFORM_ACC,) the lane's row (`platform_begin_lane`), updated.
    """
    a = acc.view(PLATFORM_ACCUMULATOR)[0]  # the row by name
    first = int(a.first)
    seen = int(a.seen)
    n_legs, kinds, axes = legs.shape[1], flags.shape[1], coupled.shape[1]
    counts, state_min, state_max, coupled_max = a.kinds, a.state_min, a.state_max, a.coupled_max
    for i in range(t.shape[0]):
        k = seen + i
        bad = False
        for j in range(kinds):
            counts[j] += flags[i, j]
            if flags[i, j] and a.bound == 0.0:
                a.bound_t, a.bound = t[i], j + 1
            bad |= flags[i, j]
        a.violations += bad
        for j in range(n_legs):
            a.rate_max = max(a.rate_max, abs(rates[i, j]))
        a.clipped += clipped[i] > 0
        a.saturated += saturated[i] > 0
        if k >= first:  # min and max, errors and tilts over the settled samples
            if k == first:
                for j in range(3):
                    state_min[j], state_max[j] = state[i, j], state[i, j]
                a.legs_min, a.legs_max = legs[i, 0], legs[i, 0]
                a.alpha_top_max = alpha_top[i]
                a.alpha_bottom_max = alpha_bottom[i]
                for j in range(axes):
                    coupled_max[j] = abs(coupled[i, j])
            for j in range(3):
                state_min[j] = min(state_min[j], state[i, j])
                state_max[j] = max(state_max[j], state[i, j])
            for j in range(n_legs):
                a.legs_min = min(a.legs_min, legs[i, j])
                a.legs_max = max(a.legs_max, legs[i, j])
            tip_error_add(a.tip, tip_error[i])
            a.alpha_top_max = max(a.alpha_top_max, alpha_top[i])
            a.alpha_bottom_max = max(a.alpha_bottom_max, alpha_bottom[i])
            for j in range(axes):
                coupled_max[j] = max(coupled_max[j], abs(coupled[i, j]))
        efficacy_add(a.efficacy, alpha_top[i], alpha_bottom[i])
        trend_add(a.state_trend, k + 1, t[i], state[i])
        trend_add(a.leg_trend, k + 1, t[i], legs[i])
    a.seen = seen + t.shape[0]


@register_borrowing
def platform_finish_lane(acc: np.ndarray, n_legs: int, out: np.ndarray) -> None:
    """What a small platform lane's metrics take beyond its accumulator row acc, after its last
    sample (`platform_add_lane`), into out (N_PLATFORM_ROW,) (`PLATFORM_ROW`): the drifts, the tip
    errors' RMS and the efficacies (fractions)."""
    a, r = acc.view(PLATFORM_ACCUMULATOR)[0], out.view(PLATFORM_ROW)[0]  # the rows by name
    judged = a.seen - a.first
    trend_finish(a.state_trend, r.state_drift)
    trend_finish(a.leg_trend, r.leg_drift[:n_legs])
    r.position_rms, r.orientation_rms = tip_error_rms(a.tip, judged)
    r.eta_printed, r.eta = efficacy_finish(a.efficacy)


def run_platform_add(
    t: np.ndarray,
    state: np.ndarray,
    legs: np.ndarray,
    rates: np.ndarray,
    tip_error: np.ndarray,
    alpha_top: np.ndarray,
    alpha_bottom: np.ndarray,
    clipped: np.ndarray,
    saturated: np.ndarray,
    coupled: np.ndarray,
    flags: np.ndarray,
    counts: np.ndarray,
    acc: np.ndarray,
) -> None:
    """A chunk of N small-platform lanes into their accumulator rows (`platform_add_lane`),
    lane n its first counts[n] samples (0 … S: a lane past its end adds none).

    Args:
        t .. flags: (N, S, ...) the chunk's records (`PLATFORM_REDUCED`), as
            `platform_add_lane` takes them per lane (coupled (N, S, 0) for the 4-UPR).
        counts: (N,) int.
        acc: (N, N_PLATFORM_ACC), updated.
    """
    for n in prange(counts.shape[0]):
        c = counts[n]
        if c > 0:
            platform_add_lane(t[n, :c], state[n, :c], legs[n, :c], rates[n, :c],
                              tip_error[n, :c], alpha_top[n, :c], alpha_bottom[n, :c],
                              clipped[n, :c], saturated[n, :c], coupled[n, :c], flags[n, :c],
                              acc[n])  # fmt: skip


def run_platform_finish(acc: np.ndarray, n_legs: int, out: np.ndarray) -> None:
    """`platform_finish_lane` of N lanes: acc (N, N_PLATFORM_ACC), out (N,
    N_PLATFORM_ROW) written."""
    for n in range(acc.shape[0]):
        platform_finish_lane(acc[n], n_legs, out[n])


@cache
def compiled_platform_add(parallel: bool) -> Callable:
    """`run_platform_add` compiled (`compile_runner`); plain Python without numba."""
    return compile_runner(run_platform_add, parallel)


@cache
def compiled_platform_finish() -> Callable:
    """`run_platform_finish` compiled (`compile_runner`, serial); plain Python without numba."""
    return compile_runner(run_platform_finish, False)

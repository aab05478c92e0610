r"""What the hybrid system records at each sample, for a whole chunk, compiled.

Nothing here feeds back into the stepping: the runner is called once per chunk, after the
kernel has stepped it, over every lane and sample (`twin.sim.lanes.HybridLanes.run`). It uses
the kernels' one-lane primitives (`twin.sim.kernels.hybrid`, `twin.planners.allocation_step`), so
the tip, its error, the legs and the manipulability are computed as the planners see them. It
reads the base from each sample's target row ᴮT_d = ᴵT_B⁻¹ ᴵT_E* (`twin.sim.target.held_targets`,
which the chunk's kernel read too), not from its pose: no roll-pitch-yaw to turn into ᴵR_B again.
The one runner keeps each sample's record (a series) or, for a run that keeps no series
(keep="metrics"), adds it to the lane's running metrics as it is made
(`twin.sim.kernels.metrics.hybrid_add_sample`, `twin.sim.lanes.HybridLanes.reduce`), the chunk's
records never kept: the same functions in the same order, so the same bits.

Per sample, with ᴵT_B the base, ᴮT_E the tip (seed 000 eq (14)) and ᴵT_E* the held tip pose:

- legs: |ᴮR_P ᴾP_i + ᴮp_P − ᴮB_i| (seed 000 eqs (4)-(5));
- tip error: [ᴮp_d − ᴮp_E; log(ᴮR_d ᴮR_Eᵀ)] with ᴮT_d = ᴵT_B⁻¹ ᴵT_E* (eq (34), SPEC erratum 6);
- manipulability: |det J_P| = sqrt(det(J_P J_Pᵀ)) (SPEC erratum 7);
- φe, θe: the azimuth and elevation of the gangway (luff pivot → tip, d3 along the tip's z
  axis) in the landing frame, minus their values at t = 0 (seed 004 §3.1 a);
- α_top: the angle between the tip's x axis ("up" at q = 0) and its held direction;
  α_bottom: the base's tilt from inertial z.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache

import numpy as np

from twin.compiled import (
    compile_runner,
    prange,
    register_borrowing,
    register_inline,
    register_jitable,
)
from twin.mechanisms.hybrid import HYBRID_CONSTANTS
from twin.mechanisms.legs import leg_vectors_lane, manipulability_lane
from twin.planners.parameters import record_dtype, row_size
from twin.planners.tasks import tip_error_lane
from twin.sim.kernels.metrics import HYBRID_ACCUMULATOR, HybridLimits, hybrid_add_sample
from twin.spatial import rpy_to_matrix_lane, tilt_lane

#: A sample's scalar record (a row of `run_hybrid_records`' `scalars`, N_SCALARS wide, read by
#: name): manipulability [-], φe, θe, α_top, α_bottom [rad] (module docstring).
SCALARS = record_dtype(
    (("manipulability", 1), ("phi_e", 1), ("theta_e", 1), ("alpha_top", 1),
     ("alpha_bottom", 1)),
    what="SCALARS",
)  # fmt: skip
N_SCALARS = row_size(SCALARS)

#: A sample's tip as the record reads it (a `tips` row, N_TIP wide, read by name): ᴮR_P
#: row-major (9), then the tip's x and z axes in B, ᴮR_E e_x (3) and ᴮR_E e_z (3). The hybrid
#: runner hands it over for a differential planner's steps, which computed it (`hand_over`).
TIP = record_dtype((("R_BP", 9), ("x_axis", 3), ("z_axis", 3)), what="TIP")
N_TIP = row_size(TIP)

#: `record_work()`'s arrays
RecordWork = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                   np.ndarray]  # fmt: skip


@register_jitable
def record_work() -> RecordWork:
    """Scratch of a lane's records, allocated once per lane (numba puts every array on the
    heap, and a reshaped view costs as much; views along a leading axis are free): ᴵR_B and
    ᴮR_P (2, 3, 3); ᴾT_E and ᴮT_E (2, 4, 4); R_d R_Eᵀ (3, 3); the tip's directions (2, 3); the
    leg vectors (6, 3); the leg Jacobian (6, 6); a tip row (N_TIP,)."""
    return (np.empty((2, 3, 3)), np.empty((2, 4, 4)), np.empty((3, 3)), np.empty((2, 3)),
            np.empty((6, 3)), np.empty((6, 6)), np.empty(N_TIP))  # fmt: skip


@register_borrowing
def gangway_angles(g: np.ndarray) -> tuple[float, float]:
    """(φ, θ) [rad]: the azimuth and elevation of the gangway vector g (3,) in the landing
    frame, as `record_from_tip` measures them (seed 004 §3.1 a)."""
    return math.atan2(g[1], g[0]), math.atan2(g[2], g[0])


@register_inline
def hand_over(
    R_BP: np.ndarray, T_E: np.ndarray, error: np.ndarray, tip_out: np.ndarray,
    error_out: np.ndarray,
) -> None:  # fmt: skip
    """A sample's ᴮR_P (3, 3), the tip ᴮT_E (4, 4) and its pose error (6,) as the record reads
    them: into tip_out (N_TIP,) (`TIP`) and error_out (6,)."""
    tip = tip_out.view(TIP)[0]  # the row by name
    R, x_axis, z_axis = tip.R_BP, tip.x_axis, tip.z_axis
    for i in range(3):
        for j in range(3):
            R[3 * i + j] = R_BP[i, j]
        x_axis[i] = T_E[i, 0]
        z_axis[i] = T_E[i, 2]
    for i in range(6):
        error_out[i] = error[i]


@register_inline
def record_from_tip(
    target: np.ndarray,
    x: np.ndarray,
    tip: np.ndarray,
    held: np.ndarray,
    landing: np.ndarray,
    phi0: float,
    theta0: float,
    c: np.record,
    legs_out: np.ndarray,
    scalars_out: np.ndarray,
    work: RecordWork,
) -> None:
    """One sample's record (module docstring) but its tip error, from its tip (`hand_over`).

    ᴵR_B is read from the target row: ᴮR_d = ᴵR_Bᵀ ᴵR_E*, so ᴵR_B = ᴵR_E* ᴮR_dᵀ.

    Args:
        target: (18,) the sample's target row (ᴮR_d row-major read).
        x: (9,) xi [m, rad].
        tip: (N_TIP,) ᴮR_P and the tip's axes (`TIP`).
        held: (4, 4) ᴵT_E*.
        landing: (3, 3) inertial → landing frame; phi0, theta0: [rad] the gangway's azimuth
            and elevation in it at t = 0 (`gangway_angles`).
        c: the hybrid constants, the `HYBRID_CONSTANTS` record (hinges read by name).
        legs_out: (6,) [m]; scalars_out: (N_SCALARS,) written.
        work: `record_work()`, overwritten (ᴵR_B, ᴮR_P, directions, legs, Jacobian).
    """
    rotations, axes, vectors, J = work[0], work[3], work[4], work[5]
    R_IB, R_BP = rotations[0], rotations[1]
    up, g = axes[0], axes[1]
    handed = tip.view(TIP)[0]  # the rows by name
    R, ex, ez = handed.R_BP, handed.x_axis, handed.z_axis
    s = scalars_out.view(SCALARS)[0]
    for i in range(3):
        for j in range(3):
            R_BP[i, j] = R[3 * i + j]
            R_IB[i, j] = (
                held[i, 0] * target[3 * j] + held[i, 1] * target[3 * j + 1]
                + held[i, 2] * target[3 * j + 2]
            )  # fmt: skip
    # legs and manipulability
    platform = c.platform_hinges
    leg_vectors_lane(R_BP, x, c.base_hinges, platform, vectors, legs_out)
    s.manipulability = manipulability_lane(R_BP, vectors, legs_out, platform, J)
    # inertial directions of the tip's axes: ᴵR_B ᴮR_E e_x (up) and d3 ᴵR_B ᴮR_E e_z (gangway)
    for i in range(3):
        up[i] = R_IB[i, 0] * ex[0] + R_IB[i, 1] * ex[1] + R_IB[i, 2] * ex[2]
        g[i] = x[8] * (R_IB[i, 0] * ez[0] + R_IB[i, 1] * ez[1] + R_IB[i, 2] * ez[2])
    gl0 = landing[0, 0] * g[0] + landing[0, 1] * g[1] + landing[0, 2] * g[2]
    gl1 = landing[1, 0] * g[0] + landing[1, 1] * g[1] + landing[1, 2] * g[2]
    gl2 = landing[2, 0] * g[0] + landing[2, 1] * g[1] + landing[2, 2] * g[2]
    s.phi_e = math.atan2(gl1, gl0) - phi0
    s.theta_e = math.atan2(gl2, gl0) - theta0
    u0, u1, u2 = held[0, 0], held[1, 0], held[2, 0]
    c0 = up[1] * u2 - up[2] * u1
    c1 = up[2] * u0 - up[0] * u2
    c2 = up[0] * u1 - up[1] * u0
    dot = up[0] * u0 + up[1] * u1 + up[2] * u2
    s.alpha_top = math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), dot)
    s.alpha_bottom = tilt_lane(R_IB[0, 2], R_IB[1, 2], R_IB[2, 2])


@register_borrowing
def sample_tip(
    target: np.ndarray, x: np.ndarray, c: np.record, error_out: np.ndarray, work: RecordWork
) -> None:
    """One sample's tip from its state alone, where no differential step handed it over:
    ᴮR_P (`rpy_to_matrix_lane`), the tip and its error against ᴮT_d as the tip task computes
    them (`tip_error_lane`), put as the runner hands a step's over (`hand_over`) into work's
    tip row; target, x, c as in `record_from_tip`, error_out (6,) [m, rad] in B written.
    """
    rotations, frames, tip = work[0], work[1], work[6]
    R_BP = rotations[1]
    rpy_to_matrix_lane(x[3], x[4], x[5], R_BP)
    tip_error_lane(x, R_BP, target, c.d1, c.a1, frames, work[2], error_out)
    hand_over(R_BP, frames[1], error_out, tip, error_out)


@register_inline
def record_sample(
    targets: np.ndarray,
    xs: np.ndarray,
    k: int,
    handed: int,
    tips: np.ndarray,
    held: np.ndarray,
    landing: np.ndarray,
    angles0: tuple[float, float],
    c: np.record,
    legs_out: np.ndarray,
    error_out: np.ndarray,
    scalars_out: np.ndarray,
    work: RecordWork,
) -> None:
    """Sample k's record (module docstring) of a lane's targets (S, 18) and states xs (S, 9):
    from the tip the kernel handed over (tips[k], `hand_over`) when k < handed, its error
    already in error_out, else from its state alone (`sample_tip`, error_out written);
    angles0: the gangway's (φ, θ) at t = 0 (`gangway_angles`); held, landing, c, work as in
    `record_from_tip`; legs_out (6,), error_out (6,), scalars_out (N_SCALARS,)."""
    if k < handed:
        tip = tips[k]
    else:
        sample_tip(targets[k], xs[k], c, error_out, work)
        tip = work[6]
    # one call site: record_from_tip is inlined (`register_inline`)
    record_from_tip(targets[k], xs[k], tip, held, landing, angles0[0], angles0[1], c, legs_out,
                    scalars_out, work)  # fmt: skip


#: A lane's running metrics as `hybrid_record_lane` adds its samples to them: its accumulator
#: row acc (N_ACC,) (`twin.sim.kernels.metrics`), or (0,) to keep the records instead; the
#: samples' times t [s] from `first` on; whether its `joint_limits` is "hold"; how many samples
#: from `first` on it adds (those up to its end)
LaneReduction = tuple[np.ndarray, np.ndarray, bool, int]


@register_borrowing
def finite_record(x: np.ndarray, legs: np.ndarray, error: np.ndarray, scalars: np.ndarray) -> bool:
    """Whether a sample's state x (9,) and its record (legs (6,), tip error (6,), scalars
    (N_SCALARS,)) are all finite: a reduced sample that is not stops its lane, whose chunk is
    then recorded and held as a kept series is (`twin.sim.faults.hold_nonfinite`)."""
    for j in range(9):
        if not math.isfinite(x[j]):
            return False
    for j in range(6):
        if not (math.isfinite(legs[j]) and math.isfinite(error[j])):
            return False
    for j in range(N_SCALARS):
        if not math.isfinite(scalars[j]):
            return False
    return True


@register_borrowing
def hybrid_record_lane(
    targets: np.ndarray,
    xs: np.ndarray,
    first: int,
    handed: int,
    held: np.ndarray,
    landing: np.ndarray,
    g0: np.ndarray,
    const: np.ndarray,
    out: tuple[np.ndarray, np.ndarray, np.ndarray],
    tips: np.ndarray,
    work: RecordWork,
    reduction: LaneReduction,
) -> bool:
    """One lane's records, sample by sample (`record_sample`), kept or reduced: each in its
    own row of the output arrays, or each added to the lane's running metrics as it is
    recorded (`hybrid_add_sample`, when acc has a row: keep="metrics") in one row the next
    sample overwrites, so a run that keeps no series never holds its chunk's records. One
    function for both, so the inlined record is compiled once. The loop is here, not in the
    runner, because a borrowing function takes its per-sample views without reference
    counting (two atomic operations per view and sample in the runner).

    Args:
        targets: (S, 18) each sample's target row; xs: (S, 9) xi per sample [m, rad].
        first: the first sample recorded: samples first … S − 1 are.
        handed: samples before it have their tip in `tips` and their error in the errors
            (`hand_over`, by the kernel); the others' are computed here (`sample_tip`).
        landing: (3, 3) inertial → landing frame; g0: (3,) the gangway vector at t = 0 in it.
        const: (N_HYBRID_CONSTANTS,) the hybrid constants, read by name (`HYBRID_CONSTANTS`).
        held, work: as in `record_from_tip`.
        out: legs (S, 6) [m], tip errors (S, 6) [m, rad], scalars (S, N_SCALARS): rows
            first … S − 1 written (errors: those at or after `handed`); reducing, legs and
            scalars (1, …): each sample's record in turn, sample S − 1's at the end.
        tips: (S, N_TIP), or (0, N_TIP) when handed ≤ first.
        reduction: the lane's running metrics (`LaneReduction`), acc updated.

    Returns:
        Whether every sample's state and record were finite, reducing (True keeping): the
        lane stops at the first that is not, its acc left part-way (the caller restores it).
    """
    legs_out, errors_out, scalars_out = out
    acc, t, hold, count = reduction
    reduce = acc.shape[0] > 0
    accumulator = acc.view(HYBRID_ACCUMULATOR)  # (1,) the row by name, reducing; else (0,)
    angles0 = gangway_angles(g0)  # once per lane
    c = const.view(HYBRID_CONSTANTS)[0]  # the constants by name
    limits: HybridLimits = (hold, c.lower, c.upper, c.leg_min, c.leg_max)
    for k in range(first, xs.shape[0]):
        row = 0 if reduce else k
        legs, error, scalars = legs_out[row], errors_out[k], scalars_out[row]
        record_sample(targets, xs, k, handed, tips, held, landing, angles0, c, legs, error,
                      scalars, work)  # fmt: skip
        if reduce:
            if not finite_record(xs[k], legs, error, scalars):
                return False
            if k - first < count:
                s = scalars.view(SCALARS)[0]
                hybrid_add_sample(accumulator[0], t[k - first], xs[k], legs, error,
                                  (s.manipulability, s.phi_e, s.theta_e, s.alpha_top,
                                   s.alpha_bottom), limits)  # fmt: skip
    return True


@register_jitable
def require_target_rows(targets: np.ndarray, xs: np.ndarray) -> None:
    """Refuse targets (N, T, 18) with fewer rows than the states xs (N, S, 9) have samples (a
    chunk's targets without its end row), which the compiled loop would read past.

    Raises:
        ValueError: T < S.
    """
    if targets.shape[1] < xs.shape[1]:
        raise ValueError("run_hybrid_records: targets needs a row per sample, the end's too")


def run_hybrid_records(
    targets: np.ndarray,
    xs: np.ndarray,
    first: int,
    handed: np.ndarray,
    held: np.ndarray,
    landing: np.ndarray,
    gangway0: np.ndarray,
    const: np.ndarray,
    legs: np.ndarray,
    errors: np.ndarray,
    scalars: np.ndarray,
    tips: np.ndarray,
    acc: np.ndarray,
    t: np.ndarray,
    hold: np.ndarray,
    counts: np.ndarray,
    finite: np.ndarray,
) -> None:
    """Records of N lanes × samples first … S − 1 of S (a chunk's states as the kernel wrote
    them, its start in row 0, need no copy without it), kept or reduced as they are made
    (`hybrid_record_lane`).

    Args:
        targets: (N, S, 18) each sample's target row (`held_targets`; ᴮR_d and ᴮp_d read);
        xs: (N, S, 9) states; first: the first sample recorded.
        handed: (N,) int64: lane n's samples before handed[n] have their tip and error from
            the kernel (`tips`, `errors`; `hybrid_record_lane`); 0 for none.
        held: (N, 4, 4); landing: (N, 3, 3); gangway0: (N, 3); const: hybrid constants.
        legs: (N, S, 6), errors: (N, S, 6), scalars: (N, S, N_SCALARS): rows first … S − 1
            written (errors: those at or after handed[n]); reducing, legs and scalars
            (N, 1, …), sample S − 1's record at the end.
        tips: (N, S, N_TIP) the handed tips (any rows when no lane has one).
        acc: (N, N_ACC) the lanes' running metrics (`twin.sim.kernels.metrics`), each sample
            added as it is recorded; (N, 0) to keep the records (`keep_records`).
        t: (S − first,) the samples' times [s]; hold: (N,) bool, each lane's joint_limits is
            "hold"; counts: (N,) int64, lane n adds its first counts[n] samples (0 past its
            end); finite: (N,) bool, written: lane n's samples and records all finite.

    Raises:
        ValueError: fewer target rows than samples (a chunk's targets without its end row),
            which the compiled loop would read past.
    """
    require_target_rows(targets, xs)
    for n in prange(xs.shape[0]):
        finite[n] = hybrid_record_lane(targets[n], xs[n], first, handed[n], held[n], landing[n],
                                       gangway0[n], const, (legs[n], errors[n], scalars[n]),
                                       tips[n], record_work(),
                                       (acc[n], t, hold[n], counts[n]))  # fmt: skip


def run_hybrid_records_lanes(
    targets: np.ndarray,
    xs: np.ndarray,
    first: int,
    handed: np.ndarray,
    held: np.ndarray,
    landing: np.ndarray,
    gangway0: np.ndarray,
    const: np.ndarray,
    legs: np.ndarray,
    errors: np.ndarray,
    scalars: np.ndarray,
    tips: np.ndarray,
    acc: np.ndarray,
    t: np.ndarray,
    hold: np.ndarray,
    counts: np.ndarray,
    finite: np.ndarray,
) -> None:
    """`run_hybrid_records` with its lanes in parallel, each a one-lane call of the compiled
    serial runner `serial_records`, so the inlined
    record is compiled once (`twin.sim.kernels.hybrid_runner.run_hybrid_lanes`). Arguments
    and errors as `run_hybrid_records`' (refused before the parallel loop: an exception
    raised inside it reaches Python as a SystemError)."""
    require_target_rows(targets, xs)
    for n in prange(xs.shape[0]):
        lane = slice(n, n + 1)
        serial_records(targets[lane], xs[lane], first, handed[lane], held[lane], landing[lane],
                       gangway0[lane], const, legs[lane], errors[lane], scalars[lane],
                       tips[lane], acc[lane], t, hold[lane], counts[lane],
                       finite[lane])  # fmt: skip


#: `run_hybrid_records` compiled serial (lazily, on its first call; `twin.compiled`), or the
#: plain function without numba: what `run_hybrid_records_lanes` calls per lane
serial_records = compile_runner(run_hybrid_records, parallel=False)


@cache
def compiled_records(parallel: bool) -> Callable:
    """`run_hybrid_records` compiled (`twin.compiled.compile_runner`), lanes in parallel
    (`run_hybrid_records_lanes`) or serial (`serial_records`); plain Python without numba."""
    if not parallel or serial_records is run_hybrid_records:
        return serial_records
    return compile_runner(run_hybrid_records_lanes, parallel=True)


def keep_records(N: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """`run_hybrid_records`' last arguments (acc, t, hold, counts, finite) for N lanes that
    keep their records and reduce none: acc (N, 0), of the types a reduction passes, so the
    runner has one compiled signature for both."""
    return (np.empty((N, 0)), np.empty(0), np.zeros(N, dtype=bool),
            np.zeros(N, dtype=np.int64), np.ones(N, dtype=bool))  # fmt: skip

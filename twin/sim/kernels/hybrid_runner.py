"""The hybrid system's chunk runners: N lanes × B steps of plan, guard and integrate.

Per lane and step, with ᴮR_P computed once for all of them:

1. the planner of the lane's `kind` (its prm row's, `COMMON_PARAMETERS`) gives the velocity
   v, its step in the planners' layer (differential:
   `twin.planners.differential_step.differential_velocity`, finished by
   `damped_differential_velocity` where it returns NEEDS_SVD; allocation:
   `twin.planners.allocation_step.allocation_velocity`; qp:
   `twin.planners.qp_step.qp_velocity`, its QP solved in the lane);
2. the guard of the former `HybridRig.advance` (`twin.sim.kernels.hybrid.guarded_step`): a
   non-finite v holds the mechanism (FAULT_PLANNER, the diagnostics' `limit_scale` = 0);
   otherwise a lane whose row's `hold` > 0 shortens the step to s = `limit_scale_lane`
   (FAULT_JOINT_LIMIT when s < 1), `limit_scale` = s, and xi integrates s·v for dt
   (`integrate_hybrid`).

Two runners share that guard: `run_hybrid` steps the differential and allocation lanes,
`run_hybrid_qp` the qp lanes; each leaves the other's lanes alone, and `run_hybrid_families`
calls the ones a chunk's lanes need. They are two because compile time grows faster than the
code compiled: the qp solver inside the one runner made its first compile 104 s instead of
54 s (one core each), where two runners compile side by side in `twin.sim.engine.warm`'s
processes (docs/performance.md).

What is recorded at the samples is computed after the chunk, in a pass of its own
(`twin.sim.kernels.records`): recording inside this loop was measured slower than the two
passes (docs/simulation.md). A differential planner's step hands the record what it has
computed for its start anyway — ᴮR_P, the tip's axes and its pose error (`hand_over`) — so
the record does not compute them again.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np

from twin.compiled import compile_runner, prange, register_borrowing
from twin.planners.allocation_step import allocation_velocity, allocation_work
from twin.planners.differential_step import (
    NEEDS_SVD,
    damped_differential_velocity,
    differential_velocity,
    differential_work,
)
from twin.planners.families import ALLOCATION_PARAMETERS, DIFFERENTIAL_PARAMETERS
from twin.planners.parameters import as_records
from twin.planners.qp_step import qp_lane_work, qp_velocity
from twin.sim.kernels.hybrid import guarded_step, limit_work
from twin.sim.kernels.layout import (
    COMMON_PARAMETERS,
    FAULT_PLANNER,
    KIND_ALLOCATION,
    KIND_DIFFERENTIAL,
    KIND_QP,
)
from twin.sim.kernels.records import hand_over
from twin.spatial import rpy_to_matrix_lane


@register_borrowing
def hybrid_lane(
    xs: np.ndarray,
    targets: np.ndarray,
    row: np.ndarray,
    memory: np.ndarray,
    const: np.ndarray,
    dt: float,
    diag: np.ndarray,
    faults: np.ndarray,
    first: int,
    errors: np.ndarray,
    tips: np.ndarray,
    start: int,
    resumed: int,
    R: np.ndarray,
    v: np.ndarray,
    differential: tuple,
    allocation: tuple,
    limit: tuple,
) -> int:
    """Steps start, start + 1, … of one lane (`run_hybrid`'s arrays without the lane axis):
    the step loop is here, not in the runner, because a borrowing function takes its per-step
    views without reference counting (measured: 8 % of a step).

    Args:
        xs … tips: as in `run_hybrid`, the lane's; row: its `prm` row; memory: its planner
            state (allocation, read and written).
        start: the first step to take; resumed: −1, or the fault bits of step start's
            planner, whose velocity the runner has put in v (and ᴮR_P in R) already.
        R: (3, 3), v: (9,): scratch (ᴮR_P and the velocity of the step last taken);
            differential, allocation, limit: the planners' and the guard's work.

    Returns:
        B when the chunk is done; else the step k whose differential solve needs the SVD
        (`differential_velocity` returned NEEDS_SVD, rare). That branch allocates, so a
        borrowing function cannot call it: the runner takes it
        (`damped_differential_velocity`) and calls again from k, resumed.
    """
    common = row.view(COMMON_PARAMETERS)[0]  # the fields every family's row starts with
    kind, hold = common.kind, common.hold > 0.0
    # the row by name, as the lane's family reads it (one of the two is used)
    differential_row = row.view(DIFFERENTIAL_PARAMETERS)[0]
    allocation_row = row.view(ALLOCATION_PARAMETERS)[0]
    for k in range(start, xs.shape[0] - 1):
        x, x_next, d = xs[k], xs[k + 1], diag[k + 1]
        if k == start and resumed >= 0:  # the runner has taken this step's SVD branch
            bits = resumed
        else:
            rpy_to_matrix_lane(x[3], x[4], x[5], R)  # ᴮR_P: the planner's, guard's, step's
            if kind == KIND_DIFFERENTIAL:
                bits = differential_velocity(x, R, targets[k], differential_row, const, dt,
                                             differential, v, d)  # fmt: skip
                if bits == NEEDS_SVD:
                    return k
            elif kind == KIND_ALLOCATION:
                bits = allocation_velocity(x, R, targets[k], allocation_row, memory, const, dt,
                                           allocation, v, d)  # fmt: skip
            else:  # not a planner of this runner: held, as a planner fault
                for j in range(9):
                    v[j] = math.nan
                bits = FAULT_PLANNER
        if kind == KIND_DIFFERENTIAL and k >= first:  # what the record would compute again
            hand_over(R, differential[3][1], differential[5][0].error, tips[k], errors[k])
        faults[k] = guarded_step(x, R, v, bits, hold, const, dt, limit, d, x_next)
    return xs.shape[0] - 1


def run_hybrid(
    xs: np.ndarray,
    targets: np.ndarray,
    prm: np.ndarray,
    memory: np.ndarray,
    const: np.ndarray,
    dt: float,
    diag: np.ndarray,
    faults: np.ndarray,
    first: int,
    errors: np.ndarray,
    tips: np.ndarray,
) -> None:
    """Step the differential and allocation lanes of N hybrid lanes through a chunk of B steps
    (module doc), lane by lane (`hybrid_lane`); qp lanes are `run_hybrid_qp`'s, left alone.

    Args:
        xs: (N, B + 1, 9) xi [m, rad]; row 0 the chunk's start, rows 1 … B written.
        targets: (N, B, N_TARGET) the held target in B at each step (layout `TARGET`); a row
            B, the chunk's end (`held_targets` with `end=True`), is not read.
        prm: (N, N_PARAMETERS) each lane's planner row.
        memory: (N, N_MEMORY) each lane's planner state, read and written (allocation).
        const: (N_HYBRID_CONSTANTS,) the hybrid constants (`HybridBoardingSystem.pack`).
        dt: [s] control period.
        diag: (N, B + 1, N_HYBRID_DIAGNOSTICS): rows 1 … B written (step k's in row k + 1).
        faults: (N, B) int64 written: the step's fault bits (`twin.sim.faults.Fault`).
        first: the first sample the chunk records (0 or 1).
        errors: (N, B + 1, 6), tips: (N, B + 1, N_TIP): a differential planner's lane hands
            over the tip and its pose error of samples first … B − 1, which its steps computed
            (`twin.sim.kernels.records.hand_over`), in rows first … B − 1; other lanes' rows
            are left alone.
    """
    n_steps = xs.shape[1] - 1
    for n in prange(xs.shape[0]):
        # scratch allocated once per lane (numba puts every array on the heap)
        R, v = np.empty((3, 3)), np.empty(9)
        if prm[n].view(COMMON_PARAMETERS)[0].kind == KIND_QP:
            continue
        differential, allocation, limit = differential_work(), allocation_work(), limit_work()
        k, bits = 0, -1
        while k < n_steps:
            k = hybrid_lane(xs[n], targets[n], prm[n], memory[n], const, dt, diag[n],
                            faults[n], first, errors[n], tips[n], k, bits, R, v, differential,
                            allocation, limit)  # fmt: skip
            if k < n_steps:  # step k needs the SVD (near a singularity), which allocates
                row = prm[n].view(DIFFERENTIAL_PARAMETERS)[0]
                bits = damped_differential_velocity(xs[n, k], row, differential, v,
                                                    diag[n, k + 1])  # fmt: skip


def run_hybrid_lanes(
    xs: np.ndarray,
    targets: np.ndarray,
    prm: np.ndarray,
    memory: np.ndarray,
    const: np.ndarray,
    dt: float,
    diag: np.ndarray,
    faults: np.ndarray,
    first: int,
    errors: np.ndarray,
    tips: np.ndarray,
) -> None:
    """`run_hybrid` with its lanes in parallel (numba's prange), each lane a one-lane call of
    the compiled serial runner `serial_hybrid`: numba compiles a function called inside a
    parallel loop again, and the step, inlined into `hybrid_lane`, is the costliest code to
    compile. Arguments as `run_hybrid`'s."""
    for n in prange(xs.shape[0]):
        lane = slice(n, n + 1)
        serial_hybrid(xs[lane], targets[lane], prm[lane], memory[lane], const, dt, diag[lane],
                      faults[lane], first, errors[lane], tips[lane])  # fmt: skip


#: `run_hybrid` compiled serial (lazily, on its first call; `twin.compiled`), or the plain
#: function without numba: what `run_hybrid_lanes` calls per lane
serial_hybrid = compile_runner(run_hybrid, parallel=False)


@cache
def compiled_hybrid(parallel: bool) -> Callable:
    """`run_hybrid` compiled by numba, parallel over lanes (`run_hybrid_lanes`) or serial
    (`serial_hybrid`: one thread, e.g. one per Dask worker), cached on disk
    (`twin.compiled.compile_runner`); the plain `run_hybrid` without numba."""
    if not parallel or serial_hybrid is run_hybrid:
        return serial_hybrid
    return compile_runner(run_hybrid_lanes, parallel=True)


@register_borrowing
def qp_lane(
    xs: np.ndarray,
    targets: np.ndarray,
    row: np.ndarray,
    const: np.ndarray,
    dt: float,
    diag: np.ndarray,
    faults: np.ndarray,
    R: np.ndarray,
    v: np.ndarray,
    limit: tuple,
    qp: tuple,
) -> None:
    """Every step of one qp lane (`run_hybrid_qp`'s arrays without the lane axis, `row` its
    `prm` row): its QP solved in the lane (`qp_velocity`), then `guarded_step`. R (3, 3) and
    v (9,) scratch; limit, qp: the guard's and the planner's work."""
    hold = row.view(COMMON_PARAMETERS)[0].hold > 0.0
    for k in range(xs.shape[0] - 1):
        x, x_next, d = xs[k], xs[k + 1], diag[k + 1]
        rpy_to_matrix_lane(x[3], x[4], x[5], R)
        bits = qp_velocity(x, targets[k], row, const, dt, qp, v, d)
        faults[k] = guarded_step(x, R, v, bits, hold, const, dt, limit, d, x_next)


def run_hybrid_qp(
    xs: np.ndarray,
    targets: np.ndarray,
    prm: np.ndarray,
    memory: np.ndarray,
    const: np.ndarray,
    dt: float,
    diag: np.ndarray,
    faults: np.ndarray,
    first: int,
    errors: np.ndarray,
    tips: np.ndarray,
) -> None:
    """Step the qp lanes of N hybrid lanes through a chunk (`qp_lane`); the others are
    `run_hybrid`'s, left alone. Arguments as `run_hybrid`'s (a qp lane keeps no memory and
    hands nothing to the records: `memory`, `first`, `errors` and `tips` are not read)."""
    for n in prange(xs.shape[0]):
        if prm[n].view(COMMON_PARAMETERS)[0].kind != KIND_QP:
            continue
        R, v = np.empty((3, 3)), np.empty(9)  # scratch allocated once per lane
        qp_lane(xs[n], targets[n], prm[n], const, dt, diag[n], faults[n], R, v, limit_work(),
                qp_lane_work())  # fmt: skip


def run_hybrid_qp_lanes(
    xs: np.ndarray,
    targets: np.ndarray,
    prm: np.ndarray,
    memory: np.ndarray,
    const: np.ndarray,
    dt: float,
    diag: np.ndarray,
    faults: np.ndarray,
    first: int,
    errors: np.ndarray,
    tips: np.ndarray,
) -> None:
    """`run_hybrid_qp` with its lanes in parallel, each a one-lane call of `serial_hybrid_qp`
    (as `run_hybrid_lanes`)."""
    for n in prange(xs.shape[0]):
        lane = slice(n, n + 1)
        serial_hybrid_qp(xs[lane], targets[lane], prm[lane], memory[lane], const, dt,
                         diag[lane], faults[lane], first, errors[lane], tips[lane])  # fmt: skip


#: `run_hybrid_qp` compiled serial (lazily), or the plain function without numba
serial_hybrid_qp = compile_runner(run_hybrid_qp, parallel=False)


@cache
def compiled_hybrid_qp(parallel: bool) -> Callable:
    """`run_hybrid_qp` compiled, parallel over lanes or serial (as `compiled_hybrid`)."""
    if not parallel or serial_hybrid_qp is run_hybrid_qp:
        return serial_hybrid_qp
    return compile_runner(run_hybrid_qp_lanes, parallel=True)


class HybridRunners:
    """The chunk runners a hybrid group needs, called as one runner (`run_hybrid`'s
    arguments): `run_hybrid` where a lane is differential or allocation, `run_hybrid_qp` where
    one is qp, each compiled on its first call.

    Attributes:
        main, qp: the two runners (compiled or plain).
    """

    def __init__(self, main: Callable, qp: Callable) -> None:
        self.main, self.qp = main, qp

    def __call__(self, *arguments: Any) -> None:
        """One chunk: `run_hybrid`'s arguments (xs, targets, prm, …), prm the third."""
        prm = arguments[2]
        is_qp = as_records(prm, COMMON_PARAMETERS)["kind"] == KIND_QP
        if not is_qp.all():
            self.main(*arguments)
        if is_qp.any():
            self.qp(*arguments)


r"""The small platforms' runner (Upu3Up, Upr4): stepping, scratch and faults, no math of its own.

`run_platform` steps N lanes (one scenario each) through a chunk of B samples. Each step is
what the former `PlatformRig.advance` did:

1. plan: `twin.planners.platform_step.plan_lane`, the `PlatformPlanner` law ("pid" or "ik"), its
   speed limit and anti-windup; a non-finite target holds the platform (FAULT_PLANNER), as
   the planner's NaN rates did;
2. guard: a non-finite rate holds the platform (FAULT_PLANNER); the new lengths stop at the
   stroke (FAULT_JOINT_LIMIT where they were cut);
3. forward kinematics warm-started at the previous state
   (`twin.mechanisms.platforms.platform_fit`, `PlatformModel.fit`); a failure there holds the
   platform (FAULT_KINEMATICS).

The lane functions live in their layers (`twin.mechanisms.platforms`, `twin.planners.platform`)
and read the lane's parameters, memory and geometry as records by name (`PLATFORM_PARAMETERS`,
`PLATFORM_MEMORY`, `PLATFORM_GEOMETRY`); the engine hands the parameters and memory as float
rows (`twin.sim.kernels.layout`), which `run_platform` views as those records.

Units: states (z, α, β) or (z, roll, pitch) and lengths are in the mechanism's native unit
(mm for the Upu3Up, m for the Upr4), angles in rad, actuator rates in native/s; targets are in
metres and the base frame B (`twin.sim.kernels.layout`).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

import numpy as np

from twin.compiled import compile_runner, prange, register_jitable
from twin.mechanisms.platforms import NewtonWork, platform_fit
from twin.planners.parameters import record_dtype, row_size
from twin.planners.platform import PlatformPlanner
from twin.planners.platform_model import PlatformModel
from twin.planners.platform_step import (
    MEMORY_SIZE,
    PLATFORM_MEMORY,
    PLATFORM_PARAMETERS,
    plan_lane,
)
from twin.sim.kernels.layout import (
    FAULT_JOINT_LIMIT,
    FAULT_KINEMATICS,
    FAULT_PLANNER,
    N_MEMORY,
    TARGET,
)

#: A step's diagnostics (a row of diag (N, B + 1, N_PLATFORM_DIAGNOSTICS), read by name):
#: 1.0 where the desired state or a desired length was clipped to a limit, 1.0 where the speed
#: limit bound (`PlatformPlanner.step`).
PLATFORM_DIAGNOSTICS = record_dtype((("clipped", 1), ("saturated", 1)),
                                    what="PLATFORM_DIAGNOSTICS")  # fmt: skip
N_PLATFORM_DIAGNOSTICS = row_size(PLATFORM_DIAGNOSTICS)


def platform_constants(model: PlatformModel) -> np.ndarray:
    """The mechanism's (1,) `PLATFORM_GEOMETRY` array (`PlatformModel.pack`)."""
    return model.pack()


def pack_platform(planner: PlatformPlanner, hold: bool) -> tuple[np.ndarray, np.ndarray]:
    """(prm row, memory row (N_MEMORY,)) of a planner after its `reset`: its `pack(hold)` and
    `pack_memory`."""
    memory = np.zeros(N_MEMORY)
    planner.pack_memory(memory)
    return planner.pack(hold), memory


@register_jitable
def step(
    x: np.ndarray,
    legs: np.ndarray,
    target: np.ndarray,
    p: np.void,
    m: np.void,
    g: np.void,
    dt: float,
    x_out: np.ndarray,
    legs_out: np.ndarray,
    diag_out: np.ndarray,
    work: np.ndarray,
    R: np.ndarray,
    J: np.ndarray,
    M: np.ndarray,
) -> int:
    """One `PlatformRig.advance`: plan, guard, move the actuators one dt, fit the state.

    Args:
        x: (3,) state at sample k [native, rad, rad]; legs: (4,) its actuator lengths
            [native] (the first n used).
        target: (N_TARGET,) the held target in B at sample k (a `TARGET` row).
        p, m, g: the lane's `PLATFORM_PARAMETERS`, `PLATFORM_MEMORY` (updated) and
            `PLATFORM_GEOMETRY` records.
        dt: [s] control period.
        x_out, legs_out: (3,), (4,) written: sample k + 1 (sample k's on a hold).
        diag_out: (N_PLATFORM_DIAGNOSTICS,) written (`PLATFORM_DIAGNOSTICS`).
        work: (8, 18) scratch; R (3, 3), J (4, 3), M (3, 4) scratch.

    Returns:
        The step's fault bits (FAULT_PLANNER, FAULT_KINEMATICS, FAULT_JOINT_LIMIT).
    """
    n = g["n_legs"]
    for j in range(4):
        legs_out[j] = legs[j]
    for j in range(3):
        x_out[j] = x[j]
    d = diag_out.view(PLATFORM_DIAGNOSTICS)[0]  # the rows by name
    d.clipped = 0.0
    d.saturated = 0.0
    for j in range(18):
        if not np.isfinite(target[j]):
            return FAULT_PLANNER  # NaN rates: the rig holds, memory untouched
    velocity, l_next, scratch = work[6], work[4], work[7]
    t = target.view(TARGET)[0]
    clipped, saturated = plan_lane(t.R_d, t.p_d, t.twist, legs, p, m, g, dt, velocity, work, R,
                                   J, M)  # fmt: skip
    d.clipped = 1.0 if clipped else 0.0
    d.saturated = 1.0 if saturated else 0.0

    # PlatformRig.advance: guard, end stops, forward kinematics
    for i in range(n):
        if not np.isfinite(velocity[i]):
            return FAULT_PLANNER
    fault = 0
    low, high = g["stroke_low"], g["stroke_high"]
    for i in range(n):
        moved = legs[i] + velocity[i] * dt
        lengths = min(max(moved, low), high)  # the actuators' end stops
        if lengths != moved:
            fault = FAULT_JOINT_LIMIT
        l_next[i] = lengths
    fit_x, residual, rates = scratch[0:3], scratch[4:8], scratch[8:11]
    if not platform_fit(l_next, x, g, fit_x, NewtonWork(R, work[1], residual, J, M, rates)):
        return fault | FAULT_KINEMATICS
    for j in range(3):
        if not np.isfinite(fit_x[j]):
            return fault | FAULT_KINEMATICS
    for j in range(3):
        x_out[j] = fit_x[j]
    for i in range(n):
        legs_out[i] = l_next[i]
    return fault


def step_lanes(
    xs: np.ndarray,
    legs: np.ndarray,
    targets: np.ndarray,
    prm: np.ndarray,
    memory: np.ndarray,
    geometry: np.ndarray,
    dt: float,
    diag: np.ndarray,
    faults: np.ndarray,
) -> None:
    """`run_platform` on records: prm (N,) `PLATFORM_PARAMETERS`, memory (N,)
    `PLATFORM_MEMORY`, geometry (1,) `PLATFORM_GEOMETRY`; one lane per thread (numba's
    prange)."""
    for n in prange(xs.shape[0]):
        work = np.zeros((8, 18))
        R, J, M = np.zeros((3, 3)), np.zeros((4, 3)), np.zeros((3, 4))
        for k in range(xs.shape[1] - 1):
            faults[n, k] = step(
                xs[n, k], legs[n, k], targets[n, k], prm[n], memory[n], geometry[0], dt,
                xs[n, k + 1], legs[n, k + 1], diag[n, k + 1], work, R, J, M,
            )  # fmt: skip


def records(prm: np.ndarray, memory: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The engine's float rows prm (N, ≥ ROW_SIZE) and memory (N, ≥ MEMORY_SIZE) as (N,)
    arrays of `PLATFORM_PARAMETERS` and `PLATFORM_MEMORY` records, views (writes go to the
    rows)."""
    return prm.view(PLATFORM_PARAMETERS)[:, 0], memory[:, :MEMORY_SIZE].view(PLATFORM_MEMORY)[:, 0]


def run_platform(
    xs: np.ndarray,
    legs: np.ndarray,
    targets: np.ndarray,
    prm: np.ndarray,
    memory: np.ndarray,
    const: np.ndarray,
    dt: float,
    diag: np.ndarray,
    faults: np.ndarray,
    stepper: Callable = step_lanes,
) -> None:
    """Step every lane through a chunk of samples (`step_lanes`, plain Python unless `stepper`
    is its compiled form).

    Args:
        xs: (N, B + 1, 3) platform states [native, rad, rad]; row 0 the chunk's start, rows
            1 … B written.
        legs: (N, B + 1, 4) actuator lengths [native], the first n_legs used; rows as xs.
        targets: (N, B, 18) the held target in B at each step (`layout.TARGET`; a row B,
            the chunk's end, is not read).
        prm: (N, ROW_SIZE) per lane (`PlatformPlanner.pack`).
        memory: (N, ≥ MEMORY_SIZE) per lane, read and written (`PLATFORM_MEMORY`).
        const: (1,) `PLATFORM_GEOMETRY` (`PlatformModel.pack`).
        dt: [s] control period.
        diag: (N, B + 1, N_PLATFORM_DIAGNOSTICS): rows 1 … B written (`PLATFORM_DIAGNOSTICS`;
            step k's in row k + 1).
        faults: (N, B) int64 written: fault bits of each step (`layout.FAULT_*`).
        stepper: `step_lanes` or its compiled form.
    """
    stepper(xs, legs, targets, *records(prm, memory), const, dt, diag, faults)


@cache
def compiled_platform(parallel: bool) -> Callable:
    """`run_platform` on `step_lanes` compiled by numba, parallel over lanes or serial, cached
    on disk (`compile_runner`); the plain `run_platform` without numba."""
    stepper = compile_runner(step_lanes, parallel)

    def run(
        xs: np.ndarray,
        legs: np.ndarray,
        targets: np.ndarray,
        prm: np.ndarray,
        memory: np.ndarray,
        const: np.ndarray,
        dt: float,
        diag: np.ndarray,
        faults: np.ndarray,
    ) -> None:
        run_platform(xs, legs, targets, prm, memory, const, dt, diag, faults, stepper)

    return run

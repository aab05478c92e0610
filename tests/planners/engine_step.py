"""One planner step on the engine's path: the lane functions `run_hybrid` composes.

`engine_step(planner, xi, target)` packs the planner into its lane row (`pack`), puts the
target into the kernel's row and takes one step of the hybrid kernel's planner stage
(`differential_velocity`, finished by `damped_differential_velocity` where it needs the SVD;
`allocation_velocity`), returning it as the object's `step` would (`PlannerOutput`), so a
test of a planner's property runs on the code the engine runs. The functions run
interpreted here (numba compiles the same ones into the runner; tests/sim/kernels hold the
compiled runner to them).
"""

from __future__ import annotations

import numpy as np

from tests.sim.oracle import pack_target
from twin.mechanisms import HybridBoardingSystem
from twin.planners import HYBRID_RATE_LIMITS, AllocationPlanner, PlannerOutput, TipTarget
from twin.planners.allocation import ALLOCATION_PARAMETERS
from twin.planners.allocation_step import allocation_velocity, allocation_work, pack_allocation
from twin.planners.differential import DIFFERENTIAL_PARAMETERS
from twin.planners.differential_step import (
    NEEDS_SVD,
    W_ERROR,
    damped_differential_velocity,
    differential_velocity,
    differential_work,
    pack_differential,
)
from twin.sim.kernels import layout
from twin.spatial import rpy_to_matrix_lane

#: the two paths a planner test runs on: the object's numpy `step`, the engine's lane step
PATHS = ("object", "engine")


def engine_step(
    planner: object, xi: np.ndarray, target: TipTarget, dt: float = 0.05
) -> PlannerOutput:
    """The engine's step of `planner` (reset already, for an allocation planner) at xi (9,)
    towards `target`: velocity (9,) and the diagnostics the kernel writes, named as the
    object's (`weights`, `null_space_share`, `damping`, `velocity_scale`, `task_error` for a
    differential planner; `position_share` for an allocation planner)."""
    mechanism = getattr(planner, "mechanism", None) or planner.tip.mechanism
    assert isinstance(mechanism, HybridBoardingSystem)
    const = mechanism.pack(HYBRID_RATE_LIMITS)
    x, row = np.array(xi, dtype=float), pack_target(target)
    R, v = np.empty((3, 3)), np.empty(9)
    rpy_to_matrix_lane(x[3], x[4], x[5], R)
    diag = np.zeros(layout.N_HYBRID_DIAGNOSTICS)
    if isinstance(planner, AllocationPlanner):
        prm, memory = pack_allocation(planner, False)
        record = prm.view(ALLOCATION_PARAMETERS)[0]
        allocation_velocity(x, R, row, record, memory, const, dt, allocation_work(), v, diag)
        share = diag[layout.D_POSITION_SHARE : layout.D_POSITION_SHARE + 3].copy()
        return PlannerOutput(velocity=v, diagnostics={"position_share": share})
    record = pack_differential(planner, False).view(DIFFERENTIAL_PARAMETERS)[0]
    work = differential_work()
    if differential_velocity(x, R, row, record, const, work, v, diag) == NEEDS_SVD:
        damped_differential_velocity(x, record, work, v, diag)
    return PlannerOutput(
        velocity=v,
        diagnostics={
            "weights": diag[layout.D_WEIGHTS : layout.D_WEIGHTS + 9].copy(),
            "null_space_share": diag[layout.D_SHARE],
            "damping": diag[layout.D_DAMPING],
            "velocity_scale": diag[layout.D_SCALE],
            "task_error": work[5][W_ERROR, :6].copy(),
        },
    )


def step(path: str, planner: object, xi: np.ndarray, target: TipTarget) -> PlannerOutput:
    """`planner.step(xi, target, 0.05)` on `path`: "object" or "engine" (`engine_step`)."""
    if path == "engine":
        return engine_step(planner, xi, target)
    return planner.step(xi, target, 0.05)

"""The rows of the arrays the engine hands the compiled kernels: one contract, three kernels.

A `Simulation` holds N lanes (one scenario each) as arrays; per chunk of B steps it calls a
kernel runner with

- `xs` (N, B + 1, S): the mechanism state, row 0 the chunk's start, rows 1 … B written;
- `targets` (N, B, 18): the held target in the base frame at each step (`TARGET` rows);
- `prm` (N, N_PARAMETERS): each lane's planner knobs, packed from its planner object;
- `memory` (N, N_MEMORY): each lane's planner state carried from step to step (DWA's shares,
  a PID's integral, …), read and written by the kernel;
- `const`: the mechanism's constants;
- `diag` (N, B + 1, …): rows 1 … B written, row k + 1 by step k, beside the state it led to
  (row 0, the chunk's start, is left alone);
- `faults` (N, B) int64: written, one row per step.

Every `prm` row starts with the lane's planner family `kind` (`KIND_*`) and `hold`, whether the
lane holds its joint limits (1.0) or only records passing them (0.0), read by name whatever the
family (`COMMON_PARAMETERS`, `twin.planners.parameters.COMMON_FIELDS`); the rest belongs to the
family, read by name as a record (`twin.planners.parameters.family_dtype`:
`DIFFERENTIAL_PARAMETERS`, `ALLOCATION_PARAMETERS`, `QP_PARAMETERS`, `PLATFORM_PARAMETERS`).
The hybrid constants are the float row of `HybridBoardingSystem.pack`, read by name too
(`HYBRID_CONSTANTS`). The target row, the hybrid diagnostics rows and the planners' fault bits
are defined where the planners' steps that read and write them are
(`twin.planners.lane_rows`); this module names them for the rest of the engine.
"""

from __future__ import annotations

# The hybrid constants' size, the target, diagnostics and fault rows of the planners' steps,
# the planner families (a prm row's `kind`) and the row sizes: each defined once, where what
# reads and writes them is (`twin.mechanisms.hybrid`, `twin.planners.lane_rows`, `.parameters`)
from twin.mechanisms.hybrid import N_HYBRID_CONSTANTS as N_HYBRID_CONSTANTS
from twin.planners.lane_rows import FAULT_INFEASIBLE as FAULT_INFEASIBLE
from twin.planners.lane_rows import FAULT_PLANNER as FAULT_PLANNER
from twin.planners.lane_rows import FAULT_SINGULAR as FAULT_SINGULAR
from twin.planners.lane_rows import HYBRID_DIAGNOSTICS as HYBRID_DIAGNOSTICS
from twin.planners.lane_rows import N_HYBRID_DIAGNOSTICS as N_HYBRID_DIAGNOSTICS
from twin.planners.lane_rows import N_TARGET as N_TARGET
from twin.planners.lane_rows import TARGET as TARGET
from twin.planners.parameters import COMMON_PARAMETERS as COMMON_PARAMETERS
from twin.planners.parameters import KIND_ALLOCATION as KIND_ALLOCATION
from twin.planners.parameters import KIND_DIFFERENTIAL as KIND_DIFFERENTIAL
from twin.planners.parameters import KIND_PLATFORM as KIND_PLATFORM
from twin.planners.parameters import KIND_QP as KIND_QP
from twin.planners.parameters import MEMORY_SIZE, ROW_SIZE

N_PARAMETERS = ROW_SIZE
N_MEMORY = MEMORY_SIZE

#: Fault bits of the engine (the planners' are `twin.planners.lane_rows`'), the values of
#: `twin.sim.faults.Fault` (tested equal), as plain ints for numba.
FAULT_BASE_MOTION, FAULT_KINEMATICS, FAULT_JOINT_LIMIT = 1, 4, 8

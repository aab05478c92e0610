"""The rows of the arrays the engine hands the compiled kernels: one contract, three kernels.

A `Simulation` holds N lanes (one scenario each) as arrays; per chunk of B steps it calls a
kernel runner with

- `xs` (N, B + 1, S): the mechanism state, row 0 the chunk's start, rows 1 … B written;
- `targets` (N, B, 18): the held target in the base frame at each step (`TARGET_*` rows);
- `prm` (N, N_PARAMETERS): each lane's planner knobs, packed from its planner object;
- `memory` (N, N_MEMORY): each lane's planner state carried from step to step (DWA's shares,
  a PID's integral, …), read and written by the kernel;
- `const`: the mechanism's constants;
- `diag` (N, B + 1, …): rows 1 … B written, row k + 1 by step k, beside the state it led to
  (row 0, the chunk's start, is left alone);
- `faults` (N, B) int64: written, one row per step.

Row 0 of `prm` names the lane's planner family (`KIND_*`), row 1 whether the lane holds its
joint limits (1.0) or only records passing them (0.0) (`twin.planners.parameters.COMMON_FIELDS`);
the rest belongs to the family. The differential and allocation families read their rows by
name, as records (`twin.planners.parameters.family_dtype`: `DIFFERENTIAL_PARAMETERS`,
`ALLOCATION_PARAMETERS`); the qp and platform families read offsets from `P_FAMILY` on.
"""

from __future__ import annotations

# Planner families (prm[P_KIND]; KIND_QP: the `qp` planner, `twin.sim.kernels.qp`) and the
# row size, defined once where the families' records are (`twin.planners.parameters`)
from twin.planners.parameters import KIND_ALLOCATION as KIND_ALLOCATION
from twin.planners.parameters import KIND_DIFFERENTIAL as KIND_DIFFERENTIAL
from twin.planners.parameters import KIND_PLATFORM as KIND_PLATFORM
from twin.planners.parameters import KIND_QP as KIND_QP
from twin.planners.parameters import ROW_SIZE

#: Target rows: ᴮR_d row-major (9), ᴮp_d [m] (3), twist ᴮξ̇_d = [ᴮṗ_d; ᴮω_d] [m/s, rad/s] (6).
TARGET_R, TARGET_P, TARGET_V, TARGET_W = 0, 9, 12, 15
N_TARGET = 18

#: Common prm rows (the fields `COMMON_FIELDS` names); a flat family's own rows start at
#: P_FAMILY.
P_KIND, P_HOLD, P_FAMILY = 0, 1, 2
N_PARAMETERS = ROW_SIZE
N_MEMORY = 48

#: Fault bits, the values of `twin.sim.faults.Fault` (tested equal), as plain ints for numba.
FAULT_BASE_MOTION, FAULT_PLANNER, FAULT_KINEMATICS = 1, 2, 4
FAULT_JOINT_LIMIT, FAULT_SINGULAR = 8, 16
FAULT_INFEASIBLE = 32

#: Hybrid-system constants (`const` of the hybrid runner): Table 6 joint limits, rate limits,
#: gangway d1 and a1 (Table 1), the Stewart hinges (6 × 3 row-major, base hinges in B,
#: platform hinges in P; seed 000 eqs (1)-(2)) and the leg stroke (Table 1).
C_LOWER, C_UPPER, C_RATE, C_D1, C_A1 = 0, 9, 18, 27, 28
C_BASE_HINGES, C_PLATFORM_HINGES, C_LEG_MIN, C_LEG_MAX = 29, 47, 65, 66
N_HYBRID_CONSTANTS = 67

#: Hybrid diagnostics rows (diag (N, B + 1, N_HYBRID_DIAGNOSTICS)): the weights diag(W⁻¹) (9),
#: null-space share, damping λ, rate-limit scale (differential planners); the position
#: shares (3, allocation planners); the fraction of the step taken (1: all; `hold` mode).
#: The engine hands diag in zeroed; a kernel leaves another family's rows alone (no NaN).
D_WEIGHTS, D_SHARE, D_DAMPING, D_SCALE, D_POSITION_SHARE, D_LIMIT_SCALE = 0, 9, 10, 11, 12, 15
#: the qp planner's level (0: tip position exact, 1: weighted, 2: limits relaxed) and how many
#: limit rows and rate bounds were active at its solution (`twin.planners.qp.solve_levels`).
D_QP_LEVEL, D_QP_ACTIVE = 16, 17
N_HYBRID_DIAGNOSTICS = 18

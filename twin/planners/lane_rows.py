"""The rows a hybrid planner's lane step reads and writes besides its parameters: the target
row, the diagnostics row and the fault bits.

The engine hands each step of a lane the held target as one float row and a diagnostics row to
fill, and takes the step's fault bits back (`twin.sim.kernels.layout`, which re-exports these
names for the rest of the engine). They are defined here, where the steps that fill them are
(`twin.planners.differential_step`, `.allocation_step`, `.qp_step`), so the planners' layer
needs nothing of the engine's.
"""

from __future__ import annotations

#: Target rows: ᴮR_d row-major (9), ᴮp_d [m] (3), twist ᴮξ̇_d = [ᴮṗ_d; ᴮω_d] [m/s, rad/s] (6)
#: (`twin.planners.tasks.TARGET_ROW`).
TARGET_R, TARGET_P, TARGET_V, TARGET_W = 0, 9, 12, 15
N_TARGET = 18

#: Fault bits a planner's step returns, the values of `twin.sim.faults.Fault` (tested equal),
#: as plain ints for numba: a velocity that is not finite, a damped (singular) solve, a QP
#: solved only with its limits relaxed.
FAULT_PLANNER, FAULT_SINGULAR, FAULT_INFEASIBLE = 2, 16, 32

#: Hybrid diagnostics rows (diag (N, B + 1, N_HYBRID_DIAGNOSTICS)): the weights diag(W⁻¹) (9),
#: null-space share, damping λ, rate-limit scale (differential planners); the position
#: shares (3, allocation planners); the fraction of the step taken (1: all; `hold` mode; the
#: engine's guard writes it). The engine hands diag in zeroed; a step leaves another family's
#: rows alone (no NaN).
D_WEIGHTS, D_SHARE, D_DAMPING, D_SCALE, D_POSITION_SHARE, D_LIMIT_SCALE = 0, 9, 10, 11, 12, 15
#: the qp planner's level (0: tip position exact, 1: weighted, 2: limits relaxed) and how many
#: limit rows and rate bounds were active at its solution (`twin.planners.qp.solve_levels`).
D_QP_LEVEL, D_QP_ACTIVE = 16, 17
N_HYBRID_DIAGNOSTICS = 18

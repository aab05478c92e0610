"""The rows a hybrid planner's lane step reads and writes besides its parameters: the target
row, the diagnostics row and the fault bits.

The engine hands each step of a lane the held target as one float row and a diagnostics row to
fill, and takes the step's fault bits back (`twin.sim.kernels.layout`, which re-exports these
names for the rest of the engine). They are defined here, where the steps that fill them are
(`twin.planners.differential_step`, `.allocation_step`, `.qp_step`), so the planners' layer
needs nothing of the engine's.
"""

from __future__ import annotations

from twin.planners.parameters import record_dtype, row_size

#: The target row a lane's tip task reads (`record_dtype`, N_TARGET floats read by name), all
#: in the Stewart base frame B: ᴮR_d row-major (9), ᴮp_d [m] (3), the twist
#: ᴮξ̇_d = [ᴮṗ_d; ᴮω_d] [m/s, rad/s] (6).
TARGET = record_dtype((("R_d", 9), ("p_d", 3), ("twist", 6)), what="TARGET")
N_TARGET = row_size(TARGET)

#: Fault bits a planner's step returns, the values of `twin.sim.faults.Fault` (tested equal),
#: as plain ints for numba: a velocity that is not finite, a damped (singular) solve, a QP
#: solved only with its limits relaxed.
FAULT_PLANNER, FAULT_SINGULAR, FAULT_INFEASIBLE = 2, 16, 32

#: A step's hybrid diagnostics (a row of diag (N, B + 1, N_HYBRID_DIAGNOSTICS), read by name):
#: the weights diag(W⁻¹) (9), null-space share, damping λ, rate-limit scale (differential
#: planners); the position shares (3, allocation planners); the fraction of the step taken
#: (1: all; `hold` mode; the engine's guard writes it); the qp planner's level (0: tip position
#: exact, 1: weighted, 2: limits relaxed) and how many limit rows and rate bounds were active
#: at its solution (`twin.planners.qp.solve_levels`). The engine hands diag in zeroed; a step
#: leaves another family's fields alone (no NaN).
HYBRID_DIAGNOSTICS = record_dtype(
    (("weights", 9), ("null_space_share", 1), ("damping", 1), ("velocity_scale", 1),
     ("position_share", 3), ("limit_scale", 1), ("qp_level", 1), ("qp_active", 1)),
    what="HYBRID_DIAGNOSTICS",
)  # fmt: skip
N_HYBRID_DIAGNOSTICS = row_size(HYBRID_DIAGNOSTICS)

"""The lane parameter records of the hybrid planner families: what an object's `pack` writes
by name and its family's step reads by name (`family_dtype`). Both import them from here, so a
step module needs nothing from its object's module and sits below it.
"""

from __future__ import annotations

from twin.planners.parameters import family_dtype

#: The hybrid families' diagnostics: the series a lane of the family records (the kernel writes
#: them; another family's are left out of a lane's series). A registry entry may name fewer.
FAMILY_DIAGNOSTICS: dict[str, frozenset[str]] = {
    "differential": frozenset({"weights", "null_space_share", "damping", "velocity_scale"}),
    "allocation": frozenset({"position_share"}),
    "qp": frozenset({"qp_level", "qp_active"}),
    "platform": frozenset(),
}

#: The differential family's lane parameters (`family_dtype`), written by the parts' `pack`:
#: k_e [1/s] (eq (34), `TipPoseTask`); the β split β^l per joint (eqs (27)-(30), 1 without
#: weights, `BetaSplit`); the joint-limit weights' scale (1, k_c on the telescope, eq (37)),
#: on/off and the limits [m, rad] (`JointLimitWeights`); the posture task's joint (−1: none),
#: k_a [1/s] and q̃ (eqs (39)-(40), `JointPostureTask`); Algorithm 1 on/off, σ [rad], q̇1,max
#: [rad/s], the slew limits [rad] and yaw_hold [-] (`SlewPriority`); λ_max and ε of the damped
#: solve (`weighted_pinv`); λ of eq (34); the rate limit on/off and its maxima [m/s, rad/s]
#: (`VelocityLimit`).
DIFFERENTIAL_PARAMETERS = family_dtype(
    (
        ("gain", 1), ("split", 9), ("scale", 9),
        ("posture_index", 1), ("posture_gain", 1), ("posture_set", 1),
        ("slew", 1), ("sigma", 1), ("slew_rate", 1), ("q1_min", 1), ("q1_max", 1),
        ("damping", 1), ("epsilon", 1), ("secondary", 1),
        ("joint_limits", 1), ("rate_limited", 1), ("rate", 9), ("yaw_hold", 1),
        ("lower", 9), ("upper", 9),
    )
)  # fmt: skip

#: The allocation family's methods, as a row's `method` numbers them
ALLOCATION_METHODS = {"conv1": 0, "conv2": 1, "dwa": 2}

#: The allocation family's lane parameters (`family_dtype`), written by
#: `AllocationPlanner.pack` after its reset: the method (`ALLOCATION_METHODS`); DWA's
#: normalisers, the Stewart manipulability [-] and the reachable range Δx, Δy, Δz [m] at the
#: working state; ᴮT_P(0) and ᴮT_E(0)⁻¹ rows 0-2 row-major (ᴮR | ᴮp [m]), the platform and
#: the inverse tip pose at reset; the platform yaw at reset [rad] (the slew joint takes the
#: yaw, dwa); the gangway joints at reset [rad, rad, m] (conv1 keeps them).
ALLOCATION_PARAMETERS = family_dtype(
    (("method", 1), ("manip_mid", 1), ("range_mid", 3), ("T_P0", 12), ("T_E0_inv", 12),
     ("yaw0", 1), ("q0", 3))
)  # fmt: skip

#: smallest w_j of the regularisation's β split (β = 0 or 1 freezes a joint, not divides by 0)
MIN_SPLIT = 1e-6

#: The qp family's lane parameters (`family_dtype`), written by name by `QPPlanner.pack` and
#: its parts' `pack`: k_e [1/s] (`TipPoseTask`); w_o, the position weight of level 1, w_s and
#: μ; the β split w_j (9, `BetaSplit`); the posture task's joint (−1: none), k_a [1/s] and q̃
#: (`JointPostureTask`); the yaw term on/off and its yaw_hold (`PlatformYawTask`); the leg
#: dampers' gain and margin [m] (`LegStrokeLimit`), the Table 6 dampers' [m | rad]
#: (`JointLimit`); the rate box (9) [m/s, rad/s] (`RateLimit`); the solver (index into
#: `SOLVERS`: 0, the compiled one the engine runs).
QP_PARAMETERS = family_dtype(
    (
        ("gain", 1), ("orientation", 1), ("position", 1), ("secondary", 1), ("damping", 1),
        ("split", 9), ("posture_index", 1), ("posture_gain", 1), ("posture_set", 1),
        ("yaw", 1), ("yaw_hold", 1), ("leg_gain", 1), ("leg_margin", 1), ("joint_gain", 1),
        ("joint_margin", 1), ("rate", 9), ("solver", 1),
    )
)  # fmt: skip

"""The 9-DOF hybrid boarding system: Stewart platform carrying the gangway (seed 000 §3.4).

Virtual joints xi = [x, y, z, roll, pitch, yaw, q1, q2, d3]: the platform pose in the
Stewart base frame B (absolute, R = Rz·Ry·Rx) and the gangway joints (q2 = 0 horizontal,
d3 the absolute gangway length). The Table 5 working state is
`[0, 0, 2.475, 0, 0, 0, 0, 0, 13.052]`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from twin.compiled import register_inline
from twin.mechanisms.gangway import Gangway, gangway_tip_lane
from twin.mechanisms.legs import LegLayout
from twin.mechanisms.limits import JOINT_PAST
from twin.mechanisms.stewart import StewartPlatform
from twin.spatial import (
    pose_to_transform,
    rodrigues_coefficients,
    rpy_of_entries,
    se3_exp,
    skew,
    transform_to_pose,
)
from twin.validation import as_array

DEG = np.pi / 180.0

#: Names of the nine virtual joints, in xi order.
JOINT_NAMES = ("x", "y", "z", "roll", "pitch", "yaw", "q1", "q2", "d3")

#: The hybrid system as its lanes read it, by name (`HybridBoardingSystem.pack`): the Table 6
#: joint limits (absolute, SPEC erratum 3) and the virtual-joint rate limits [m, rad, /s]; the
#: gangway's d1 and a1 [m] (Table 1); the Stewart hinges, base hinges ᴮB_i and platform hinges
#: ᴾP_i (6 × 3 row-major, seed 000 eqs (1)-(2)) [m]; the leg stroke [m] (Table 1). A lane
#: function takes the float row (`N_HYBRID_CONSTANTS`,) and views it as this record.
HYBRID_CONSTANTS = np.dtype(
    (
        np.record,
        [
            ("lower", np.float64, (9,)), ("upper", np.float64, (9,)),
            ("rate", np.float64, (9,)), ("d1", np.float64), ("a1", np.float64),
            ("base_hinges", np.float64, (18,)), ("platform_hinges", np.float64, (18,)),
            ("leg_min", np.float64), ("leg_max", np.float64),
        ],
    )
)  # fmt: skip
#: float64 values in the constants row
N_HYBRID_CONSTANTS = HYBRID_CONSTANTS.itemsize // 8


@dataclass(frozen=True)
class HybridBoardingSystem:
    """Composition of `StewartPlatform` and `Gangway` (seed 000 eqs (14)-(25), Tables 5-6).

    Attributes:
        stewart: the parallel part.
        gangway: the serial part, mounted on the platform frame P.
        working_state: (9,) Table 5 active-compensation operating state.
        initial_state: (9,) Table 5 initial (stowed) state.
        lower, upper: (9,) absolute virtual-joint limits: Table 6 ranges about the working
            state (SPEC erratum 3), angles [rad].
    """

    stewart: StewartPlatform = field(default_factory=StewartPlatform)
    gangway: Gangway = field(default_factory=Gangway)
    working_state: np.ndarray = field(
        default_factory=lambda: np.array([0, 0, 2.475, 0, 0, 0, 0, 0, 13.052], dtype=float)
    )
    initial_state: np.ndarray = field(
        default_factory=lambda: np.array([0, 0, 1.525, 0, 0, 0, 0, 0, 9.552], dtype=float)
    )
    state_names: tuple[str, ...] = JOINT_NAMES

    @property
    def lower(self) -> np.ndarray:
        """(9,) lower limits [m, rad]: Table 6 minimum added to the working state."""
        table6 = np.array([-1.36, -1.15, -0.95, -30 * DEG, -30 * DEG, -36 * DEG])
        return np.concatenate([self.working_state[:6] + table6, self.gangway.lower])

    @property
    def upper(self) -> np.ndarray:
        """(9,) upper limits [m, rad]: Table 6 maximum added to the working state."""
        table6 = np.array([1.165, 1.15, 1.12, 30 * DEG, 30 * DEG, 36 * DEG])
        return np.concatenate([self.working_state[:6] + table6, self.gangway.upper])

    @property
    def state_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper), each (9,)."""
        return self.lower, self.upper

    @property
    def pose_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) of the platform pose, each (6,): the first six virtual joints."""
        return self.lower[:6], self.upper[:6]

    @property
    def layout(self) -> LegLayout:
        """The Stewart legs (for the URDF and the scene)."""
        return self.stewart.layout

    def pack(self, rate_limit: ArrayLike) -> np.ndarray:
        """The system as its lanes read it: a float row (N_HYBRID_CONSTANTS,) written by name
        as one `HYBRID_CONSTANTS` record (a lane views it so).

        Args:
            rate_limit: (9,) [m/s, rad/s] virtual-joint rate limits (`HYBRID_RATE_LIMITS`).
        """
        row = np.zeros(N_HYBRID_CONSTANTS)
        c = row.view(HYBRID_CONSTANTS)[0]
        c["lower"], c["upper"] = self.lower, self.upper
        c["rate"] = np.asarray(rate_limit, dtype=float)
        c["d1"], c["a1"] = self.gangway.d1, self.gangway.a1
        c["base_hinges"] = np.asarray(self.layout.base_hinges).reshape(18)
        c["platform_hinges"] = np.asarray(self.layout.platform_hinges).reshape(18)
        c["leg_min"], c["leg_max"] = self.stewart.leg_min, self.stewart.leg_max
        return row

    def platform_pose(self, xi: ArrayLike) -> np.ndarray:
        """Platform pose (..., 6) [m, rad] in B from virtual joints (..., 9)."""
        return as_array(xi, "xi", (9,))[..., :6]

    def leg_lengths(self, xi: ArrayLike) -> np.ndarray:
        """Stewart leg lengths (..., 6) [m] for virtual joints xi (..., 9); seed 000 eq (5)."""
        return self.stewart.leg_lengths(self.platform_pose(xi))

    def manipulability(self, xi: ArrayLike) -> np.ndarray:
        """Yoshikawa manipulability of the Stewart part (...,) (seed 004 §3.1 b, SPEC erratum 7)."""
        return self.stewart.manipulability(self.platform_pose(xi))

    def end_effector(self, xi: ArrayLike) -> np.ndarray:
        """ᴮT_E (..., 4, 4): ᴮT_P · ᴾT_E, the gangway tip in the Stewart base frame; eq (14)."""
        xi = as_array(xi, "xi", (9,))
        return pose_to_transform(xi[..., :6]) @ self.gangway.forward(xi[..., 6:])

    def tip_pose(self, xi: ArrayLike) -> np.ndarray:
        """Gangway tip as `[x, y, z, roll, pitch, yaw]` (..., 6) [m, rad] in B."""
        return transform_to_pose(self.end_effector(xi))

    def task_jacobian(self, xi: ArrayLike) -> np.ndarray:
        """J_task (..., 6, 9), seed 000 eq (24)-(25).

        Rows: the tip's linear and angular velocity in B. Columns 0-5: the platform's
        linear velocity ᴾṖ and angular velocity ω_P, both in the platform frame P;
        columns 6-8: q̇1, q̇2, ḋ3. Integrate with `integrate`, not by adding to Euler angles.
        """
        xi = as_array(xi, "xi", (9,))
        R = pose_to_transform(xi[..., :6])[..., :3, :3]
        p_E = self.gangway.forward(xi[..., 6:])[..., :3, 3]  # ᴾP_E
        J_s = self.gangway.jacobian(xi[..., 6:])
        top = np.concatenate([R, -skew((R @ p_E[..., None])[..., 0]) @ R, R @ J_s[..., :3, :]], -1)
        bottom = np.concatenate([np.zeros_like(R), R, R @ J_s[..., 3:, :]], -1)
        return np.concatenate([top, bottom], -2)

    def integrate(self, xi: ArrayLike, velocity: ArrayLike, dt: float) -> np.ndarray:
        """xi after applying virtual-joint velocities (..., 9) for dt [s].

        The platform pose moves on SE(3): ᴮT_P ← ᴮT_P exp([ᴾṖ; ω_P] dt) (body twist);
        the gangway joints add q̇ dt.
        """
        xi = as_array(xi, "xi", (9,))
        velocity = as_array(velocity, "velocity", (9,))
        step = as_array(dt, "dt")  # a NaN or inf dt would return a NaN state silently
        T = pose_to_transform(xi[..., :6]) @ se3_exp(velocity[..., :6] * step)
        return np.concatenate([transform_to_pose(T), xi[..., 6:] + velocity[..., 6:] * step], -1)

    def limit_excess(self, xi: ArrayLike) -> np.ndarray:
        """How far each virtual joint and each leg is past its limit, (..., 15) [m, rad]:
        the 9 joints (Table 6) then the 6 legs (Table 1); 0 inside."""
        xi = as_array(xi, "xi", (9,))
        legs = self.leg_lengths(xi)
        s = self.stewart
        return np.concatenate(
            [
                np.maximum(self.lower - xi, 0.0) + np.maximum(xi - self.upper, 0.0),
                np.maximum(s.leg_min - legs, 0.0) + np.maximum(legs - s.leg_max, 0.0),
            ],
            axis=-1,
        )

    def within_limits(self, xi: ArrayLike) -> np.ndarray:
        """True where xi (..., 9) is inside the Table 6 limits and every leg inside Table 1, to
        their tolerances (`twin.mechanisms.limits`, as the metrics count in `hold` mode)."""
        xi = as_array(xi, "xi", (9,))
        joints = np.all(JOINT_PAST(xi, self.lower, self.upper, 0.0) == 0.0, axis=-1)
        return joints & self.stewart.within_limits(self.leg_lengths(xi))


# ---------------------------------------------------------------------------------------------
# One lane (floats and small arrays, compiled by numba into the kernels that call them,
# `twin.compiled`; plain Python without numba)
# ---------------------------------------------------------------------------------------------


@register_inline
def tip_transform(
    x: np.ndarray, R: np.ndarray, d1: float, a1: float, G: np.ndarray, T_out: np.ndarray
) -> None:
    """ᴮT_E = ᴮT_P ᴾT_E, the gangway tip in the Stewart base frame (seed 000 eq (14),
    `HybridBoardingSystem.end_effector`).

    Args:
        x: (9,) xi [m, rad].
        R: (3, 3) ᴮR_P of x (`rpy_to_matrix_lane`; its caller has it already).
        d1, a1: [m] the gangway's (`gangway_tip_lane`).
        G: (4, 4) written: ᴾT_E (`gangway_tip_lane`).
        T_out: (4, 4) written.
    """
    gangway_tip_lane(x[6], x[7], x[8], d1, a1, G)
    for i in range(3):
        for j in range(4):
            T_out[i, j] = R[i, 0] * G[0, j] + R[i, 1] * G[1, j] + R[i, 2] * G[2, j]
        T_out[i, 3] += x[i]
    T_out[3, 0], T_out[3, 1], T_out[3, 2], T_out[3, 3] = 0.0, 0.0, 0.0, 1.0


@register_inline
def integrate_hybrid(
    x: np.ndarray, R: np.ndarray, v: np.ndarray, dt: float, x_out: np.ndarray
) -> None:
    """xi after the virtual-joint velocity v held for dt (`HybridBoardingSystem.integrate`).

    The platform pose moves on SE(3) by the exponential map of its body twist,
    ᴮT_P ← ᴮT_P exp([ᴾṖ; ω_P] dt) (`twin.spatial.se3_exp`: Rodrigues, and V(ω) v for the
    translation, Lynch & Park eq (3.88)); the gangway joints add q̇ dt (Euler).

    Args:
        x: (9,) xi [m, rad].
        R: (3, 3) ᴮR_P of x (`rpy_to_matrix_lane`; the planner's, shared by the bisection).
        v: (9,) [ᴾṖ [m/s]; ω_P [rad/s] (in P); q̇1, q̇2 [rad/s]; ḋ3 [m/s]].
        dt: [s].
        x_out: (9,) written; may be x itself.
    """
    vx, vy, vz = v[0] * dt, v[1] * dt, v[2] * dt
    wx, wy, wz = v[3] * dt, v[4] * dt, v[5] * dt
    a, b, c = rodrigues_coefficients(math.sqrt(wx * wx + wy * wy + wz * wz))
    # S = skew(ω dt), S² = [k_ij]; exp(S) = I + a S + b S² = [e_ij], V = I + b S + c S²
    # (scalars, not arrays: numba would put a (3, 3) on the heap at every call)
    k00, k11, k22 = -wz * wz - wy * wy, -wz * wz - wx * wx, -wy * wy - wx * wx
    k01, k02, k12 = wx * wy, wx * wz, wy * wz
    e00, e01, e02 = 1.0 + b * k00, -a * wz + b * k01, a * wy + b * k02
    e10, e11, e12 = a * wz + b * k01, 1.0 + b * k11, -a * wx + b * k12
    e20, e21, e22 = -a * wy + b * k02, a * wx + b * k12, 1.0 + b * k22
    t0 = (1.0 + c * k00) * vx + (-b * wz + c * k01) * vy + (b * wy + c * k02) * vz
    t1 = (b * wz + c * k01) * vx + (1.0 + c * k11) * vy + (-b * wx + c * k12) * vz
    t2 = (-b * wy + c * k02) * vx + (b * wx + c * k12) * vy + (1.0 + c * k22) * vz
    # the entries of N = ᴮR_P exp(S) that matrix_to_rpy reads
    n00 = R[0, 0] * e00 + R[0, 1] * e10 + R[0, 2] * e20
    n10 = R[1, 0] * e00 + R[1, 1] * e10 + R[1, 2] * e20
    n20 = R[2, 0] * e00 + R[2, 1] * e10 + R[2, 2] * e20
    n21 = R[2, 0] * e01 + R[2, 1] * e11 + R[2, 2] * e21
    n22 = R[2, 0] * e02 + R[2, 1] * e12 + R[2, 2] * e22
    p0 = R[0, 0] * t0 + R[0, 1] * t1 + R[0, 2] * t2 + x[0]
    p1 = R[1, 0] * t0 + R[1, 1] * t1 + R[1, 2] * t2 + x[1]
    p2 = R[2, 0] * t0 + R[2, 1] * t1 + R[2, 2] * t2 + x[2]
    q1, q2, d3 = x[6] + v[6] * dt, x[7] + v[7] * dt, x[8] + v[8] * dt
    x_out[0], x_out[1], x_out[2] = p0, p1, p2
    x_out[3], x_out[4], x_out[5] = rpy_of_entries(n00, n10, n20, n21, n22)
    x_out[6], x_out[7], x_out[8] = q1, q2, d3

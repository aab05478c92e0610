"""The 9-DOF hybrid boarding system: Stewart platform carrying the gangway (seed 000 §3.4).

Virtual joints xi = [x, y, z, roll, pitch, yaw, q1, q2, d3]: the platform pose in the
Stewart base frame B (absolute, R = Rz·Ry·Rx) and the gangway joints (q2 = 0 horizontal,
d3 the absolute gangway length). The Table 5 working state is
`[0, 0, 2.475, 0, 0, 0, 0, 0, 13.052]`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from twin.mechanisms.gangway import Gangway
from twin.mechanisms.legs import LegLayout
from twin.mechanisms.stewart import StewartPlatform
from twin.spatial import pose_to_transform, se3_exp, skew, transform_to_pose
from twin.validation import as_array

DEG = np.pi / 180.0

#: Names of the nine virtual joints, in xi order.
JOINT_NAMES = ("x", "y", "z", "roll", "pitch", "yaw", "q1", "q2", "d3")


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
        dt = as_array(dt, "dt")  # a NaN or inf dt would return a NaN state silently
        T = pose_to_transform(xi[..., :6]) @ se3_exp(velocity[..., :6] * dt)
        return np.concatenate([transform_to_pose(T), xi[..., 6:] + velocity[..., 6:] * dt], -1)

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
        """True where xi (..., 9) is inside the Table 6 limits and every leg inside Table 1."""
        xi = as_array(xi, "xi", (9,))
        joints = np.all((xi >= self.lower - 1e-12) & (xi <= self.upper + 1e-12), axis=-1)
        return joints & self.stewart.within_limits(self.leg_lengths(xi))

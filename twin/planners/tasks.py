r"""Tasks: a residual, its Jacobian and a gain, in seed 000's sign convention.

Each task asks for a velocity ẋ_demand = ẋ_d + k e with e = x_d − x (seed 000 eq (34)) and
exposes the Jacobian J with ẋ = J q̇. Tasks only read the state; they hold their target.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.mechanisms.hybrid import HybridBoardingSystem
from twin.planners.target import TipTarget
from twin.spatial import pose_error


@dataclass(frozen=True)
class TipPoseTask:
    r"""Primary task: the gangway tip follows ᴮT_E,d (seed 000 eqs (25), (34)).

    Error e = [ᴮp_d − ᴮp; log(R_d Rᵀ)] in B (SPEC erratum 6), Jacobian J_task (eq (24)).

    Attributes:
        mechanism: the hybrid system.
        gain: k_e [1/s], the closed-loop deviation coefficient (0: open loop, eq (33)).
    """

    mechanism: HybridBoardingSystem
    gain: float = 25.0

    def error(self, xi: np.ndarray, target: TipTarget) -> np.ndarray:
        """e (..., 6) [m, rad]."""
        return pose_error(target.transform, self.mechanism.end_effector(xi))

    def jacobian(self, xi: np.ndarray) -> np.ndarray:
        """J_task (..., 6, 9)."""
        return self.mechanism.task_jacobian(xi)

    def demand(self, xi: np.ndarray, target: TipTarget) -> tuple[np.ndarray, np.ndarray]:
        """(ẋ_d + k_e e, e), each (..., 6)."""
        e = self.error(xi, target)
        return target.twist + self.gain * e, e


@dataclass(frozen=True)
class JointPostureTask:
    r"""Secondary task: hold one joint at a set value, seed 000 eqs (39)-(40).

    J_a = e_iᵀ (selects joint `index`; eq (39), SPEC erratum 5: q2 is the 8th of nine),
    ζ̇_a = 0 + k_a (ζ_a − q_i) with ζ_a = q̃_i, the joint's value when compensation starts.

    Attributes:
        index: which virtual joint (7 = q2).
        setpoint: q̃_i [rad | m].
        gain: k_a [1/s].
        n: number of joints.
    """

    index: int
    setpoint: float
    gain: float = 1.0
    n: int = 9

    def jacobian(self, xi: np.ndarray) -> np.ndarray:
        """J_a (..., 1, n)."""
        J = np.zeros((*xi.shape[:-1], 1, self.n))
        J[..., 0, self.index] = 1.0
        return J

    def demand(self, xi: np.ndarray) -> np.ndarray:
        """(..., 1) [rad/s | m/s]."""
        return self.gain * (self.setpoint - xi[..., self.index : self.index + 1])


@dataclass(frozen=True)
class PlatformYawTask:
    r"""Seed 000 Algorithm 1 as a task term (the `qp` planner): the platform keeps its yaw and
    the slew joint turns the tip about P's z axis instead.

    Algorithm 1 (`twin.planners.limits.SlewPriority`) hands the sum of the platform's body yaw
    rate ω_pz and the slew rate q̇1 to q̇1, leaving the platform ω_pz,hold = −yaw_hold·tan(φ)·ω_py
    (with yaw_hold = 1 the rate at which its Euler yaw stays put, docs/decisions.md "MTMP's
    yaw"). As a residual: J_y v = ω_pz + yaw_hold·tan(φ)·ω_py, wanted 0; the slew joint's limits
    and rate are the QP's hard limits, so Algorithm 1's σ bands are not needed.

    Attributes:
        yaw_hold: [-] as `SlewPriority.yaw_hold`.
        n: number of joints.
    """

    yaw_hold: float = 1.0
    n: int = 9

    def jacobian(self, xi: np.ndarray) -> np.ndarray:
        """J_y (..., 1, n): ω_pz (column 5) plus yaw_hold·tan(roll) ω_py (column 4)."""
        J = np.zeros((*xi.shape[:-1], 1, self.n))
        J[..., 0, 4] = self.yaw_hold * np.tan(xi[..., 3])
        J[..., 0, 5] = 1.0
        return J

    def demand(self, xi: np.ndarray) -> np.ndarray:
        """(..., 1) [rad/s]: zero."""
        return np.zeros((*xi.shape[:-1], 1))

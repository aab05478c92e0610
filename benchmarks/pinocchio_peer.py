"""The peer: the hybrid system as a Pinocchio serial chain, and a closed-loop WPI loop on it.

Nine virtual joints as a chain, the way a general-purpose rigid-body library sees the machine:
platform x, y, z (prismatic along B's axes), yaw, pitch, roll (Rz·Ry·Rx, seed 000 eq (3)), then
slew, luff and telescope with Table 2's modified DH transforms as joint placements (SPEC
erratum 3: θ2 = q2 + 90°). Pinocchio's q is therefore [x, y, z, yaw, pitch, roll, q1, q2, d3]
and its q̇ holds Euler-angle rates, where our xi is [x, y, z, roll, pitch, yaw, …] and our
J_task's platform columns are the body twist [ᴾṖ; ω_P] in P (`body_to_pin_rates` maps one to
the other).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from twin.mechanisms import HybridBoardingSystem
from twin.spatial import rpy_rate_matrix, rpy_to_matrix


def build_model(mechanism: HybridBoardingSystem | None = None) -> tuple[pin.Model, int]:
    """The chain as a `pin.Model` and the frame id of the gangway tip E."""
    h = mechanism or HybridBoardingSystem()
    model = pin.Model()
    parent = 0
    identity = pin.SE3.Identity()
    for name, joint in (
        ("x", pin.JointModelPX()),
        ("y", pin.JointModelPY()),
        ("z", pin.JointModelPZ()),
        ("yaw", pin.JointModelRZ()),
        ("pitch", pin.JointModelRY()),
        ("roll", pin.JointModelRX()),
    ):
        parent = model.addJoint(parent, joint, identity, name)
    rot_x = pin.SE3(pin.utils.rotate("x", np.pi / 2), np.zeros(3))  # DH α = 90°
    g = h.gangway
    placements = (
        ("q1", pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([0.0, 0.0, g.d1]))),
        (
            "q2",
            pin.JointModelRZ(),
            rot_x * pin.SE3(pin.utils.rotate("z", np.pi / 2), np.array([g.a1, 0.0, 0.0])),
        ),
        ("d3", pin.JointModelPZ(), rot_x),
    )
    for name, joint, placement in placements:
        parent = model.addJoint(parent, joint, placement, name)
    tip = model.addFrame(pin.Frame("tip", parent, identity, pin.FrameType.OP_FRAME))
    return model, tip


def xi_to_q(xi: np.ndarray) -> np.ndarray:
    """Our xi [x, y, z, roll, pitch, yaw, q1, q2, d3] → Pinocchio's q (yaw, pitch, roll)."""
    return np.r_[xi[:3], xi[5], xi[4], xi[3], xi[6:]]


def body_to_pin_rates(xi: np.ndarray) -> np.ndarray:
    """M (9, 9) with q̇_pin = M v for our velocities v (platform body twist in P, q̇1, q̇2, ḋ3).

    ᴮṗ = ᴮR_P ᴾṖ; the Euler rates solve E(rpy) d(rpy)/dt = ᴮR_P ω_P (twin.spatial).
    """
    rpy = xi[3:6]
    R = rpy_to_matrix(rpy)
    rates = np.linalg.solve(rpy_rate_matrix(rpy), R)  # d(roll, pitch, yaw)/dt per ω_P
    M = np.zeros((9, 9))
    M[:3, :3] = R
    M[3:6, 3:6] = rates[::-1]  # Pinocchio's order: yaw, pitch, roll
    M[6:, 6:] = np.eye(3)
    return M


class PinocchioPeer:
    """Closed-loop weighted pseudo-inverse (seed 000 eqs (31), (34)) in a plain Python loop.

    Per step: forward kinematics and the tip's frame Jacobian (`computeFrameJacobian`,
    LOCAL_WORLD_ALIGNED = [ᴮv_E; ᴮω_E]), the pose error e = [p_d − p; log3(R_d Rᵀ)], the damped
    6×9 solve q̇ = W Jᵀ (J W Jᵀ + λ²I)⁻¹ (ẋ_d + k_e e) and the integration `pin.integrate`.

    Args:
        beta: [-] β of eq (28) (W⁻¹ = β on the platform, 1 − β on the gangway).
        k_e: [1/s] closed-loop gain.
        damping: λ [-], constant.
    """

    def __init__(self, beta: float = 0.7, k_e: float = 25.0, damping: float = 1e-3) -> None:
        self.model, self.tip = build_model()
        self.data = self.model.createData()
        self.w = np.r_[np.full(6, beta), np.full(3, 1.0 - beta)]
        self.k_e = k_e
        self.lam2 = damping**2

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """J (6, 9) of the tip, [ᴮv_E; ᴮω_E] per q̇_pin."""
        return pin.computeFrameJacobian(
            self.model, self.data, q, self.tip, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )

    def tip_pose(self, q: np.ndarray) -> pin.SE3:
        """ᴮT_E."""
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[self.tip]

    def run(self, q: np.ndarray, targets: np.ndarray, twists: np.ndarray, dt: float) -> np.ndarray:
        """Track `targets` (n, 4, 4) ᴮT_d with feed-forward `twists` (n, 6); q after each step.

        Returns:
            (n, 9) Pinocchio configurations.
        """
        model, data, tip, w, k_e, lam2 = (
            self.model, self.data, self.tip, self.w, self.k_e, self.lam2
        )  # fmt: skip
        out = np.empty((len(targets), model.nq))
        eye = np.eye(6)
        for k in range(len(targets)):
            J = pin.computeFrameJacobian(
                model, data, q, tip, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
            )
            pin.updateFramePlacement(model, data, tip)  # FK ran inside computeFrameJacobian
            T = data.oMf[tip]
            T_d = targets[k]
            error = np.r_[T_d[:3, 3] - T.translation, pin.log3(T_d[:3, :3] @ T.rotation.T)]
            WJt = w[:, None] * J.T
            v = WJt @ np.linalg.solve(J @ WJt + lam2 * eye, twists[k] + k_e * error)
            q = pin.integrate(model, q, v * dt)
            out[k] = q
        return out

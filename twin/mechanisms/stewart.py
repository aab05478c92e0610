"""The 6-DOF Stewart platform of the hybrid boarding system (seed 000 §3.2, Table 1).

Frames (docs/frames.md): base B at the centre of the bottom hinge circle, platform P at
the centre of the top hinge circle, both z up. A pose is `[x, y, z, roll, pitch, yaw]`
[m, rad] of P in B with ᴮR_P = Rz(yaw)·Ry(pitch)·Rx(roll) (seed 000 eq (3)).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from twin.errors import ConvergenceError, UnreachableError
from twin.mechanisms.legs import LegLayout, LegState, legs, twist_jacobian
from twin.mechanisms.newton import newton, start
from twin.spatial import pose_to_transform, rpy_rate_matrix
from twin.validation import as_array

# [m] Table 1 prints the stroke to the millimetre; the retracted legs of its own geometry are
# 2.57986 m (Table 5 rounds them to 2.58), so the limits are enforced to half a millimetre.
LENGTH_TOL = 5e-4


def hinge_angles(
    d: float, r: float, offsets: tuple[float, ...], sign: tuple[int, ...]
) -> np.ndarray:
    """ϑ_i = offset_i ± asin(d / 2r) (seed 000 eqs (1)-(2)); pairs of hinges a chord d apart."""
    half = np.arcsin(d / (2.0 * r))
    return np.asarray(offsets) + np.asarray(sign) * half


@dataclass(frozen=True)
class StewartPlatform:
    """Seed 000 Table 1 geometry; all lengths [m].

    Attributes:
        r_base: r_B, radius of the bottom hinge circle.
        r_platform: r_P, radius of the top hinge circle.
        d_base: d_B, distance between paired bottom hinges.
        d_platform: d_P, distance between paired top hinges.
        leg_min: l_1 lower limit (Table 1).
        leg_max: l_1 upper limit (Table 1).
    """

    r_base: float = 2.650
    r_platform: float = 1.950
    d_base: float = 0.350
    d_platform: float = 0.350
    leg_min: float = 2.580
    leg_max: float = 4.180
    layout: LegLayout = field(init=False, repr=False)

    def __post_init__(self) -> None:
        pi = np.pi
        # seed 000 eq (1): ϑ_P; SPEC erratum 1: seed 000's ϑ_B, not seed 004's.
        theta_p = hinge_angles(
            self.d_platform,
            self.r_platform,
            (pi / 6, pi / 6, -pi / 2, -pi / 2, 5 * pi / 6, 5 * pi / 6),
            (1, -1, 1, -1, 1, -1),
        )
        theta_b = hinge_angles(
            self.d_base,
            self.r_base,
            (pi / 2, -pi / 6, -pi / 6, -5 * pi / 6, -5 * pi / 6, pi / 2),
            (-1, 1, -1, 1, -1, 1),
        )

        def circle(r: float, theta: np.ndarray) -> np.ndarray:
            return np.stack([r * np.cos(theta), r * np.sin(theta), np.zeros(6)], -1)

        layout = LegLayout(
            base_hinges=circle(self.r_base, theta_b),  # seed 000 eq (2)
            platform_hinges=circle(self.r_platform, theta_p),  # seed 000 eq (1)
            length_min=np.full(6, self.leg_min),
            length_max=np.full(6, self.leg_max),
        )
        object.__setattr__(self, "layout", layout)

    def legs(self, pose: ArrayLike) -> LegState:
        """Leg vectors, lengths and unit vectors for poses (..., 6) [m, rad]; eqs (3)-(5)."""
        pose = as_array(pose, "pose", (6,))
        return legs(self.layout, pose_to_transform(pose))

    def leg_lengths(self, pose: ArrayLike, *, check: bool = False) -> np.ndarray:
        """Leg lengths l_i (..., 6) [m] for platform poses (..., 6) [m, rad] in B; eq (5).

        With `check`, a pose whose legs leave [leg_min, leg_max] raises UnreachableError;
        without, the lengths are returned as they are (a planner counts the violations).
        """
        lengths = self.legs(pose).lengths
        if check:
            self.check_lengths(lengths, "pose")
        return lengths

    def check_lengths(self, lengths: np.ndarray, name: str) -> None:
        """Raise UnreachableError if any leg leaves the stroke by more than `LENGTH_TOL`."""
        bad = (lengths < self.leg_min - LENGTH_TOL) | (lengths > self.leg_max + LENGTH_TOL)
        if np.any(bad):
            raise UnreachableError(
                f"{name} needs leg lengths {np.round(lengths[bad], 4).tolist()!r:.120} m, "
                f"allowed [{self.leg_min}, {self.leg_max}] m per leg (seed 000 Table 1)"
            )

    def jacobian(self, pose: ArrayLike) -> np.ndarray:
        """J_P (..., 6, 6): l̇ = J_P [ᴮṖ_P; ᴮω_P], both velocities in B (seed 000 eq (8))."""
        return twist_jacobian(self.legs(pose))

    def manipulability(self, pose: ArrayLike) -> np.ndarray:
        """Yoshikawa's sqrt(det(J_P J_Pᵀ)) (..., ) [-] (SPEC erratum 7)."""
        J = self.jacobian(pose)
        return np.sqrt(np.abs(np.linalg.det(J @ np.swapaxes(J, -1, -2))))

    def pose_jacobian(self, pose: ArrayLike) -> np.ndarray:
        """∂l/∂pose (..., 6, 6) with respect to `[x, y, z, roll, pitch, yaw]` (Euler rates)."""
        pose = as_array(pose, "pose", (6,))
        J = self.jacobian(pose)
        return np.concatenate([J[..., :3], J[..., 3:] @ rpy_rate_matrix(pose[..., 3:])], -1)

    def within_limits(self, lengths: ArrayLike) -> np.ndarray:
        """True where every leg of (..., 6) lengths [m] lies in [leg_min, leg_max]."""
        lengths = np.asarray(lengths)
        return np.all((lengths >= self.leg_min) & (lengths <= self.leg_max), axis=-1)

    def forward(
        self,
        lengths: ArrayLike,
        guess: ArrayLike | None = None,
        *,
        tol: float = 1e-12,
        max_iter: int = 30,
    ) -> np.ndarray:
        """Platform pose (..., 6) [m, rad] from leg lengths (..., 6) [m] by Newton-Raphson.

        Args:
            lengths: (..., 6) [m] leg lengths, each within [leg_min, leg_max].
            guess: (..., 6) starting pose; default the level pose at the height that
                gives the mean leg length (good enough inside the workspace).
            tol: [m] stop when every leg's residual is below this.
            max_iter: iterations before giving up.

        Raises:
            TwinError: bad shape, NaN, or a length outside the leg limits.
            ConvergenceError: the residual did not fall below `tol` in `max_iter` steps.
        """
        lengths = as_array(lengths, "lengths", (6,))
        self.check_lengths(lengths, "lengths")
        level = np.zeros(lengths.shape)
        level[..., 2] = self.height_for_length(lengths.mean(axis=-1))

        def equations(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return self.leg_lengths(x) - lengths, self.pose_jacobian(x)

        result = newton(equations, start(guess, level, lengths.shape), tol=tol, max_iter=max_iter)
        if not result.converged:
            raise ConvergenceError(
                f"Stewart forward kinematics did not converge in {max_iter} Newton steps "
                f"(worst leg residual {result.worst:.3g} m > tol {tol:g} m); give a closer `guess`"
            )
        return result.x

    def height_for_length(self, length: ArrayLike) -> np.ndarray:
        """Height z [m] of the level, centred platform whose six legs all have `length` [m]."""
        B, P = self.layout.base_hinges[0], self.layout.platform_hinges[0]
        horizontal = np.hypot(*(P - B)[:2])
        return np.sqrt(np.maximum(np.asarray(length, float) ** 2 - horizontal**2, 0.0))

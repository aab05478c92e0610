"""The 6-DOF Stewart platform of the hybrid boarding system (seed 000 §3.2, Table 1).

Frames (docs/frames.md): base B at the centre of the bottom hinge circle, platform P at
the centre of the top hinge circle, both z up. A pose is `[x, y, z, roll, pitch, yaw]`
[m, rad] of P in B with ᴮR_P = Rz(yaw)·Ry(pitch)·Rx(roll) (seed 000 eq (3)).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from twin.batch import LaneBatch
from twin.compiled import register_jitable
from twin.errors import ConvergenceError, UnreachableError
from twin.mechanisms.legs import (
    LegLayout,
    LegState,
    leg_arm_lane,
    leg_twist_row_lane,
    leg_vectors_lane,
    legs,
    twist_jacobian,
)
from twin.mechanisms.limits import LEG_PAST
from twin.mechanisms.newton import (
    NewtonResult,
    check_tolerances,
    newton_loop,
    start,
)
from twin.spatial import pose_to_transform, rpy_rate_entries, rpy_to_matrix_lane
from twin.validation import as_array


def hinge_angles(
    d: float, r: float, offsets: tuple[float, ...], sign: tuple[int, ...]
) -> np.ndarray:
    """ϑ_i = offset_i ± asin(d / 2r) (seed 000 eqs (1)-(2)); pairs of hinges a chord d apart."""
    half = np.arcsin(d / (2.0 * r))
    return np.asarray(offsets) + np.asarray(sign) * half


# One lane (a single pose; floats and small arrays, compiled by numba into the loops that call
# them, `twin.compiled`; plain Python without numba): the legs, ∂l/∂pose, forward kinematics.


@register_jitable
def stewart_kinematics_lane(
    pose: np.ndarray,
    base: np.ndarray,
    platform: np.ndarray,
    R: np.ndarray,
    vectors: np.ndarray,
    lengths: np.ndarray,
    J: np.ndarray,
) -> None:
    """Leg lengths l_i [m] of a pose (6,) [m, rad] into lengths (6,) and ∂l/∂pose into J (6, 6)
    [m/m, m/rad] (`StewartPlatform.pose_jacobian`); R (3, 3) and vectors (6, 3) written (ᴮR_P
    and the legs, scratch).

    l_i = |ᴮR_P ᴾP_i + ᴮp − ᴮB_i| (seed 000 eqs (3)-(5), `leg_vectors_lane`); the rows
    [n_iᵀ, (ᴮR_P ᴾP_i × n_i)ᵀ] of seed 000 eq (8) (`leg_twist_row_lane`) with the angular part
    turned to Euler rates, ω = E(rpy) d(rpy)/dt (`twin.spatial.rpy_rate_entries`).

    Args:
        base, platform: (18,) ᴮB_i and ᴾP_i row-major [m].
    """
    rpy_to_matrix_lane(pose[3], pose[4], pose[5], R)  # seed 000 eq (3)
    leg_vectors_lane(R, pose, base, platform, vectors, lengths)
    e00, e10, e20, e01, e11 = rpy_rate_entries(pose[4], pose[5])
    for i in range(6):
        a0, a1, a2 = leg_arm_lane(R, platform, i)
        v0, v1, v2 = vectors[i, 0], vectors[i, 1], vectors[i, 2]
        n0, n1, n2, m0, m1, m2 = leg_twist_row_lane(a0, a1, a2, v0, v1, v2, lengths[i])
        J[i, 0], J[i, 1], J[i, 2] = n0, n1, n2
        # (arm × n_i)ᵀ E, E's yaw column e_z
        J[i, 3] = m0 * e00 + m1 * e10 + m2 * e20
        J[i, 4] = m0 * e01 + m1 * e11
        J[i, 5] = m2


@register_jitable
def stewart_newton(
    lengths: np.ndarray,
    base: np.ndarray,
    platform: np.ndarray,
    tol: float,
    max_iter: int,
    x: np.ndarray,
    R: np.ndarray,
    vectors: np.ndarray,
    residual: np.ndarray,
    J: np.ndarray,
    M: np.ndarray,
    step: np.ndarray,
) -> tuple[int, int]:
    """`StewartPlatform.forward` from the start pose x (6,), in place: `newton_loop` on
    l(x) − L (lengths (6,) [m]) with `stewart_kinematics_lane`, at most max_iter + 1
    evaluations, tol [m] on the residual. Returns (the last step's outcome, STEPPED if
    max_iter ran out; the steps taken before it). R, vectors, J (6, 6), M (6, 7): scratch;
    residual (6,), step (6,): the last evaluation's, written."""
    return newton_loop(stewart_legs_lane, (base, platform, R, vectors), lengths, 6, tol, np.inf,
                       max_iter, x, residual, J, M, step)  # fmt: skip


@register_jitable
def stewart_legs_lane(x: np.ndarray, data: tuple, lengths: np.ndarray, J: np.ndarray) -> None:
    """`stewart_kinematics_lane` as `newton_loop` calls it: data = (base, platform, R,
    vectors)."""
    base, platform, R, vectors = data
    stewart_kinematics_lane(x, base, platform, R, vectors, lengths, J)


def _kinematics_batch(
    poses: np.ndarray, base: np.ndarray, platform: np.ndarray, lengths: np.ndarray, J: np.ndarray
) -> None:
    """`stewart_kinematics_lane` of poses (N, 6) into lengths (N, 6) and J (N, 6, 6)."""
    R, vectors = np.zeros((3, 3)), np.zeros((6, 3))
    for k in range(poses.shape[0]):
        stewart_kinematics_lane(poses[k], base, platform, R, vectors, lengths[k], J[k])


def _forward_batch(
    lengths: np.ndarray,
    guesses: np.ndarray,
    base: np.ndarray,
    platform: np.ndarray,
    tol: float,
    max_iter: int,
    x: np.ndarray,
    residual: np.ndarray,
    step: np.ndarray,
    outcome: np.ndarray,
) -> None:
    """`stewart_newton` of lengths (N, 6) from guesses (N, 6) into x (N, 6), the last residual
    and step (N, 6), and (outcome, steps) (N, 2)."""
    R, vectors = np.zeros((3, 3)), np.zeros((6, 3))
    J, M = np.zeros((6, 6)), np.zeros((6, 7))
    for k in range(lengths.shape[0]):
        for j in range(6):
            x[k, j] = guesses[k, j]
            residual[k, j] = 0.0
            step[k, j] = np.inf  # no step taken yet
        result = stewart_newton(lengths[k], base, platform, tol, max_iter, x[k], R, vectors,
                                residual[k], J, M, step[k])  # fmt: skip
        outcome[k, 0], outcome[k, 1] = result[0], result[1]


#: the lanes over a batch: what `pose_jacobian` and `forward` call
KINEMATICS = LaneBatch(_kinematics_batch, cores=(1,))
FORWARD = LaneBatch(_forward_batch, cores=(1, 1))


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
        """Raise UnreachableError if any leg leaves the stroke by more than `LEG_TOL` (Table 1
        prints the stroke to the millimetre: `twin.mechanisms.limits`)."""
        bad = LEG_PAST(lengths, self.leg_min, self.leg_max) != 0.0
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
        """∂l/∂pose (..., 6, 6) with respect to `[x, y, z, roll, pitch, yaw]` (Euler rates), by
        `stewart_kinematics_lane` lane by lane."""
        pose = as_array(pose, "pose", (6,))
        return KINEMATICS([pose], self._hinges(), [(6,), (6, 6)])[1]

    def within_limits(self, lengths: ArrayLike) -> np.ndarray:
        """True where every leg of (..., 6) lengths [m] lies in [leg_min, leg_max] to
        `LEG_TOL` (`leg_past_lane`, as the metrics count)."""
        lengths = np.asarray(lengths, dtype=float)
        return np.all(LEG_PAST(lengths, self.leg_min, self.leg_max) == 0.0, axis=-1)

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
        check_tolerances(tol, max_iter)
        level = np.zeros(lengths.shape)
        level[..., 2] = self.height_for_length(lengths.mean(axis=-1))
        x, residual, step, outcome = FORWARD(
            [lengths, start(guess, level, lengths.shape)],
            [*self._hinges(), float(tol), int(max_iter)],
            [(6,), (6,), (6,), (2,)],
        )  # fmt: skip
        result = NewtonResult.of(x, residual, step, outcome)
        if not result.converged:
            raise ConvergenceError(
                f"Stewart forward kinematics did not converge in {max_iter} Newton steps "
                f"(worst leg residual {result.worst:.3g} m > tol {tol:g} m); give a closer `guess`"
            )
        return result.x

    def _hinges(self) -> list[np.ndarray]:
        """[ᴮB_i (18,), ᴾP_i (18,)] row-major [m], as the lanes take them."""
        layout = self.layout
        return [
            np.array(hinges).reshape(-1) for hinges in (layout.base_hinges, layout.platform_hinges)
        ]

    def height_for_length(self, length: ArrayLike) -> np.ndarray:
        """Height z [m] of the level, centred platform whose six legs all have `length` [m]."""
        B, P = self.layout.base_hinges[0], self.layout.platform_hinges[0]
        horizontal = np.hypot(*(P - B)[:2])
        return np.sqrt(np.maximum(np.asarray(length, float) ** 2 - horizontal**2, 0.0))

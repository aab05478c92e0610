"""What every parallel mechanism shares: legs between base and platform hinges.

A parallel mechanism here is a base, a platform and straight legs, leg i running from the
base hinge B_i (base frame) to the platform hinge P_i (platform frame). Inverse kinematics
is then the same closed-vector equation for all three mechanisms (seed 000 eqs (4)-(5),
seed 001 eq (16), seed 002 eq (15)): l_i = ᴮR_P ᴾP_i + ᴮO_P - ᴮB_i.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from twin.batch import LaneBatch
from twin.compiled import register_inline


@dataclass(frozen=True)
class LegLayout:
    """Hinge geometry and stroke of a parallel mechanism, in metres.

    This is also what the URDF generator draws: each leg a base-attached chain
    (universal joint, then a prismatic joint) ending on the platform hinge.

    Attributes:
        base_hinges: (n, 3) [m] B_i in the base frame.
        platform_hinges: (n, 3) [m] P_i in the platform frame.
        length_min: (n,) [m] shortest hinge-to-hinge length.
        length_max: (n,) [m] longest hinge-to-hinge length.
        actuated: (n,) which legs carry an actuator (a passive guide limb does not).
    """

    base_hinges: np.ndarray
    platform_hinges: np.ndarray
    length_min: np.ndarray
    length_max: np.ndarray
    actuated: tuple[bool, ...] = field(default=())

    def __post_init__(self) -> None:
        n = np.shape(self.base_hinges)[0]
        if not self.actuated:
            object.__setattr__(self, "actuated", (True,) * n)
        for name in ("base_hinges", "platform_hinges", "length_min", "length_max"):
            array = np.array(getattr(self, name), dtype=float)
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    @property
    def n_legs(self) -> int:
        return self.base_hinges.shape[0]


@dataclass(frozen=True)
class LegState:
    """Legs of a batch of platform poses.

    Attributes:
        vectors: (..., n, 3) [m] l_i = ᴮP_i - ᴮB_i in the base frame.
        lengths: (..., n) [m] |l_i|.
        units: (..., n, 3) n_i = l_i / |l_i|.
        arms: (..., n, 3) [m] ᴮR_P ᴾP_i, platform origin → hinge, in the base frame.
    """

    vectors: np.ndarray
    lengths: np.ndarray
    units: np.ndarray
    arms: np.ndarray


def legs(layout: LegLayout, transform: np.ndarray) -> LegState:
    """Leg vectors for platform transforms ᴮT_P (..., 4, 4); seed 000 eqs (4)-(5), computed
    by `leg_vectors_lane` lane by lane (`LEGS`)."""
    n = layout.n_legs
    base, platform = layout.base_hinges.reshape(-1), layout.platform_hinges.reshape(-1)
    vectors, lengths, arms = LEGS([transform], [base, platform], [(n, 3), (n,), (n, 3)])
    return LegState(vectors, lengths, vectors / lengths[..., None], arms)


def twist_jacobian(state: LegState) -> np.ndarray:
    """J with l̇ = J [v_O; ω], v_O the platform-origin velocity and ω the angular velocity,
    both in the base frame; rows [n_iᵀ, (ᴮR_P ᴾP_i × n_i)ᵀ], (..., n, 6), by
    `leg_twist_row_lane` leg by leg (`TWIST`) from the state's arms, vectors and lengths.

    seed 000 eq (8) prints the moment arm as ᴮP_i, which is right for the spatial twist
    (velocity of the body point at the base origin); for the origin velocity it is the
    arm ᴮR_P ᴾP_i. The two differ by a unit-determinant shear, so manipulability is the
    same (docs/decisions.md).
    """
    n = state.lengths.shape[-1]
    return TWIST([state.arms, state.vectors, state.lengths], [], [(n, 6)])[0]


def universal_frames(home_units: np.ndarray) -> np.ndarray:
    """U-joint frames (n, 3, 3) centred on the home leg directions (n, 3).

    z along the home direction s⁰, x = s⁰ × e_z (horizontal; e_x for a vertical leg),
    y = z × x, as seed 002 §2.1 sets its U joints: the angles are then zero at home, and a
    joint limit reads as a deviation from home.
    """
    z = home_units / np.linalg.norm(home_units, axis=-1, keepdims=True)
    x = np.cross(z, [0.0, 0.0, 1.0])
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    x = np.where(norm > 1e-9, x / np.where(norm > 1e-9, norm, 1.0), [1.0, 0.0, 0.0])
    return np.stack([x, np.cross(z, x), z], -1)


def universal_angles(units: np.ndarray, frames: np.ndarray | None = None) -> np.ndarray:
    """U-joint angles (a, b) with F Rx(a) Ry(b) e_z = n for unit leg directions (..., n, 3).

    The URDF legs are revolute-x, revolute-y, prismatic-z chains in the frame F of each leg
    (`universal_frames`; identity if None); this is their inverse. Returns (..., n, 2) [rad].
    """
    if frames is not None:
        units = (np.swapaxes(frames, -1, -2) @ units[..., None])[..., 0]
    b = np.arcsin(np.clip(units[..., 0], -1.0, 1.0))
    a = np.arctan2(-units[..., 1], units[..., 2])
    return np.stack([a, b], -1)


# ---------------------------------------------------------------------------------------------
# One lane (a single pose; floats and small arrays, compiled by numba into the kernels that
# call them, `twin.compiled`; plain Python without numba)
# ---------------------------------------------------------------------------------------------


@register_inline
def leg_component(
    R: np.ndarray, p: np.ndarray, base: np.ndarray, platform: np.ndarray, i: int, k: int
) -> float:
    """Component k of leg i, l_i = ᴮR_P ᴾP_i + ᴮO_P − ᴮB_i [m] (seed 000 eqs (4)-(5)).

    Args:
        R: (3, 3) ᴮR_P; p: ᴮO_P [m], its first three entries read (a pose or xi will do).
        base: (3n,) ᴮB_i row-major [m]; platform: (3n,) ᴾP_i row-major [m].
    """
    return (
        R[k, 0] * platform[3 * i] + R[k, 1] * platform[3 * i + 1] + R[k, 2] * platform[3 * i + 2]
        + p[k] - base[3 * i + k]
    )  # fmt: skip


@register_inline
def leg_lengths_lane(
    R: np.ndarray, p: np.ndarray, base: np.ndarray, platform: np.ndarray, lengths_out: np.ndarray
) -> None:
    """|l_i| [m] of every leg into lengths_out (n,) (seed 000 eq (5)); arguments as
    `leg_component`'s."""
    for i in range(lengths_out.shape[0]):
        l0 = leg_component(R, p, base, platform, i, 0)
        l1 = leg_component(R, p, base, platform, i, 1)
        l2 = leg_component(R, p, base, platform, i, 2)
        lengths_out[i] = math.sqrt(l0 * l0 + l1 * l1 + l2 * l2)


@register_inline
def leg_vectors_lane(
    R: np.ndarray,
    p: np.ndarray,
    base: np.ndarray,
    platform: np.ndarray,
    vectors_out: np.ndarray,
    lengths_out: np.ndarray,
) -> None:
    """The legs l_i into vectors_out (n, 3) [m], in B, and |l_i| into lengths_out (n,) [m]
    (seed 000 eqs (4)-(5), `legs`); arguments as `leg_component`'s."""
    for i in range(lengths_out.shape[0]):
        s = 0.0
        for k in range(3):
            v = leg_component(R, p, base, platform, i, k)
            vectors_out[i, k] = v
            s += v * v
        lengths_out[i] = math.sqrt(s)


@register_inline
def leg_arm_lane(R: np.ndarray, platform: np.ndarray, i: int) -> tuple[float, float, float]:
    """The arm ᴮR_P ᴾP_i [m] of leg i, platform origin → hinge in B (the first term of seed 000 eqs
    (4)-(5)); R (3, 3) ᴮR_P, platform (3n,) ᴾP_i row-major [m]."""
    h0, h1, h2 = platform[3 * i], platform[3 * i + 1], platform[3 * i + 2]
    return (
        R[0, 0] * h0 + R[0, 1] * h1 + R[0, 2] * h2,
        R[1, 0] * h0 + R[1, 1] * h1 + R[1, 2] * h2,
        R[2, 0] * h0 + R[2, 1] * h1 + R[2, 2] * h2,
    )


@register_inline
def leg_twist_row_lane(
    a0: float, a1: float, a2: float, v0: float, v1: float, v2: float, length: float
) -> tuple[float, float, float, float, float, float]:
    """The leg's row [n_iᵀ, (ᴮR_P ᴾP_i × n_i)ᵀ] of the twist Jacobian (seed 000 eq (8) with
    the arm of `twist_jacobian`), n_i = l_i / |l_i|, as six floats [-, m].

    Every leg Jacobian of the package is built from this row: `twist_jacobian`,
    `manipulability_lane`, `twin.mechanisms.stewart.stewart_kinematics_lane` (Euler rates)
    and `twin.mechanisms.platforms.platform_kinematics` (the small platforms' state rates).

    Args:
        a0, a1, a2: the arm ᴮR_P ᴾP_i [m] in B (`leg_arm_lane`).
        v0, v1, v2: the leg l_i [m] in B (`leg_vectors_lane`); length: |l_i| [m].
    """
    inverse = 1.0 / length  # one division, three multiplications
    n0, n1, n2 = v0 * inverse, v1 * inverse, v2 * inverse
    return n0, n1, n2, a1 * n2 - a2 * n1, a2 * n0 - a0 * n2, a0 * n1 - a1 * n0


def _legs_batch(
    T: np.ndarray,
    base: np.ndarray,
    platform: np.ndarray,
    vectors: np.ndarray,
    lengths: np.ndarray,
    arms: np.ndarray,
) -> None:
    """`leg_vectors_lane` and `leg_arm_lane` over transforms T (N, 4, 4) into vectors
    (N, n, 3), lengths (N, n) and arms (N, n, 3)."""
    for k in range(T.shape[0]):
        leg_vectors_lane(T[k, :3, :3], T[k, :3, 3], base, platform, vectors[k], lengths[k])
        for i in range(lengths.shape[1]):
            arms[k, i, 0], arms[k, i, 1], arms[k, i, 2] = leg_arm_lane(T[k, :3, :3], platform, i)


def _twist_batch(arms: np.ndarray, vectors: np.ndarray, lengths: np.ndarray, J: np.ndarray) -> None:
    """`leg_twist_row_lane` of arms (N, n, 3), vectors (N, n, 3), lengths (N, n) into J
    (N, n, 6)."""
    for k in range(lengths.shape[0]):
        for i in range(lengths.shape[1]):
            a, v = arms[k, i], vectors[k, i]
            row = leg_twist_row_lane(a[0], a[1], a[2], v[0], v[1], v[2], lengths[k, i])
            for j in range(6):
                J[k, i, j] = row[j]


#: the legs of a batch of poses, lane by lane: what `legs` calls
LEGS = LaneBatch(_legs_batch, cores=(2,))
#: the twist Jacobians of a batch of leg states: what `twist_jacobian` calls
TWIST = LaneBatch(_twist_batch, cores=(2, 2, 1))


@register_inline
def manipulability_lane(
    R: np.ndarray, vectors: np.ndarray, lengths: np.ndarray, platform: np.ndarray, J: np.ndarray
) -> float:
    """Yoshikawa's sqrt(det(J Jᵀ)) = |det J| [-] of the six-leg Jacobian J (6, 6), rows
    [n_iᵀ, (ᴮR_P ᴾP_i × n_i)ᵀ] (`leg_twist_row_lane`; seed 004 §3.1 b, SPEC erratum 7), by
    Gaussian elimination with partial pivoting.

    Args:
        R: (3, 3) ᴮR_P; vectors (6, 3), lengths (6,): the legs (`leg_vectors_lane`) [m].
        platform: (18,) ᴾP_i row-major [m].
        J: (6, 6) scratch (the caller's, allocated once: numba puts arrays on the heap).
    """
    for i in range(6):
        a0, a1, a2 = leg_arm_lane(R, platform, i)
        v0, v1, v2 = vectors[i, 0], vectors[i, 1], vectors[i, 2]
        J[i, 0], J[i, 1], J[i, 2], J[i, 3], J[i, 4], J[i, 5] = leg_twist_row_lane(
            a0, a1, a2, v0, v1, v2, lengths[i]
        )
    det = 1.0
    for j in range(6):
        pivot = j
        for i in range(j + 1, 6):
            if abs(J[i, j]) > abs(J[pivot, j]):
                pivot = i
        if pivot != j:
            det = -det
            for k in range(j, 6):
                J[j, k], J[pivot, k] = J[pivot, k], J[j, k]
        d = J[j, j]
        det *= d
        if d == 0.0:
            return 0.0
        inverse = 1.0 / d
        for i in range(j + 1, 6):
            f = J[i, j] * inverse
            for k in range(j + 1, 6):
                J[i, k] -= f * J[j, k]
    return abs(det)

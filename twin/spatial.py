r"""Rigid-body math over a leading batch axis: rotations, poses and their tangents.

One convention for the whole twin (SPEC erratum 12): right-handed frames, z up, a pose is
`[x, y, z, roll, pitch, yaw]` [m, rad] and its rotation is Z-Y-X,
:math:`R = R_z(\psi) R_y(\theta) R_x(\phi)` (seed 000 eq (3), SPEC erratum 2).
Quaternions, where they appear, are `wxyz` (viser's order).
"""

from __future__ import annotations

import math

import numpy as np

from twin.batch import LaneBatch
from twin.compiled import LaneUfunc, register_borrowing, register_inline


def skew(v: np.ndarray) -> np.ndarray:
    """S(v) with S(v) w = v × w; `v` (..., 3) → (..., 3, 3)."""
    S = np.zeros((*v.shape[:-1], 3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def rpy_to_matrix(rpy: np.ndarray) -> np.ndarray:
    """ᴮR_P = Rz(yaw) Ry(pitch) Rx(roll), seed 000 eq (3); `rpy` (..., 3) [rad] → (..., 3, 3)."""
    angles = np.moveaxis(np.asarray(rpy, dtype=float), -1, 0)  # components first: contiguous
    c, s = np.cos(angles), np.sin(angles)
    cf, ct, cp = c
    sf, st, sp = s
    R = np.empty((3, 3, *angles.shape[1:]))
    R[0, 0], R[0, 1], R[0, 2] = cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf
    R[1, 0], R[1, 1], R[1, 2] = sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf
    R[2, 0], R[2, 1], R[2, 2] = -st, ct * sf, ct * cf
    return np.moveaxis(R, (0, 1), (-2, -1))


def matrix_to_rpy(R: np.ndarray) -> np.ndarray:
    """Inverse of `rpy_to_matrix` on pitch ∈ (-π/2, π/2); (..., 3, 3) → (..., 3) [rad]."""
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    pitch = np.arctan2(-R[..., 2, 0], np.hypot(R[..., 2, 1], R[..., 2, 2]))
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    return np.stack([roll, pitch, yaw], -1)


def rpy_rate_matrix(rpy: np.ndarray) -> np.ndarray:
    """E(rpy) with ω = E · d(rpy)/dt, ω in the parent (base) frame; (..., 3) → (..., 3, 3), by
    `rpy_rate_entries` lane by lane."""
    return RPY_RATE([rpy], [], [(3, 3)])[0]


def _coefficients(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`rodrigues_coefficients` of each angle of an array [rad]."""
    return np.vectorize(rodrigues_coefficients, otypes=[float, float, float])(theta)


def so3_exp(w: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation vector (..., 3) [rad] → rotation matrix (..., 3, 3)."""
    a, b, _ = _coefficients(np.linalg.norm(w, axis=-1)[..., None, None])
    K = skew(w)
    return np.eye(3) + a * K + b * (K @ K)


def so3_log(R: np.ndarray) -> np.ndarray:
    """Rotation matrix (..., 3, 3) → rotation vector (..., 3) [rad], angle in [0, π]."""
    cos = np.clip((np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    theta = np.arccos(cos)
    vee = np.stack(
        [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1
    )
    sin = np.sin(theta)
    small = theta < 1e-6
    scale = np.where(small, 0.5 + theta**2 / 12.0, theta / (2.0 * np.where(small, 1.0, sin)))
    w = scale[..., None] * vee
    # Near π the antisymmetric part vanishes; take the axis from the symmetric part instead.
    near_pi = theta > np.pi - 1e-4
    if np.any(near_pi):
        S = (R[near_pi] + np.swapaxes(R[near_pi], -1, -2)) / 2.0 - cos[
            near_pi, None, None
        ] * np.eye(3)
        k = np.argmax(np.diagonal(S, axis1=-2, axis2=-1), axis=-1)
        axis = np.take_along_axis(S, k[:, None, None], axis=-2)[:, 0, :]
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        sign = np.where(np.sum(axis * vee[near_pi], -1) < 0, -1.0, 1.0)
        w[near_pi] = sign[:, None] * axis * theta[near_pi, None]
    return w


def pose_to_transform(pose: np.ndarray) -> np.ndarray:
    """`[x, y, z, roll, pitch, yaw]` (..., 6) [m, rad] → homogeneous transform (..., 4, 4)."""
    T = np.zeros((*pose.shape[:-1], 4, 4))
    T[..., :3, :3] = rpy_to_matrix(pose[..., 3:])
    T[..., :3, 3] = pose[..., :3]
    T[..., 3, 3] = 1.0
    return T


def transform_to_pose(T: np.ndarray) -> np.ndarray:
    """Homogeneous transform (..., 4, 4) → `[x, y, z, roll, pitch, yaw]` (..., 6)."""
    return np.concatenate([T[..., :3, 3], matrix_to_rpy(T[..., :3, :3])], -1)


def invert_transform(T: np.ndarray) -> np.ndarray:
    """T⁻¹ for rigid transforms (..., 4, 4), using Rᵀ rather than a general inverse."""
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -(Rt @ T[..., :3, 3, None])[..., 0]
    out[..., 3, 3] = 1.0
    return out


def pose_error(T_target: np.ndarray, T: np.ndarray) -> np.ndarray:
    """e = x_d - x: position difference and rotation vector log(R_d Rᵀ), both in the parent frame.

    seed 000 eq (34) with SPEC erratum 6 (axis-angle, not Euler differences); (..., 6).
    """
    dp = T_target[..., :3, 3] - T[..., :3, 3]
    dw = so3_log(T_target[..., :3, :3] @ np.swapaxes(T[..., :3, :3], -1, -2))
    return np.concatenate([dp, dw], -1)


def matrix_to_wxyz(R: np.ndarray) -> np.ndarray:
    """Rotation matrix (..., 3, 3) → unit quaternion (..., 4), w first, w ≥ 0."""
    w = so3_log(R)
    theta = np.linalg.norm(w, axis=-1, keepdims=True)
    axis = np.where(theta > 1e-12, w / np.where(theta > 1e-12, theta, 1.0), 0.0)
    return np.concatenate([np.cos(theta / 2.0), axis * np.sin(theta / 2.0)], -1)


def se3_exp(twist: np.ndarray) -> np.ndarray:
    """Exponential map of a body twist `[v, ω]` (..., 6) [m, rad] → transform (..., 4, 4).

    T exp(ξ dt) integrates a constant body twist exactly: the rotation is Rodrigues, the
    translation V(ω) v with V = I + (1-cos θ)/θ² K + (θ-sin θ)/θ³ K² (Lynch & Park, Modern
    Robotics, eq (3.88)).
    """
    v, w = twist[..., :3], twist[..., 3:]
    _, b, c = _coefficients(np.linalg.norm(w, axis=-1)[..., None, None])
    K = skew(w)
    V = np.eye(3) + b * K + c * (K @ K)
    T = np.zeros((*twist.shape[:-1], 4, 4))
    T[..., :3, :3] = so3_exp(w)
    T[..., :3, 3] = (V @ v[..., None])[..., 0]
    T[..., 3, 3] = 1.0
    return T


def se3_log(T: np.ndarray) -> np.ndarray:
    """Inverse of `se3_exp`: transform (..., 4, 4) → body twist `[v, ω]` (..., 6)."""
    w = so3_log(T[..., :3, :3])
    theta = np.linalg.norm(w, axis=-1)[..., None, None]
    K = skew(w)
    d = np.vectorize(v_inverse_coefficient, otypes=[float])(theta)
    V_inv = np.eye(3) - 0.5 * K + d * (K @ K)  # Lynch & Park eq (3.92)
    return np.concatenate([(V_inv @ T[..., :3, 3, None])[..., 0], w], -1)


# One lane at a time, compiled (numba) or plain Python: the engine's kernels compose these.
# ---------------------------------------------------------------------------------------------


#: [rad] below this angle `v_inverse_coefficient` and `rodrigues_coefficients`' c are their
#: series: the closed forms subtract numbers within θ²/12 (θ²/6) of each other and divide by
#: θ², losing about 24ε/θ² (6ε/θ²) of the coefficient, relative; with the old switches at
#: 1e-6 and 1e-8 rad, se3_log ∘ se3_exp was 8e-8 m off a metre's twist at 1e-5 rad
SERIES_BELOW = 0.1


@register_inline
def v_inverse_coefficient(theta: float) -> float:
    """d(θ) of V⁻¹ = I − K/2 + d K², K = skew(ω), θ = |ω| [rad] (Lynch & Park eq (3.92)):
    (1 − (θ/2) cot(θ/2)) / θ² (= (1 − θ sin θ / (2(1 − cos θ))) / θ²), or below
    `SERIES_BELOW` its series 1/12 + θ²/720 + θ⁴/30240 + θ⁶/1209600 (the next term is under
    1e-13 of d there). Within 5e-13 of d, relative, for θ in (0, π) (tests/test_spatial.py)."""
    if theta < SERIES_BELOW:
        t2 = theta * theta
        return 1.0 / 12.0 + t2 * (1.0 / 720.0 + t2 * (1.0 / 30240.0 + t2 / 1209600.0))
    half = 0.5 * theta
    return (1.0 - half / math.tan(half)) / (theta * theta)


@register_inline
def rpy_to_matrix_lane(roll: float, pitch: float, yaw: float, R_out: np.ndarray) -> None:
    """ᴮR_P = Rz(yaw) Ry(pitch) Rx(roll) (seed 000 eq (3), `twin.spatial.rpy_to_matrix`).

    Args:
        roll, pitch, yaw: [rad].
        R_out: (3, 3) written.
    """
    cf, ct, cp = math.cos(roll), math.cos(pitch), math.cos(yaw)
    sf, st, sp = math.sin(roll), math.sin(pitch), math.sin(yaw)
    R_out[0, 0] = cp * ct
    R_out[0, 1] = cp * st * sf - sp * cf
    R_out[0, 2] = cp * st * cf + sp * sf
    R_out[1, 0] = sp * ct
    R_out[1, 1] = sp * st * sf + cp * cf
    R_out[1, 2] = sp * st * cf - cp * sf
    R_out[2, 0] = -st
    R_out[2, 1] = ct * sf
    R_out[2, 2] = ct * cf


@register_inline
def tilt_lane(x: float, y: float, z: float) -> float:
    """Angle [rad] between a direction (x, y, z) and the z axis of its frame (a body axis and
    inertial z up: a tilt), by atan2 of its horizontal and vertical parts, which resolves small
    angles that acos cannot."""
    return math.atan2(math.hypot(x, y), z)


#: `tilt_lane` over broadcast arrays
TILT = LaneUfunc(tilt_lane, 3)


@register_inline
def rpy_rate_entries(pitch: float, yaw: float) -> tuple[float, float, float, float, float]:
    """The entries of E(rpy) (ω = E d(rpy)/dt, ω in the parent frame) that are not 0 or 1: its
    roll column (cψ cθ, sψ cθ, −sθ) and the top of its pitch column (−sψ, cψ); the yaw column
    is e_z. For R = Rz(ψ)Ry(θ)Rx(φ): ω = ψ̇ e_z + θ̇ Rz e_y + φ̇ Rz Ry e_x; pitch θ, yaw ψ [rad].
    """
    ct, st = math.cos(pitch), math.sin(pitch)
    cp, sp = math.cos(yaw), math.sin(yaw)
    return cp * ct, sp * ct, -st, -sp, cp


@register_inline
def rpy_rates_lane(
    pitch: float, yaw: float, w0: float, w1: float, w2: float
) -> tuple[float, float, float]:
    """d(rpy)/dt = E(rpy)⁻¹ ω [rad/s] of an angular velocity ω (w0, w1, w2) [rad/s] in the
    parent frame (`rpy_rate_entries`' inverse): (cψ ω_x + sψ ω_y) / cθ, −sψ ω_x + cψ ω_y,
    ω_z + tθ (cψ ω_x + sψ ω_y); pitch θ, yaw ψ [rad], |θ| < π/2."""
    cy, sy = math.cos(yaw), math.sin(yaw)
    across = cy * w0 + sy * w1
    return across / math.cos(pitch), -sy * w0 + cy * w1, w2 + math.tan(pitch) * across


def _rpy_rate_batch(rpy: np.ndarray, E: np.ndarray) -> None:
    """E(rpy) (`rpy_rate_entries`) of rpy (N, 3) [rad] into E (N, 3, 3)."""
    for k in range(rpy.shape[0]):
        e00, e10, e20, e01, e11 = rpy_rate_entries(rpy[k, 1], rpy[k, 2])
        E[k, 0, 0], E[k, 0, 1], E[k, 0, 2] = e00, e01, 0.0
        E[k, 1, 0], E[k, 1, 1], E[k, 1, 2] = e10, e11, 0.0
        E[k, 2, 0], E[k, 2, 1], E[k, 2, 2] = e20, 0.0, 1.0


#: `rpy_rate_matrix` over a batch
RPY_RATE = LaneBatch(_rpy_rate_batch, cores=(1,))


@register_inline
def so3_log_lane(R: np.ndarray, w_out: np.ndarray) -> None:
    """Rotation vector [rad] of the rotation matrix R (3, 3), angle in [0, π]
    (`twin.spatial.so3_log`, including its near-π branch); written to w_out (3,)."""
    cos = (R[0, 0] + R[1, 1] + R[2, 2] - 1.0) / 2.0
    cos = min(max(cos, -1.0), 1.0)
    theta = math.acos(cos)
    v0, v1, v2 = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
    if theta < 1e-6:
        scale = 0.5 + theta**2 / 12.0
    else:
        scale = theta / (2.0 * math.sin(theta))
    w_out[0], w_out[1], w_out[2] = scale * v0, scale * v1, scale * v2
    if theta > math.pi - 1e-4:
        # the antisymmetric part vanishes near π: the axis is the symmetric part's largest row
        s00, s11, s22 = R[0, 0] - cos, R[1, 1] - cos, R[2, 2] - cos
        s01, s02 = (R[0, 1] + R[1, 0]) / 2.0, (R[0, 2] + R[2, 0]) / 2.0
        s12 = (R[1, 2] + R[2, 1]) / 2.0
        a0, a1, a2 = s00, s01, s02  # np.argmax: the first largest diagonal entry
        if s11 > s00 and s11 >= s22:
            a0, a1, a2 = s01, s11, s12
        elif s22 > s00 and s22 > s11:
            a0, a1, a2 = s02, s12, s22
        norm = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        a0, a1, a2 = a0 / norm, a1 / norm, a2 / norm
        sign = -1.0 if a0 * v0 + a1 * v1 + a2 * v2 < 0 else 1.0
        w_out[0], w_out[1], w_out[2] = sign * a0 * theta, sign * a1 * theta, sign * a2 * theta


@register_inline
def rpy_of_entries(
    r00: float, r10: float, r20: float, r21: float, r22: float
) -> tuple[float, float, float]:
    """(roll, pitch, yaw) [rad] of a rotation from the five entries `matrix_to_rpy` reads
    (R[0, 0], R[1, 0], R[2, 0], R[2, 1], R[2, 2]), pitch ∈ (−π/2, π/2): the one statement of
    the inverse of seed 000 eq (3) for the lanes, which often hold only those entries."""
    return (math.atan2(r21, r22), math.atan2(-r20, math.hypot(r21, r22)),
            math.atan2(r10, r00))  # fmt: skip


@register_borrowing
def matrix_to_rpy_lane(R: np.ndarray, out: np.ndarray) -> None:
    """[roll, pitch, yaw] [rad] of R (3, 3) on pitch ∈ (−π/2, π/2) (`twin.spatial.matrix_to_rpy`);
    written to out (3,)."""
    out[0], out[1], out[2] = rpy_of_entries(R[0, 0], R[1, 0], R[2, 0], R[2, 1], R[2, 2])


@register_inline
def rodrigues_coefficients(theta: float) -> tuple[float, float, float]:
    """(a, b, c) = (sin θ / θ, (1 − cos θ) / θ², (θ − sin θ) / θ³) of a rotation angle θ ≥ 0
    [rad]: exp(K) = I + a K + b K² (Rodrigues) and the SE(3) exponential's V = I + b K + c K²
    (Lynch & Park eq (3.88)), K = skew(ω) with |ω| = θ. Free of cancellation: b as
    (sin(θ/2) / (θ/2))² / 2, and c by its series below `SERIES_BELOW` (1/6 − θ²/120 + θ⁴/5040
    − θ⁶/362880; the closed form loses 6ε/θ² of c, relative). Each within 1e-13 of its exact
    value, relative (tests/test_spatial.py)."""
    if theta < 1e-8:
        return 1.0 - theta**2 / 6.0, 0.5 - theta**2 / 24.0, 1.0 / 6.0 - theta**2 / 120.0
    half = 0.5 * theta
    sinc_half = math.sin(half) / half
    if theta < SERIES_BELOW:
        t2 = theta * theta
        c = 1.0 / 6.0 - t2 * (1.0 / 120.0 - t2 * (1.0 / 5040.0 - t2 / 362880.0))
    else:
        c = (theta - math.sin(theta)) / theta**3
    return math.sin(theta) / theta, 0.5 * sinc_half * sinc_half, c


@register_borrowing
def so3_exp_lane(w0: float, w1: float, w2: float, R_out: np.ndarray) -> None:
    """Rodrigues (`twin.spatial.so3_exp`): rotation vector [rad] → R_out (3, 3)."""
    a, b, _ = rodrigues_coefficients(math.sqrt(w0 * w0 + w1 * w1 + w2 * w2))
    # I + a K + b K², K = skew(w), K² = w wᵀ − |w|² I
    R_out[0, 0] = 1.0 + b * (-w2 * w2 - w1 * w1)
    R_out[1, 1] = 1.0 + b * (-w2 * w2 - w0 * w0)
    R_out[2, 2] = 1.0 + b * (-w1 * w1 - w0 * w0)
    R_out[0, 1], R_out[1, 0] = -a * w2 + b * w0 * w1, a * w2 + b * w0 * w1
    R_out[0, 2], R_out[2, 0] = a * w1 + b * w0 * w2, -a * w1 + b * w0 * w2
    R_out[1, 2], R_out[2, 1] = -a * w0 + b * w1 * w2, a * w0 + b * w1 * w2


@register_borrowing
def se3_log_lane(R: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """`twin.spatial.se3_log` of the transform [R (3, 3), p (3,) [m]]: body twist [v; ω]
    (6,) [m, rad] into out, with V⁻¹ of Lynch & Park eq (3.92)."""
    so3_log_lane(R, out[3:])  # ω first: out's rotation rows
    w0, w1, w2 = out[3], out[4], out[5]
    d = v_inverse_coefficient(math.sqrt(w0 * w0 + w1 * w1 + w2 * w2))
    # V⁻¹ = I − K/2 + d K², K = skew(w)
    k00, k11, k22 = -w2 * w2 - w1 * w1, -w2 * w2 - w0 * w0, -w1 * w1 - w0 * w0
    k01, k02, k12 = w0 * w1, w0 * w2, w1 * w2
    out[0] = (1.0 + d * k00) * p[0] + (0.5 * w2 + d * k01) * p[1] + (-0.5 * w1 + d * k02) * p[2]
    out[1] = (-0.5 * w2 + d * k01) * p[0] + (1.0 + d * k11) * p[1] + (0.5 * w0 + d * k12) * p[2]
    out[2] = (0.5 * w1 + d * k02) * p[0] + (-0.5 * w0 + d * k12) * p[1] + (1.0 + d * k22) * p[2]

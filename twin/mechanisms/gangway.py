"""The 3-DOF slew / luff / telescopic gangway (seed 000 §3.3 and Table 2; seed 004 §2.3).

Joints q = [q1, q2, d3]: slew q1 [rad] about the platform z axis, luff q2 [rad] with q2 = 0
horizontal and q2 > 0 raising the tip, d3 [m] the absolute gangway length. In Table 2's
DH terms (SPEC erratum 3) θ1 = q1, θ2 = q2 + 90°, d3(DH) = d3. Frame 0 is the Stewart
platform frame P; the tip frame E is DH frame 3 (z along the gangway, x up at q = 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twin.batch import LaneBatch
from twin.compiled import register_borrowing, register_inline
from twin.errors import UnreachableError
from twin.mechanisms.limits import JOINT_PAST
from twin.validation import as_array


def dh_transform(a: ArrayLike, alpha: ArrayLike, d: ArrayLike, theta: ArrayLike) -> np.ndarray:
    """ⁱ⁻¹T_i of the modified (Craig) DH convention, seed 000 eq (9); broadcast → (..., 4, 4)."""
    a, alpha, d, theta = np.broadcast_arrays(*map(np.asarray, (a, alpha, d, theta)))
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    T = np.zeros((*ct.shape, 4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 3] = ct, -st, a
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st * ca, ct * ca, -sa, -d * sa
    T[..., 2, 0], T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = st * sa, ct * sa, ca, d * ca
    T[..., 3, 3] = 1.0
    return T


@dataclass(frozen=True)
class Gangway:
    """Seed 000 Table 1/2 and seed 004 §2.3 parameters; lengths [m], angles [rad].

    Attributes:
        d1: height of the gangway plane above the top hinge circle (Table 1).
        a1: offset between the luffing (swing) axis and the slew axis (Table 1).
        length_min: retracted gangway length, the DH d3 offset (Table 2).
        length_max: fully extended length (Table 1: 9.552 + 7 m).
        q1_limit: slew limit ± (Table 6).
        q2_limit: luff limit ± (Table 6).
        la, lb: fixed sides of the luffing-cylinder triangle (seed 004 eq (5)).
        ld: height of the cylinder's lower pivot (seed 004 Fig. 3; drawing only).
        phi1: fixed angle ϕ1 of seed 004 eq (5), not given there: 0 puts ϕ2 = 90° at
            q2 = 0, so q2 ∈ [-30°, 30°] maps to ϕ2 ∈ [60°, 120°], 60° clear of the collinear
            (dead) positions either way; stroke 1.456-2.289 m (docs/decisions.md).
    """

    d1: float = 3.106
    a1: float = 0.230
    length_min: float = 9.552
    length_max: float = 16.552
    q1_limit: float = np.deg2rad(30.0)
    q2_limit: float = np.deg2rad(30.0)
    la: float = 0.93
    lb: float = 1.678
    ld: float = 0.4
    phi1: float = 0.0

    @property
    def lower(self) -> np.ndarray:
        """Joint lower limits [q1, q2, d3] (Table 6, d3 absolute)."""
        return np.array([-self.q1_limit, -self.q2_limit, self.length_min])

    @property
    def upper(self) -> np.ndarray:
        """Joint upper limits [q1, q2, d3] (Table 6, d3 absolute)."""
        return np.array([self.q1_limit, self.q2_limit, self.length_max])

    def links(self, q: ArrayLike) -> np.ndarray:
        """Cumulative ⁰T_1, ⁰T_2, ⁰T_3 (..., 3, 4, 4) from Table 2 and eq (9)."""
        q = as_array(q, "q", (3,))
        zero = np.zeros(q.shape[:-1])
        half_pi = np.pi / 2
        T01 = dh_transform(0.0, 0.0, self.d1, q[..., 0])
        T12 = dh_transform(self.a1, half_pi, 0.0, q[..., 1] + half_pi)  # SPEC erratum 3
        T23 = dh_transform(zero, half_pi, q[..., 2], 0.0)
        T02 = T01 @ T12
        return np.stack([T01, T02, T02 @ T23], -3)

    def forward(self, q: ArrayLike) -> np.ndarray:
        """Tip transform ⁰T_3 = ᴾT_E (..., 4, 4) for joints q (..., 3); eq (10), in closed
        form by `gangway_tip_lane` lane by lane (`links` multiplies the DH chain out)."""
        q = as_array(q, "q", (3,))
        return GANGWAY_TIP([q], [float(self.d1), float(self.a1)], [(4, 4)])[0]

    def jacobian(self, q: ArrayLike) -> np.ndarray:
        """J_s (..., 6, 3): [ᴾṖ_E; ᴾω_E] = J_s [q̇1, q̇2, ḋ3], in frame 0 = P; eq (11), by
        `gangway_jacobian_lane` lane by lane."""
        q = as_array(q, "q", (3,))
        return GANGWAY_JACOBIAN([q], [float(self.d1), float(self.a1)], [(6, 3)])[0]

    def inverse(self, position: ArrayLike, *, check: bool = True) -> np.ndarray:
        """Joints q (..., 3) that put the tip at `position` (..., 3) [m] in frame P.

        Seed 004 eqs (7)-(8): θ1 = atan2(p_y, p_x), θ2 = atan2(p_x/cos θ1 - a1, d1 - p_z).
        For d3 seed 004 offers (d1 - p_z)/cos θ2 or (p_y - a1 s1)/(s1 s2), both singular
        at the working pose (θ1 = 0, θ2 = 90°); we use the equivalent, never-singular
        d3 = hypot(p_x/cos θ1 - a1, d1 - p_z). p_x/cos θ1 is written hypot(p_x, p_y), which
        equals it for |θ1| < 90°, the only branch the slew limits allow.

        Raises:
            UnreachableError: with `check`, when the joints leave the Table 6 limits.
        """
        p = as_array(position, "position", (3,))
        q = GANGWAY_INVERSE([p], [float(self.d1), float(self.a1)], [(3,)])[0]  # the lane's
        if check:
            bad = np.any(JOINT_PAST(q, self.lower, self.upper, 0.0) != 0.0, axis=-1)
            if np.any(bad):
                raise UnreachableError(
                    f"position {np.round(p[bad], 4).tolist()!r:.120} m needs gangway joints "
                    f"{np.round(q[bad], 4).tolist()!r:.120}, allowed [q1, q2, d3] in "
                    f"{np.round(self.lower, 4).tolist()} .. {np.round(self.upper, 4).tolist()}"
                )
        return q

    def cylinder_length(self, q2: ArrayLike) -> np.ndarray:
        """Luffing-cylinder length l_c [m] for luff angle q2 [rad]; seed 004 eq (5).

        ϕ3 = θ2 = q2 + π/2 is the luff joint's geometric angle (ϕ3 = π/2 horizontal).
        """
        q2 = as_array(q2, "q2")
        phi2 = np.pi - self.phi1 - (q2 + np.pi / 2)
        return np.sqrt(self.lb**2 + self.la**2 - 2 * self.la * self.lb * np.cos(phi2))

    def luff_from_cylinder(self, length: ArrayLike) -> np.ndarray:
        """Inverse of `cylinder_length`: q2 [rad] for a cylinder length [m] (law of cosines)."""
        length = as_array(length, "length")
        cos_phi2 = (self.lb**2 + self.la**2 - length**2) / (2 * self.la * self.lb)
        if np.any(np.abs(cos_phi2) > 1):
            raise UnreachableError(
                f"cylinder length {length.tolist()!r:.80} m impossible; allowed "
                f"({abs(self.lb - self.la):.3f}, {self.la + self.lb:.3f}) m"
            )
        return np.pi / 2 - self.phi1 - np.arccos(cos_phi2)


# ---------------------------------------------------------------------------------------------
# One lane (floats and small arrays, compiled by numba into the kernels that call them,
# `twin.compiled`; plain Python without numba)
# ---------------------------------------------------------------------------------------------

HALF_PI = math.pi / 2


@register_inline
def gangway_tip_lane(
    q1: float, q2: float, d3: float, d1: float, a1: float, G_out: np.ndarray
) -> None:
    """ᴾT_E, the gangway tip in the platform frame (Table 2 with θ2 = q2 + 90°, SPEC erratum 3;
    seed 000 eq (10), `Gangway.forward`) in closed form.

    Args:
        q1, q2: [rad] slew and luff; d3: [m] gangway length.
        d1, a1: [m] `Gangway.d1`, `Gangway.a1` (Table 1).
        G_out: (4, 4) written.
    """
    s1, c1 = math.sin(q1), math.cos(q1)
    s2, c2 = math.sin(q2 + HALF_PI), math.cos(q2 + HALF_PI)
    reach = a1 + d3 * s2
    G_out[0, 0], G_out[0, 1], G_out[0, 2], G_out[0, 3] = c1 * c2, s1, c1 * s2, c1 * reach
    G_out[1, 0], G_out[1, 1], G_out[1, 2], G_out[1, 3] = s1 * c2, -c1, s1 * s2, s1 * reach
    G_out[2, 0], G_out[2, 1], G_out[2, 2], G_out[2, 3] = s2, 0.0, -c2, d1 - d3 * c2
    G_out[3, 0], G_out[3, 1], G_out[3, 2], G_out[3, 3] = 0.0, 0.0, 0.0, 1.0


@register_inline
def gangway_jacobian_lane(G: np.ndarray, d3: float, a1: float, J: np.ndarray, column: int) -> None:
    """J_s (seed 000 eq (11), `Gangway.jacobian`): [ᴾṖ_E; ᴾω_E] = J_s [q̇1, q̇2, ḋ3] in P, into
    the columns column … column + 2 of J (≥ 6, ≥ column + 3).

    Args:
        G: (4, 4) ᴾT_E of the joints (`gangway_tip_lane`: its rotation holds the sines and
            cosines of q1 and θ2 = q2 + 90°).
        d3, a1: [m] the gangway length and `Gangway.a1`.
    """
    s1, c1, s2, c2 = G[0, 1], -G[1, 1], G[2, 0], -G[2, 2]
    c = column
    J[0, c], J[0, c + 1], J[0, c + 2] = -a1 * s1 - d3 * s1 * s2, d3 * c1 * c2, c1 * s2
    J[1, c], J[1, c + 1], J[1, c + 2] = a1 * c1 + d3 * c1 * s2, d3 * s1 * c2, s1 * s2
    J[2, c], J[2, c + 1], J[2, c + 2] = 0.0, d3 * s2, -c2
    J[3, c], J[3, c + 1], J[3, c + 2] = 0.0, s1, 0.0
    J[4, c], J[4, c + 1], J[4, c + 2] = 0.0, -c1, 0.0
    J[5, c], J[5, c + 1], J[5, c + 2] = 1.0, 0.0, 0.0


@register_borrowing
def gangway_inverse_lane(
    px: float, py: float, pz: float, d1: float, a1: float, q_out: np.ndarray
) -> None:
    """Gangway joints [q1, q2, d3] [rad, rad, m] into q_out (3,) that put the tip at ᴾp [m]
    in the platform frame: seed 004 eqs (7)-(8) as `Gangway.inverse` writes them
    (d3 = hypot(p_x/cos θ1 − a1, d1 − p_z), never singular), unchecked; d1, a1 [m] as in
    `gangway_tip_lane`."""
    rho = math.hypot(px, py) - a1
    height = d1 - pz
    q_out[0] = math.atan2(py, px)
    q_out[1] = math.atan2(rho, height) - math.pi / 2
    q_out[2] = math.hypot(rho, height)


def _tip_batch(q: np.ndarray, d1: float, a1: float, out: np.ndarray) -> None:
    """`gangway_tip_lane` over joints q (N, 3) into out (N, 4, 4)."""
    for k in range(q.shape[0]):
        gangway_tip_lane(q[k, 0], q[k, 1], q[k, 2], d1, a1, out[k])


def _jacobian_batch(q: np.ndarray, d1: float, a1: float, out: np.ndarray) -> None:
    """`gangway_jacobian_lane` over joints q (N, 3) into out (N, 6, 3)."""
    G = np.empty((4, 4))
    for k in range(q.shape[0]):
        gangway_tip_lane(q[k, 0], q[k, 1], q[k, 2], d1, a1, G)
        gangway_jacobian_lane(G, q[k, 2], a1, out[k], 0)


def _inverse_batch(p: np.ndarray, d1: float, a1: float, out: np.ndarray) -> None:
    """`gangway_inverse_lane` over tip positions p (N, 3) into out (N, 3)."""
    for k in range(p.shape[0]):
        gangway_inverse_lane(p[k, 0], p[k, 1], p[k, 2], d1, a1, out[k])


#: the lanes over a batch: what `Gangway.forward`, `Gangway.jacobian` and `Gangway.inverse` call
GANGWAY_TIP = LaneBatch(_tip_batch, cores=(1,))
GANGWAY_JACOBIAN = LaneBatch(_jacobian_batch, cores=(1,))
GANGWAY_INVERSE = LaneBatch(_inverse_batch, cores=(1,))

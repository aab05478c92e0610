r"""Limits that shape a velocity after the solve: seed 000's Algorithm 1 and rate limits."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twin.batch import LaneBatch
from twin.compiled import LaneUfunc, register_inline
from twin.planners.parameters import refuse


@dataclass(frozen=True)
class SlewPriority:
    r"""Seed 000 Algorithm 1 (secondary task 1): the slew joint takes the platform's yaw motion.

    The platform yaw rate ω_pz (column 5) and the slew rate q̇1 (column 6) turn the tip about
    the same axis (J_task columns 5 and 6 are equal, since the slew axis is P's z axis), so
    moving velocity between them leaves the tip untouched. Their sum w_1sum stays; the
    platform keeps ω_pz,hold of it and q̇1 takes the rest, up to ±q̇1,max, while q1 is inside
    its flexible range [q1,min + σ, q1,max − σ]; in the σ-wide protection bands q̇1's share is
    blended with a raised cosine; beyond the limits the platform takes it all.

    What the platform keeps (docs/decisions.md, "MTMP's yaw"):

    - `yaw_hold` = 1 (the default): ω_pz,hold = −tan(φ)·ω_py, the body yaw rate at which the
      platform's Euler yaw stays put. With R = Rz(ψ)Ry(θ)Rx(φ) (SPEC erratum 2),
      ψ̇ = (sin φ·ω_py + cos φ·ω_pz)/cos θ, which is zero exactly then. The paper's ψ_p is an
      Euler angle (Table 6: ±36°), and this reading keeps q1 within Table 7's ±1.25°.
    - `yaw_hold` = 0: ω_pz,hold = 0, Algorithm 1 as printed on the body rate ("w_pz = 0");
      the Euler yaw then drifts through roll and pitch cycles (rotations do not commute) and
      q1 follows it.
    - values between blend the two: ω_pz,hold = −yaw_hold·tan(φ)·ω_py.

    Attributes:
        q1_min, q1_max: [rad] slew limits (Table 6).
        sigma: [rad] critical protection angle σ.
        rate_max: [rad/s] q̇1,max.
        yaw_index, slew_index: columns of ω_pz and q̇1.
        yaw_hold: [-] 1 holds the platform's Euler yaw, 0 its body yaw rate (see above).
        roll_index, pitch_rate_index: the state's roll φ and the velocity's ω_py.
    """

    q1_min: float
    q1_max: float
    sigma: float
    rate_max: float
    yaw_index: int = 5
    slew_index: int = 6
    yaw_hold: float = 1.0
    roll_index: int = 3
    pitch_rate_index: int = 4

    def held_yaw_rate(self, xi: np.ndarray, v: np.ndarray) -> np.ndarray:
        """ω_pz,hold (...,) [rad/s]: the platform's share of w_1sum in the flexible range
        (`held_yaw_rate_lane`)."""
        roll, pitch_rate = xi[..., self.roll_index], v[..., self.pitch_rate_index]
        return np.asarray(HELD_YAW_RATE(self.yaw_hold, roll, pitch_rate))

    def __call__(self, xi: np.ndarray, v: np.ndarray) -> np.ndarray:
        """v (..., n) with w_1sum split between the platform yaw and the slew joint
        (`slew_priority_lane`)."""
        q1 = xi[..., self.slew_index]
        total = v[..., self.yaw_index] + v[..., self.slew_index]  # w_1sum
        free = total - self.held_yaw_rate(xi, v)  # what q̇1 may take
        slew = np.asarray(
            SLEW_PRIORITY(q1, free, self.q1_min, self.q1_max, self.sigma, self.rate_max)
        )
        out = v.copy()
        out[..., self.slew_index] = slew
        out[..., self.yaw_index] = total - slew
        return out

    def pack(self, record: np.void) -> None:
        """Switch a differential parameter record's `slew` on and write σ, q̇1,max, the slew
        limits and yaw_hold.

        Raises:
            TwinError: other columns than the platform yaw (5), slew (6), roll (3) and pitch
                rate (4), a yaw_hold that is not finite or σ ≤ 0.
        """
        columns = (self.yaw_index, self.slew_index, self.roll_index, self.pitch_rate_index)
        if columns != (5, 6, 3, 4):
            raise refuse(
                "Algorithm 1 on other columns than the platform yaw (5), slew (6), roll (3) "
                "and pitch rate (4)"
            )
        if not np.isfinite(self.yaw_hold):
            raise refuse(f"Algorithm 1 with yaw_hold = {self.yaw_hold!r} (must be finite)")
        if not self.sigma > 0:
            raise refuse(f"Algorithm 1 with σ = {self.sigma!r} (must be > 0)")
        record["slew"] = 1.0
        record["sigma"], record["slew_rate"] = self.sigma, self.rate_max
        record["q1_min"], record["q1_max"] = self.q1_min, self.q1_max
        record["yaw_hold"] = self.yaw_hold


@dataclass(frozen=True)
class VelocityLimit:
    """Scale the whole velocity so that no joint exceeds its rate limit.

    A common scale keeps the direction of motion, so the tip still moves the commanded way,
    only slower; the planner's closed loop (k_e) then recovers the lag.

    Attributes:
        maximum: (n,) [m/s | rad/s] per-joint rate limits.
    """

    maximum: np.ndarray

    def __call__(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(scaled v, scale (...,) in (0, 1]), by `velocity_limit_lane` lane by lane."""
        v = np.asarray(v, dtype=float)
        maximum = np.asarray(self.maximum, dtype=float)  # (n,), a float or batched (..., n)
        maximum = np.broadcast_to(maximum, np.broadcast_shapes(maximum.shape, v.shape[-1:]))
        scaled, scale = VELOCITY_LIMIT([v, maximum], [], [v.shape[-1:], ()])
        return scaled, scale

    def pack(self, record: np.void) -> None:
        """Switch a differential parameter record's `rate_limited` on and write `rate` (9,).

        Raises:
            TwinError: a maximum ≤ 0 (or NaN), or not broadcastable to the nine joints.
        """
        try:
            maximum = np.broadcast_to(np.asarray(self.maximum, dtype=float), (9,))
        except ValueError as exc:
            raise refuse(f"the rate limits {self.maximum!r:.80} (not of nine joints)") from exc
        if not np.all(maximum > 0):
            raise refuse(f"the rate limits {maximum.tolist()!r:.120} (must be > 0)")
        record["rate_limited"] = 1.0
        record["rate"] = maximum


# ---------------------------------------------------------------------------------------------
# One lane (floats and small arrays, compiled by numba into the engine's kernel,
# `twin.compiled`; plain Python without numba)
# ---------------------------------------------------------------------------------------------


@register_inline
def slew_priority_lane(
    q1: float, free: float, q1_min: float, q1_max: float, sigma: float, rate_max: float
) -> float:
    """q̇1 [rad/s] of seed 000 Algorithm 1 (`SlewPriority`) for one lane: `free` [rad/s], the
    part of w_1sum the slew joint may take (w_1sum − ω_pz,hold), clipped to ±q̇1,max in the
    flexible range (lines 2-7), blended by a raised cosine in the σ-wide bands (lines 8-11),
    0 beyond the limits; q1, q1_min, q1_max, sigma [rad], rate_max [rad/s]."""
    if q1 >= q1_min + sigma and q1 <= q1_max - sigma:  # lines 2-7
        return rate_max if free > rate_max else (-rate_max if free < -rate_max else free)
    if q1 > q1_min and q1 < q1_min + sigma:  # lines 8-9
        return 0.5 * free * (1.0 + math.cos((q1_min + sigma - q1) / sigma * math.pi))
    if q1 > q1_max - sigma and q1 < q1_max:  # lines 10-11
        return 0.5 * free * (1.0 + math.cos((q1 - q1_max + sigma) / sigma * math.pi))
    return 0.0


@register_inline
def held_yaw_rate_lane(yaw_hold: float, roll: float, pitch_rate: float) -> float:
    """ω_pz,hold = −yaw_hold·tan(φ)·ω_py [rad/s], what Algorithm 1 leaves the platform's body
    yaw rate (`SlewPriority`: yaw_hold = 1 holds its Euler yaw, 0 its body yaw rate); roll φ
    [rad], pitch rate ω_py [rad/s]."""
    if yaw_hold == 0.0:
        return 0.0
    return -yaw_hold * math.tan(roll) * pitch_rate


#: the lanes as ufuncs over broadcast arrays: what `SlewPriority` calls
SLEW_PRIORITY = LaneUfunc(slew_priority_lane, 6)
HELD_YAW_RATE = LaneUfunc(held_yaw_rate_lane, 3)


@register_inline
def velocity_limit_lane(v: np.ndarray, maximum: np.ndarray) -> float:
    """`VelocityLimit` on one lane: v (n,) [m/s | rad/s] scaled in place by one factor so that
    no |v_j| exceeds maximum[j] (n,) (the direction kept); the factor in (0, 1] returned (NaN,
    and v NaN, when v has a NaN)."""
    most, nan = 1.0, False
    for j in range(v.shape[0]):
        ratio_j = abs(v[j]) / maximum[j]
        if ratio_j != ratio_j:
            nan = True
        elif ratio_j > most:
            most = ratio_j
    scale = math.nan if nan else 1.0 / most
    for j in range(v.shape[0]):
        v[j] = v[j] * scale
    return scale


def _velocity_limit_batch(
    v: np.ndarray, maximum: np.ndarray, scaled: np.ndarray, scale: np.ndarray
) -> None:
    """`velocity_limit_lane` over velocities v (N, n) and limits (N, n) into scaled (N, n)
    and scale (N,)."""
    for k in range(v.shape[0]):
        for j in range(v.shape[1]):  # element by element: numba's slice copy compiles 10× longer
            scaled[k, j] = v[k, j]
        scale[k] = velocity_limit_lane(scaled[k], maximum[k])


#: the lane over a batch: what `VelocityLimit` calls
VELOCITY_LIMIT = LaneBatch(_velocity_limit_batch, cores=(1, 1))

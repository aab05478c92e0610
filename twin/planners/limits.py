r"""Limits that shape a velocity after the solve: seed 000's Algorithm 1 and rate limits."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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
        """ω_pz,hold (...,) [rad/s]: the platform's share of w_1sum in the flexible range."""
        if self.yaw_hold == 0.0:
            return np.zeros(np.shape(v)[:-1])
        return -self.yaw_hold * np.tan(xi[..., self.roll_index]) * v[..., self.pitch_rate_index]

    def __call__(self, xi: np.ndarray, v: np.ndarray) -> np.ndarray:
        q1 = xi[..., self.slew_index]
        total = v[..., self.yaw_index] + v[..., self.slew_index]  # w_1sum
        free = total - self.held_yaw_rate(xi, v)  # what q̇1 may take
        flexible = (q1 >= self.q1_min + self.sigma) & (q1 <= self.q1_max - self.sigma)
        slew_flexible = np.clip(free, -self.rate_max, self.rate_max)  # lines 2-7
        low_band = (q1 > self.q1_min) & (q1 < self.q1_min + self.sigma)  # lines 8-9
        high_band = (q1 > self.q1_max - self.sigma) & (q1 < self.q1_max)  # lines 10-11
        phase = np.where(
            low_band,
            (self.q1_min + self.sigma - q1) / self.sigma,
            (q1 - self.q1_max + self.sigma) / self.sigma,
        )
        slew_band = 0.5 * free * (1.0 + np.cos(phase * np.pi))
        slew = np.where(flexible, slew_flexible, np.where(low_band | high_band, slew_band, 0.0))
        out = v.copy()
        out[..., self.slew_index] = slew
        out[..., self.yaw_index] = total - slew
        return out


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
        """(scaled v, scale (...,) in (0, 1])."""
        ratio = np.max(np.abs(v) / self.maximum, axis=-1)
        scale = 1.0 / np.maximum(ratio, 1.0)
        return v * scale[..., None], scale

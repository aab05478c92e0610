r"""A small platform as its planner and rig see it (`PlatformModel`): three DOFs, the
actuator lengths (its state), their stroke and rate limits, and the level pose it keeps: the
3UPU_UP (seed 001) and the 4-UPR (seed 002) behind one interface, with the tolerances its
limit checks allow.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike

from twin.errors import ConvergenceError, TwinError
from twin.mechanisms import platforms
from twin.mechanisms.platforms import (
    FIT_MAX_ITER,
    MAX_LEGS,
    batch,
)
from twin.mechanisms.upr4 import Upr4
from twin.mechanisms.upu3up import Upu3Up
from twin.planners.platform_step import desired_lanes
from twin.spatial import pose_to_transform
from twin.validation import as_array, check_range

#: [mm, rad] the Upu3Up's limit checks allow seed 001's own forward-kinematics accuracy (§IV:
#: about 1e-2 mm and 1e-4°), so a state servoed onto a limit does not count as beyond it.
LENGTH_TOL, ANGLE_TOL = 1e-2, float(np.radians(1e-4))
#: [m] the Upr4's actuators stopped at a stroke end sit on it to rounding (`reached`)
AT_TOL = 1e-9


@dataclass(frozen=True)
class PlatformModel:
    """A small platform as its planner and rig see it: three DOFs, actuator lengths, limits.

    Attributes:
        mechanism: the `Upu3Up` (state (z [mm], α, β [rad])) or `Upr4` (state (z [m], roll,
            pitch [rad])).
        z_hold: [m] the Upr4's held platform height (default its home height z0); seed 002
            §4 needs no height control, so z stays where it starts. Unused by the Upu3Up,
            which compensates heave.
    """

    mechanism: Upu3Up | Upr4
    z_hold: float | None = None
    _envelope: Upu3Up | None = field(init=False, repr=False, compare=False)
    _geometry: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.mechanism, Upu3Up | Upr4):
            raise TwinError(
                f"PlatformModel needs a Upu3Up or Upr4, got {type(self.mechanism).__name__}"
            )
        envelope = None
        if isinstance(self.mechanism, Upu3Up):
            m = self.mechanism
            # Forward kinematics must find the pose wherever the hardware can go: the state
            # box is a planning limit (counted by `violations`), the UP limb's stroke and a
            # tilt short of π/2 (where Rx·Ry degenerates) are the hardware's.
            envelope = replace(
                m,
                heave_limit=min(m.l - m.leg_min, m.leg_max - m.l),
                tilt_limit=float(np.radians(85.0)),
            )
        else:
            z_hold = self.mechanism.z0 if self.z_hold is None else float(self.z_hold)
            object.__setattr__(self, "z_hold", z_hold)
        object.__setattr__(self, "_envelope", envelope)
        geometry = self.pack()
        geometry.setflags(write=False)
        object.__setattr__(self, "_geometry", geometry)

    @property
    def geometry(self) -> np.ndarray:
        """(1,) the `PLATFORM_GEOMETRY` record the lane functions read (`pack`), read-only."""
        return self._geometry

    @property
    def name(self) -> str:
        """Registry name, `"upu3up"` or `"upr4"`."""
        return "upu3up" if isinstance(self.mechanism, Upu3Up) else "upr4"

    @property
    def unit(self) -> float:
        """[m] one native length unit: 1e-3 (mm) for the Upu3Up, 1 for the Upr4."""
        return 1e-3 if isinstance(self.mechanism, Upu3Up) else 1.0

    @property
    def stroke(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high), each (n,) [native], the actuators' end stops."""
        m = self.mechanism
        if isinstance(m, Upu3Up):
            return np.full(3, m.leg_min), np.full(3, m.leg_max)
        return np.full(4, m.stroke_min), np.full(4, m.stroke_max)

    @property
    def n_legs(self) -> int:
        """Actuators: 3 UPU limbs (seed 001) or 4 UPR limbs (seed 002)."""
        return self.stroke[0].size

    def leg_lengths(self, state: ArrayLike) -> np.ndarray:
        """Actuator lengths (..., n) [native] of states (..., 3); seed 001 eqs (16)-(18),
        seed 002 eqs (15)-(18) (`twin.mechanisms.platforms.platform_kinematics`)."""
        return platforms.leg_lengths(self._geometry, as_array(state, "state", (3,)))

    def jacobian(self, state: ArrayLike) -> np.ndarray:
        """∂l/∂state (..., n, 3) [native/native, native/rad]; seed 001 eq (24), Upr4.jacobian
        (`twin.mechanisms.platforms.platform_kinematics`)."""
        return platforms.jacobian(self._geometry, as_array(state, "state", (3,)))

    def transform(self, state: ArrayLike) -> np.ndarray:
        """ᴮT_P (..., 4, 4) [m] of states (..., 3), the top's pose in the base frame.

        The Upu3Up's includes the coupled x/y displacement and yaw of seed 001 eq (13).
        """
        return pose_to_transform(self.mechanism.platform_pose(state))

    def desired_state(self, transform: ArrayLike) -> np.ndarray:
        r"""The state (..., 3) whose top best matches a desired ᴮT_P,d (..., 4, 4) [m].

        Only the top normal n = ᴮR_P,d e_z is kept (a level top in the inertial frame has
        n = ᴮR_Iᵀ e_z); yaw and the horizontal position are beyond the three DOFs.

        - Upu3Up: R e_z = (sin β, −sin α cos β, cos α cos β) for R = Rx(α)·Ry(β) (seed 001
          eq (11)), so β = asin n_x, α = atan2(−n_y, n_z). O1 = (l + z) n (eq (13)), so
          z = n·p_d − l, the point of the UP limb's line closest to p_d; for a held inertial
          pose it keeps O1's inertial height, since the line is then vertical.
        - Upr4: R e_z = (sin pitch cos roll, −sin roll, cos pitch cos roll) for
          R = Ry(pitch)·Rx(roll) (seed 002 eq (15)), so roll = −asin n_y,
          pitch = atan2(n_x, n_z); z = `z_hold`.

        The result is not clipped to the limits (`desired_batch` with `clip` does that);
        `desired_state_lane`.
        """
        T = as_array(transform, "transform", (4, 4))
        return self.desired_batch(T, clip=False)[0]

    def desired_batch(self, T: np.ndarray, clip: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(states (..., 3), lengths (..., n), clipped (...)) of desired poses T (..., 4, 4)
        (`desired_lanes`; lengths and clipped only with `clip`)."""
        shape = T.shape[:-2]
        rotations = np.ascontiguousarray(T[..., :3, :3]).reshape(-1, 9)
        positions = np.ascontiguousarray(T[..., :3, 3]).reshape(-1, 3)
        N = len(rotations)
        states, lengths = np.zeros((N, 3)), np.zeros((N, MAX_LEGS))
        clipped = np.zeros(N, dtype=np.bool_)
        z_hold = np.nan if self.z_hold is None else float(self.z_hold)
        batch(desired_lanes)(rotations, positions, z_hold, self._geometry, states, lengths,
                             clipped, clip)  # fmt: skip
        n = self.n_legs
        return states.reshape(*shape, 3), lengths[:, :n].reshape(*shape, n), clipped.reshape(shape)

    def fit(self, lengths: np.ndarray, guess: np.ndarray) -> np.ndarray:
        """Actual state (3,) of actuator lengths (n,) [native], warm-started at `guess` (3,)
        (`twin.mechanisms.platforms.platform_fit`).

        Upu3Up: seed 001's Newton-Raphson (`Upu3Up.forward`, eqs (20)-(24)) on the hardware
        envelope. Upr4: four limbs for three DOFs, so independently servoed lengths are in
        general slightly inconsistent; the rigid top takes the least-squares pose (the
        mismatch becomes internal force, not motion): Gauss-Newton on l(x) − L, the
        iteration of `Upr4.forward` without its consistency check.

        Raises:
            TwinError: lengths outside the stroke, or no state found (`ConvergenceError`).
        """
        lengths = as_array(lengths, "lengths", (self.n_legs,))
        guess = as_array(guess, "guess", (3,))
        low, high = self.stroke
        if self._envelope is not None:  # Upu3Up.forward's own check first
            check_range(lengths, "lengths [mm]", low[0], high[0])
        state, found = platforms.fit(self._geometry, lengths, guess)
        if not np.all(found):
            raise ConvergenceError(
                f"{self.name} pose of lengths {np.round(lengths, 6).tolist()} did not converge "
                f"within the envelope from {np.round(guess, 6).tolist()} (Newton-Raphson on the "
                f"Upu3Up, {FIT_MAX_ITER} Gauss-Newton steps on the Upr4)"
            )
        return state

    def pack(self) -> np.ndarray:
        """The platform as the lanes read it: the mechanism's `pack` (a (1,) array of one
        `PLATFORM_GEOMETRY` record, native units), the Upu3Up's envelope widened to the
        hardware's (`fit`)."""
        out = self.mechanism.pack()
        if self._envelope is not None:
            out[0]["envelope_low"], out[0]["envelope_high"] = self._envelope.state_limits
        return out

    def violations(
        self, state: ArrayLike, lengths: ArrayLike | None = None
    ) -> dict[str, np.ndarray]:
        """Limit name → (...) bool for states (..., 3), by the mechanism's own limits.

        Upr4: `Upr4.limits_violated` (stroke, U joints, collision eq (3)). Upu3Up: its
        `state_limits` box and the UPU stroke [leg_min, leg_max] (what
        `Upu3Up.leg_lengths(check=True)` enforces), within `LENGTH_TOL` and `ANGLE_TOL`; it
        has no U-joint or collision limit.

        With `lengths` (..., n) [native], the actuators' own lengths, the stroke is judged on
        them, not on the lengths of the state: the Upr4's four legs over-determine its three
        DOFs, so the legs of its least-squares state (`fit`) lie up to a few mm off the
        actuators', past the stroke while the actuators stand on their end stops.
        """
        state = as_array(state, "state", (3,))
        m = self.mechanism
        if isinstance(m, Upr4):
            out = m.limits_violated(state[..., 0], state[..., 1], state[..., 2])
            if lengths is None:
                return out
            tol = 0.0  # `limits_violated`'s own: strictly beyond the stroke
        else:
            box_low, box_high = m.state_limits
            margin = np.array([LENGTH_TOL, ANGLE_TOL, ANGLE_TOL])
            out = {"state": np.any((state < box_low - margin) | (state > box_high + margin),
                                   axis=-1)}  # fmt: skip
            tol = LENGTH_TOL
            if lengths is None:
                lengths = self.leg_lengths(state)
        lengths = as_array(lengths, "lengths", (self.n_legs,))
        low, high = self.stroke
        out["stroke_min"] = np.any(lengths < low - tol, axis=-1)
        out["stroke_max"] = np.any(lengths > high + tol, axis=-1)
        return out

    def reached(self, state: ArrayLike, lengths: ArrayLike) -> dict[str, np.ndarray]:
        """Limit name → (...) bool: at a limit or beyond it, for states (..., 3) and their
        actuator lengths (..., n) [native] (what `joint_limits="record"` counts).

        `violations` counts only what lies beyond a limit; here a value on it counts too, as
        the actuators stopped at their end stops or a state servoed onto its clipped demand
        sit there. Upu3Up: the state box and the stroke within `LENGTH_TOL` / `ANGLE_TOL` of
        the limit (seed 001's forward-kinematics accuracy). Upr4: the stroke within `AT_TOL`;
        its U joints and collision (eq (3)) are never clamped, so they count beyond only.
        """
        state = as_array(state, "state", (3,))
        lengths = as_array(lengths, "lengths", (self.n_legs,))
        out = dict(self.violations(state, lengths))
        low, high = self.stroke
        tol = LENGTH_TOL if isinstance(self.mechanism, Upu3Up) else AT_TOL
        out["stroke_min"] = out["stroke_min"] | np.any(lengths <= low + tol, axis=-1)
        out["stroke_max"] = out["stroke_max"] | np.any(lengths >= high - tol, axis=-1)
        if isinstance(self.mechanism, Upu3Up):
            box_low, box_high = self.mechanism.state_limits
            margin = np.array([LENGTH_TOL, ANGLE_TOL, ANGLE_TOL])
            on_box = (state <= box_low + margin) | (state >= box_high - margin)
            out["state"] = out["state"] | np.any(on_box, axis=-1)
        return out

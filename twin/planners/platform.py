r"""Small-platform planners: keep the top level by servoing the actuator lengths.

The 3UPU_UP (seed 001) and the 4-UPR (seed 002) have three DOFs each, (z, α, β) and
(z, roll, pitch). A planner takes the desired top pose in the base frame as a `TipTarget`,
keeps from it what the three DOFs can do (`PlatformModel.desired_state`), turns that into
desired actuator lengths l_d by inverse kinematics and servoes the actuators towards them:

- ``pid``, seed 002's position loop (§5, Fig. 11): PID on the length error e = l_d(t) − l,
  with anti-windup; reactive, like the paper's, so it lags the waves by about 1/kp. Its
  proportional term is the continuous loop ė = −kp e sampled exactly (zero-order hold,
  gain (1 − e^(−kp·dt))/dt), stable at every control period. With `actuator_mass` > 0 the
  actuators are instead effort-driven masses under seed 002's Gazebo PID
  (`PlatformPlanner.actuate`);
- ``ik``, an ideal position servo with the target's one-step preview:
  l̇ = (l_d(t + dt) − l) / dt, l_d(t + dt) from the target advanced by its twist over dt (the
  predictive control seed 002 §5 recommends).

When an actuator would exceed `actuator_speed` (seed 002 §5: 0.1 m/s), the tilt keeps
priority over the heave (`PlatformPlanner.limit`): keeping the top level is the task.

Units: lengths are in the mechanism's own unit — mm for the Upu3Up, as seed 001 and `Upu3Up`,
m for the Upr4 — so actuator rates are mm/s and m/s; `PlatformModel.unit` converts. Targets
are in metres, like every `TipTarget`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from twin.batch import LaneBatch
from twin.compiled import register_jitable
from twin.errors import ConvergenceError, TwinError
from twin.mechanisms import platforms
from twin.mechanisms.newton import least_squares_lane
from twin.mechanisms.platforms import (
    FIT_MAX_ITER,
    MAX_LEGS,
    MECHANISM_UPU3UP,
    NewtonWork,
    batch,
    newton_work,
    platform_fit,
    platform_kinematics,
)
from twin.mechanisms.upr4 import Upr4
from twin.mechanisms.upu3up import Upu3Up
from twin.planners.gains import proportional_gain
from twin.planners.parameters import (
    KIND_PLATFORM,
    PlannerParameters,
    family_dtype,
    parameter_record,
    parameter_row,
)
from twin.planners.target import PlannerOutput, TipTarget
from twin.spatial import pose_to_transform, so3_exp_lane
from twin.validation import as_array, check_range

LAWS = ("ik", "pid")
#: `PLATFORM_PARAMETERS["law"]` of each law
LAW_IK, LAW_PID = 0, 1
#: [mm, rad] the Upu3Up's limit checks allow seed 001's own forward-kinematics accuracy (§IV:
#: about 1e-2 mm and 1e-4°), so a state servoed onto a limit does not count as beyond it.
LENGTH_TOL, ANGLE_TOL = 1e-2, float(np.radians(1e-4))
#: [m] the Upr4's actuators stopped at a stroke end sit on it to rounding (`reached`)
AT_TOL = 1e-9
#: Seed 002 §5's effort PID, tuned in Gazebo: kp [N/m], ki [N/(m·s)], kd [N·s/m].
EFFORT_KP, EFFORT_KI, EFFORT_KD = 5000.0, 0.5, 10.0
#: [s] longest step of the actuator dynamics within a control period (Gazebo's default 1 ms
#: physics step, at which its controllers run too).
PHYSICS_STEP = 1e-3


@register_jitable
def physics_steps(dt: float) -> int:
    """Steps of the actuator dynamics in a control period dt [s]: the fewest of ≤ 1 ms."""
    return max(1, int(np.ceil(dt / PHYSICS_STEP - 1e-9)))


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


def advance_target(target: TipTarget, dt: float) -> np.ndarray:
    """ᴮT_P,d(t + dt) (..., 4, 4): the target moved by its twist, held constant over dt.

    The twist's ω is the desired frame's angular velocity expressed in B, Ṙ_d = [ω]× R_d, so
    R_d(t + dt) = exp(ω dt) R_d; p_d(t + dt) = p_d + ṗ_d dt. With the simulation's targets,
    whose twist is the mean rate to the next sample (`twin.sim.target.held_targets`), this is
    that next sample exactly. By `advance_target_lane` lane by lane (`ADVANCE`), the step the
    engine's "ik" law takes.
    """
    return ADVANCE([target_rows(target)], [float(dt)], [(4, 4)])[0]


#: A platform planner's knobs as the engine's kernel reads them (`PlatformPlanner.pack`): the
#: law (`LAW_*`), kp [1/s], ki [1/s²], kd [-], the speed limit [native/s] (`speed_limit`), the
#: Upr4's held height z_hold [m] (NaN for the Upu3Up), the actuators' moving mass [kg] (0:
#: velocity-commanded; `actuate`) and their top speed [m/s] (`actuator_speed`).
PLATFORM_PARAMETERS = family_dtype(
    (
        ("law", 1),
        ("kp", 1),
        ("ki", 1),
        ("kd", 1),
        ("speed_limit", 1),
        ("z_hold", 1),
        ("mass", 1),
        ("speed", 1),
    )
)
#: A platform planner's state carried from step to step (`PlatformPlanner.pack_memory`): the
#: PID integral ∫e dt [native·s], the previous error e [native], whether there is one (1.0)
#: or the next derivative starts from zero (0.0), the effort-driven actuators' velocity
#: [native/s]; MAX_LEGS values each.
PLATFORM_MEMORY = np.dtype(
    [
        ("integral", np.float64, (MAX_LEGS,)),
        ("previous", np.float64, (MAX_LEGS,)),
        ("has_previous", np.float64),
        ("velocity", np.float64, (MAX_LEGS,)),
    ]
)
#: float64 values of a lane's memory row that `PLATFORM_MEMORY` covers
MEMORY_SIZE = PLATFORM_MEMORY.itemsize // 8


def memory_record(row: np.ndarray) -> np.void:
    """A lane's float memory row (≥ MEMORY_SIZE,) seen as one `PLATFORM_MEMORY` record:
    writing a field writes the row."""
    return row[:MEMORY_SIZE].view(PLATFORM_MEMORY)[0]


# One lane (floats and small arrays; compiled by numba into the engine's kernel and the
# objects' batch loops, `twin.compiled`; plain Python without numba): the control laws.


@register_jitable
def desired_state_lane(
    R_d: np.ndarray, p_d: np.ndarray, z_hold: float, g: np.void, state: np.ndarray
) -> None:
    """`PlatformModel.desired_state` of ᴮT_P,d (R_d (9,) row-major, p_d (3,) [m]) into state
    (3,), not clipped; g: the `PLATFORM_GEOMETRY` record; z_hold [m] the Upr4's height.

    From the top normal n = ᴮR_P,d e_z: Upu3Up β = asin n_x, α = atan2(−n_y, n_z) (seed 001
    eq (11)), z = n·p_d / unit − l (eq (13)); Upr4 roll = −asin n_y, pitch = atan2(n_x, n_z)
    (seed 002 eq (15)), z = z_hold.
    """
    nx, ny, nz = R_d[2], R_d[5], R_d[8]  # third column of ᴮR_P,d
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    nx, ny, nz = nx / norm, ny / norm, nz / norm
    if g["mechanism"] == MECHANISM_UPU3UP:
        along = nx * p_d[0] + ny * p_d[1] + nz * p_d[2]
        state[0] = along / g["unit"] - g["l"]  # seed 001 eq (13)
        state[1] = np.arctan2(-ny, nz)
        state[2] = np.arcsin(min(max(nx, -1.0), 1.0))
    else:
        state[0] = z_hold
        state[1] = -np.arcsin(min(max(ny, -1.0), 1.0))
        state[2] = np.arctan2(nx, nz)


@register_jitable
def desired_lane(
    R_d: np.ndarray,
    p_d: np.ndarray,
    z_hold: float,
    g: np.void,
    state: np.ndarray,
    lengths: np.ndarray,
    R: np.ndarray,
    o: np.ndarray,
    J: np.ndarray,
) -> bool:
    """`PlatformPlanner.desired` of ᴮT_P,d (R_d (9,) row-major, p_d (3,) [m]): the desired
    state (3,) clipped to the state limits into `state`, its lengths (n,) clipped to the
    stroke into `lengths` [native]; returns whether anything was clipped. g: the
    `PLATFORM_GEOMETRY` record; z_hold [m] the Upr4's height; R, o, J scratch.
    The state is `desired_state_lane`'s, its lengths `platform_kinematics`' (seed 001 eqs
    (16)-(18), seed 002 eqs (15)-(18)).
    """
    desired_state_lane(R_d, p_d, z_hold, g, state)
    clipped = False
    for j in range(3):
        value = min(max(state[j], g["state_low"][j]), g["state_high"][j])
        clipped = clipped or value != state[j]
        state[j] = value
    platform_kinematics(state, g, R, o, lengths, J, False)
    for i in range(g["n_legs"]):
        value = min(max(lengths[i], g["stroke_low"]), g["stroke_high"])
        clipped = clipped or value != lengths[i]
        lengths[i] = value
    return clipped


@register_jitable
def advance_target_lane(
    R_d: np.ndarray,
    p_d: np.ndarray,
    twist: np.ndarray,
    dt: float,
    R_out: np.ndarray,
    p_out: np.ndarray,
    E: np.ndarray,
) -> None:
    """`advance_target` of one target (R_d (9,) row-major, p_d (3,) [m], twist (6,) [m/s,
    rad/s]) over dt [s]: R_d ← exp(ω dt) R_d (`so3_exp_lane`) into R_out (9,), p_d ← p_d + ṗ_d dt
    into p_out (3,); E (≥ 3, ≥ 3) scratch."""
    so3_exp_lane(twist[3] * dt, twist[4] * dt, twist[5] * dt, E)
    for j in range(3):
        d0, d1, d2 = R_d[j], R_d[3 + j], R_d[6 + j]
        for i in range(3):
            R_out[3 * i + j] = E[i, 0] * d0 + E[i, 1] * d1 + E[i, 2] * d2
        p_out[j] = p_d[j] + twist[j] * dt


@register_jitable
def limit_lane(
    command: np.ndarray,
    lengths: np.ndarray,
    guess: np.ndarray,
    speed: float,
    g: np.void,
    velocity: np.ndarray,
    x: np.ndarray,
    w: NewtonWork,
) -> bool:
    """`PlatformPlanner.limit`: rates (n,) [native/s] within ±speed [native/s] into
    `velocity`; returns whether the limit bound. x, w: scratch (w.step the split's rates).

    Beyond the limit, the command c is split at the pose of `lengths` (`platform_fit` from
    `guess`; `guess` itself where that fails) into tilt and heave parts, ṡ = J⁺ c,
    c = J ṡ_tilt + J ṡ_heave: the tilt part whole if it fits, scaled uniformly if not; the
    heave part the largest share σ ∈ [0, 1] that fits.
    """
    n = g["n_legs"]
    peak = 0.0
    for i in range(n):
        if not np.isfinite(command[i]):  # not reached with a finite target: pass it on
            peak = -1.0
            break
        peak = max(peak, abs(command[i]))
    if peak <= speed:
        for i in range(n):
            velocity[i] = command[i]
        return False
    if not platform_fit(lengths, guess, g, x, w):
        for j in range(3):
            x[j] = guess[j]  # no pose from the encoders: split at the desired state instead
    R, J, M, rates = w.R, w.J, w.M, w.step
    platform_kinematics(x, g, R, w.o, w.residual, J, True)
    if not least_squares_lane(J, command, n, M, rates):
        for j in range(3):
            rates[j] = np.nan
    tilt_peak = 0.0
    for i in range(n):
        tilt = J[i, 1] * rates[1] + J[i, 2] * rates[2]
        velocity[i] = tilt
        tilt_peak = max(tilt_peak, abs(tilt))
    if tilt_peak >= speed:
        scale = speed / tilt_peak
        for i in range(n):
            velocity[i] = velocity[i] * scale
        return True
    share = 1.0
    for i in range(n):
        heave = J[i, 0] * rates[0]
        if heave > 0:
            share = min(share, (speed - velocity[i]) / heave)
        elif heave < 0:
            share = min(share, (-speed - velocity[i]) / heave)
    share = min(1.0, max(0.0, share))
    for i in range(n):
        velocity[i] = velocity[i] + share * (J[i, 0] * rates[0])
    return True


@register_jitable
def actuate_lane(
    l_d: np.ndarray,
    legs: np.ndarray,
    mass: float,
    top: float,
    g: np.void,
    dt: float,
    integral: np.ndarray,
    actuator_velocity: np.ndarray,
    rates: np.ndarray,
) -> bool:
    """`PlatformPlanner.actuate`: effort-driven actuators (mass [kg] each, top speed [m/s])
    under seed 002's Gazebo PID over dt [s], the desired lengths l_d (n,) held; the mean rates
    of their travel into `rates` (n,) [native/s]; returns whether the speed limit bound.
    `integral` (n,) [native·s] and `actuator_velocity` (n,) [native/s] carry over, updated.

    Per step h = dt / n_h (`physics_steps`): ∫e += e h; the spring and the damper implicitly,
    u⁺ = (m/h u + K_p e + K_i ∫e) / (m/h + K_d + h K_p); |u⁺| ≤ top; x⁺ = x + h u⁺, stopped at
    the stroke's ends (u⁺ = 0 there); all in metres, the travel x − x₀ summed apart from x₀.
    """
    unit = g["unit"]
    n_h = physics_steps(dt)
    h = dt / n_h
    inertia = mass / h  # [kg/s]
    low, high = g["stroke_low"] * unit, g["stroke_high"] * unit
    saturated = False
    for i in range(g["n_legs"]):
        start = legs[i] * unit
        travel = 0.0
        u = actuator_velocity[i] * unit
        accumulated = integral[i] * unit
        goal = l_d[i] * unit
        for _ in range(n_h):
            e = goal - (start + travel)
            accumulated = accumulated + e * h
            u = (inertia * u + EFFORT_KP * e + EFFORT_KI * accumulated) / (
                inertia + EFFORT_KD + h * EFFORT_KP
            )
            if abs(u) > top:
                saturated = True
            u = min(max(u, -top), top)
            travel = travel + h * u
            x = start + travel
            if x < low:
                travel, u = low - start, 0.0
            elif x > high:
                travel, u = high - start, 0.0
        actuator_velocity[i] = u / unit
        integral[i] = accumulated / unit
        rates[i] = travel / unit / dt
    return saturated


@register_jitable
def plan_lane(
    R_d: np.ndarray,
    p_d: np.ndarray,
    twist: np.ndarray,
    legs: np.ndarray,
    p: np.void,
    m: np.void,
    g: np.void,
    dt: float,
    velocity: np.ndarray,
    work: np.ndarray,
    R: np.ndarray,
    J: np.ndarray,
    M: np.ndarray,
) -> tuple[bool, bool]:
    """`PlatformPlanner.step` on a finite target (R_d (9,), p_d (3,) [m], twist (6,)) and
    actuator lengths legs (n,) [native]: rates (n,) [native/s] into `velocity`; returns
    (clipped, saturated). p, m, g: the `PLATFORM_PARAMETERS`, `PLATFORM_MEMORY` (updated) and
    `PLATFORM_GEOMETRY` records; work (8, 18), R (3, 3), J (4, 3), M (3, 4) scratch.

    "ik": l̇ = (l_d(t + dt) − l) / dt, the target advanced by its twist; "pid": kp e + ki ∫e
    + kd ė with e = l_d − l and the sampled kp (`proportional_gain`), or the effort-driven
    actuators (`actuate_lane`); then the speed limit (`limit_lane`) and the PID's
    conditional integration (anti-windup).
    """
    ahead, o, state_d, l_d, l_next = work[0], work[1], work[2], work[3], work[4]
    command, scratch = work[5], work[7]
    fit_x, residual, rates = scratch[0:3], scratch[4:8], scratch[8:11]
    n = g["n_legs"]
    clipped = desired_lane(R_d, p_d, p["z_hold"], g, state_d, l_d, R, o, J)
    pid = p["law"] == LAW_PID
    if pid and p["mass"] > 0.0:  # effort-driven actuators
        saturated = actuate_lane(l_d, legs, p["mass"], p["speed"], g, dt, m["integral"],
                                 m["velocity"], velocity)  # fmt: skip
        return clipped, saturated
    if pid:
        has_previous = m["has_previous"] != 0.0
        kp, ki, kd = proportional_gain(p["kp"], dt), p["ki"], p["kd"]
        for i in range(n):
            error = l_d[i] - legs[i]
            previous = m["previous"][i] if has_previous else error
            command[i] = kp * error + ki * m["integral"][i] + kd * (error - previous) / dt
    else:
        advance_target_lane(R_d, p_d, twist, dt, ahead[0:9], ahead[9:12], M)
        ahead_clipped = desired_lane(ahead[0:9], ahead[9:12], p["z_hold"], g, scratch, l_next,
                                     R, o, J)  # fmt: skip
        clipped = clipped or ahead_clipped
        for i in range(n):
            command[i] = (l_next[i] - legs[i]) / dt  # reach l_d(t + dt) in one step
    newton = NewtonWork(R, o, residual, J, M, rates)
    saturated = limit_lane(command, legs, state_d, p["speed_limit"], g, velocity, fit_x, newton)
    if pid:  # anti-windup by conditional integration: no integral while the limit binds
        for i in range(n):
            error = l_d[i] - legs[i]
            if not saturated:
                m["integral"][i] = m["integral"][i] + error * dt
            m["previous"][i] = error
        m["has_previous"] = 1.0
    return clipped, saturated


# Batch loops: the objects' API over the same lane functions, compiled lazily on first use and
# cached on disk (`twin.mechanisms.platforms.batch`; plain Python without numba).


def desired_lanes(
    rotations: np.ndarray,
    positions: np.ndarray,
    z_hold: float,
    geometry: np.ndarray,
    states: np.ndarray,
    lengths: np.ndarray,
    clipped: np.ndarray,
    clip: bool,
) -> None:
    """`desired_lane` (clip) or `desired_state_lane` of rotations (N, 9) and positions (N, 3)
    into states (N, 3), lengths (N, MAX_LEGS) and clipped (N,) bool."""
    R, o, J = np.zeros((3, 3)), np.zeros(3), np.zeros((MAX_LEGS, 3))
    for k in range(states.shape[0]):
        if clip:
            clipped[k] = desired_lane(rotations[k], positions[k], z_hold, geometry[0], states[k],
                                      lengths[k], R, o, J)  # fmt: skip
        else:
            desired_state_lane(rotations[k], positions[k], z_hold, geometry[0], states[k])


def plan_lanes(
    targets: np.ndarray,
    legs: np.ndarray,
    prm: np.ndarray,
    memory: np.ndarray,
    geometry: np.ndarray,
    dt: float,
    velocity: np.ndarray,
    work: np.ndarray,
    flags: np.ndarray,
) -> None:
    """`plan_lane` of targets (N, 18) (ᴮR_d row-major, ᴮp_d, twist) and lengths (N, n): rates
    into velocity (N, n), its scratch into work (N, 8, 18) (row 2 the desired state, row 3 the
    desired lengths), clipped + 2 saturated into flags (N,); prm (N,) and memory (N,) records."""
    R, J, M = np.zeros((3, 3)), np.zeros((MAX_LEGS, 3)), np.zeros((3, 4))
    for k in range(targets.shape[0]):
        target = targets[k]
        clipped, saturated = plan_lane(target[0:9], target[9:12], target[12:18], legs[k], prm[k],
                                       memory[k], geometry[0], dt, velocity[k], work[k], R, J,
                                       M)  # fmt: skip
        flags[k] = (1 if clipped else 0) + (2 if saturated else 0)


def limit_lanes(
    commands: np.ndarray,
    lengths: np.ndarray,
    guesses: np.ndarray,
    speed: float,
    geometry: np.ndarray,
    velocity: np.ndarray,
    bound: np.ndarray,
) -> None:
    """`limit_lane` of commands (N, n) at lengths (N, n) from guesses (N, 3) into velocity
    (N, n) and bound (N,) bool."""
    x, w = np.zeros(3), newton_work()
    for k in range(commands.shape[0]):
        bound[k] = limit_lane(commands[k], lengths[k], guesses[k], speed, geometry[0],
                              velocity[k], x, w)  # fmt: skip


def actuate_lanes(
    l_d: np.ndarray,
    legs: np.ndarray,
    mass: float,
    top: float,
    geometry: np.ndarray,
    dt: float,
    integral: np.ndarray,
    actuator_velocity: np.ndarray,
    rates: np.ndarray,
    saturated: np.ndarray,
) -> None:
    """`actuate_lane` of desired lengths l_d (N, n) from legs (N, n): integral and
    actuator_velocity (N, n) updated, rates (N, n) and saturated (N,) bool written."""
    for k in range(l_d.shape[0]):
        saturated[k] = actuate_lane(l_d[k], legs[k], mass, top, geometry[0], dt, integral[k],
                                    actuator_velocity[k], rates[k])  # fmt: skip


def _advance_batch(rows: np.ndarray, dt: float, T: np.ndarray) -> None:
    """`advance_target_lane` of target rows (N, 18) (`target_rows`) over dt [s] into T (N, 4, 4)."""
    E = np.zeros((3, 3))
    R, p = np.zeros(9), np.zeros(3)
    for k in range(rows.shape[0]):
        advance_target_lane(rows[k, 0:9], rows[k, 9:12], rows[k, 12:18], dt, R, p, E)
        for i in range(3):
            for j in range(3):
                T[k, i, j] = R[3 * i + j]
            T[k, i, 3] = p[i]
            T[k, 3, i] = 0.0
        T[k, 3, 3] = 1.0


#: the lane over a batch of targets: what `advance_target` calls
ADVANCE = LaneBatch(_advance_batch, cores=(1,))


def target_rows(target: TipTarget) -> np.ndarray:
    """A target's rows (..., 18): ᴮR_d row-major (9), ᴮp_d [m] (3), twist [m/s, rad/s] (6)."""
    T = np.asarray(target.transform, dtype=float)
    twist = np.broadcast_to(target.twist, (*T.shape[:-2], 6))
    rotation = T[..., :3, :3].reshape(*T.shape[:-2], 9)
    return np.ascontiguousarray(np.concatenate([rotation, T[..., :3, 3], twist], -1))


class PlatformPlanner:
    """Servo a small platform's actuators towards the level pose of the target.

    The planner's state is the actuator lengths (the encoders, seed 002 §5); its velocity the
    actuator rates (n,) [native/s], each within ±`actuator_speed`. A non-finite target gives
    a NaN velocity, which the simulation treats as a fault.

    With `actuator_mass` > 0 (law `"pid"`) the actuators are not velocity-commanded but
    effort-driven: each is a moving mass pushed by seed 002's Gazebo PID (`actuate`), and the
    rate returned is the mean rate over the step of where that mass went.

    Args:
        model: the platform.
        law: `"ik"` (ideal position servo) or `"pid"` (seed 002's PID position loop).
        actuator_speed: [m/s] each actuator's speed limit (seed 002 §5: 0.1 m/s).
        kp: [1/s] proportional gain (`"pid"`), sampled exactly (`proportional_gain`).
        ki: [1/s²] integral gain (`"pid"`).
        kd: [-] derivative gain (`"pid"`).
        actuator_mass: [kg] moving mass per actuator of the effort-driven model (`"pid"`);
            0 for velocity-commanded actuators.
    """

    #: the kernel family it packs for (`twin.planners.families.FAMILY_DIAGNOSTICS`)
    family: ClassVar[str] = "platform"

    def __init__(
        self,
        model: PlatformModel,
        law: str,
        actuator_speed: float,
        kp: float = 0.0,
        ki: float = 0.0,
        kd: float = 0.0,
        actuator_mass: float = 0.0,
    ) -> None:
        if law not in LAWS:
            raise TwinError(f"PlatformPlanner law: unknown {law!r}; allowed: {list(LAWS)}")
        if not (np.isfinite(actuator_speed) and actuator_speed > 0):
            raise TwinError(f"actuator_speed must be > 0 m/s, got {actuator_speed!r}")
        for name, gain in (("kp", kp), ("ki", ki), ("kd", kd), ("actuator_mass", actuator_mass)):
            if not (np.isfinite(gain) and gain >= 0):
                raise TwinError(f"{name} must be finite and >= 0, got {gain!r}")
        self.model = model
        self.law = law
        self.actuator_speed = float(actuator_speed)
        self.kp, self.ki, self.kd = float(kp), float(ki), float(kd)
        self.actuator_mass = float(actuator_mass)
        self.integral = np.zeros(model.n_legs)  # [native · s] ∫e dt
        self.actuator_velocity = np.zeros(model.n_legs)  # [native/s] the masses' (`actuate`)
        self._previous_error: np.ndarray | None = None

    @property
    def dynamic(self) -> bool:
        """Whether the actuators are the effort-driven masses of `actuate`."""
        return self.law == "pid" and self.actuator_mass > 0

    def __repr__(self) -> str:
        gains = f", kp={self.kp}, ki={self.ki}, kd={self.kd}" if self.law == "pid" else ""
        if self.dynamic:
            gains = f", actuator_mass={self.actuator_mass}"
        return (
            f"PlatformPlanner({self.model.name}, law={self.law!r}, "
            f"actuator_speed={self.actuator_speed}{gains})"
        )

    @property
    def speed_limit(self) -> float:
        """[native/s] `actuator_speed` in the mechanism's length unit."""
        return self.actuator_speed / self.model.unit

    def pack(self, hold: bool) -> np.ndarray:
        """The lane's parameter row (ROW_SIZE,): a `PLATFORM_PARAMETERS` record filled by name.
        `hold` (the scenario's joint-limit mode) is recorded but unused: the actuators' end
        stops always hold."""
        row = parameter_row(KIND_PLATFORM, hold)
        p = parameter_record(row, PLATFORM_PARAMETERS)
        p["law"] = LAW_PID if self.law == "pid" else LAW_IK
        p["kp"], p["ki"], p["kd"] = self.kp, self.ki, self.kd
        p["speed_limit"] = self.speed_limit
        z_hold = self.model.z_hold
        p["z_hold"] = np.nan if z_hold is None else float(z_hold)
        p["mass"] = self.actuator_mass if self.dynamic else 0.0
        p["speed"] = self.actuator_speed
        return row

    def pack_memory(self, row: np.ndarray) -> None:
        """Write the planner's state (after `reset` or steps) into a lane's memory row
        (≥ MEMORY_SIZE,) by name (`PLATFORM_MEMORY`)."""
        m = memory_record(row)
        n = self.model.n_legs
        m["integral"][:n] = self.integral
        m["velocity"][:n] = self.actuator_velocity
        if self.previous_error is not None:
            m["previous"][:n] = self.previous_error
            m["has_previous"] = 1.0

    @property
    def previous_error(self) -> np.ndarray | None:
        """(n,) [native] the last step's error e = l_d − l, the derivative's start; None
        before the first step after a `reset` on a non-finite target."""
        return self._previous_error

    @previous_error.setter
    def previous_error(self, error: np.ndarray | None) -> None:
        self._previous_error = None if error is None else self._lengths(error).copy()

    def desired(self, transform: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
        """(desired state (3,) clipped to the limits, its lengths (n,) within the stroke,
        whether anything was clipped) for a desired ᴮT_P,d (4, 4) [m] (`desired_lane`)."""
        T = as_array(transform, "transform", (4, 4))
        state, lengths, clipped = self.model.desired_batch(T[None], clip=True)
        return state[0], lengths[0], bool(clipped[0])

    def reset(self, state: np.ndarray, target: TipTarget) -> None:
        """Clear the integral and the actuators' velocity; the first derivative term starts
        from the current error."""
        lengths = self._lengths(state)
        self.integral = np.zeros(self.model.n_legs)
        self.actuator_velocity = np.zeros(self.model.n_legs)
        self._previous_error = None
        if np.all(np.isfinite(target.transform)):
            self._previous_error = self.desired(target.transform)[1] - lengths

    def step(self, state: np.ndarray, target: TipTarget, dt: float) -> PlannerOutput:
        """Actuator rates (n,) [native/s] for lengths `state` (n,) [native] and the target
        (`plan_lane`, the engine's step: the law, the speed limit, the anti-windup).

        Diagnostics: `desired_state` (3,), `desired_legs` (n,) [native], `leg_error` (n,)
        e = l_d − l, `clipped` (1 if the desired state or a length was clipped to a limit),
        `saturated` (1 if the speed limit bound).
        """
        if not (np.isfinite(dt) and dt > 0):
            raise TwinError(f"dt must be > 0 s, got {dt!r}")
        lengths = self._lengths(state)
        n = self.model.n_legs
        if not (np.all(np.isfinite(target.transform)) and np.all(np.isfinite(target.twist))):
            nan = np.full(n, np.nan)
            return PlannerOutput(nan, {"clipped": 0.0, "saturated": 0.0})
        prm = self.pack(hold=True)
        memory = np.zeros(MEMORY_SIZE)
        self.pack_memory(memory)
        velocity, work, flags = np.zeros((1, n)), np.zeros((1, 8, 18)), np.zeros(1, np.int64)
        rows = target_rows(target)[None]
        batch(plan_lanes)(rows, lengths[None], prm.view(PLATFORM_PARAMETERS),
                          memory.view(PLATFORM_MEMORY), self.model.geometry, dt, velocity, work,
                          flags)  # fmt: skip
        m = memory_record(memory)
        self.integral = m["integral"][:n].copy()
        self.actuator_velocity = m["velocity"][:n].copy()
        if m["has_previous"]:
            self._previous_error = m["previous"][:n].copy()
        l_d = work[0, 3, :n].copy()
        return PlannerOutput(
            velocity[0],
            {
                "desired_state": work[0, 2, :3].copy(),
                "desired_legs": l_d,
                "leg_error": l_d - lengths,
                "clipped": float(flags[0] & 1),
                "saturated": float(flags[0] >> 1),
            },
        )

    def actuate(self, l_d: np.ndarray, lengths: np.ndarray, dt: float) -> tuple[np.ndarray, bool]:
        r"""Effort-driven actuators over one control period: (mean rates (n,) [native/s] of
        where they went, whether the speed limit bound) (`actuate_lane`).

        Each actuator is a mass m (`actuator_mass`) on a prismatic joint, pushed by seed 002
        §5's effort PID towards the desired length l_d held over the period (the paper's
        controller runs on the simulator's clock; ours at `PHYSICS_STEP`):

            m u̇ = F = K_p e + K_i ∫e dt − K_d u,     e = l_d − x,   ẋ = u,

        with the paper's gains (`EFFORT_KP`, `EFFORT_KI`, `EFFORT_KD`: N/m, N/(m·s), N·s/m;
        the derivative acts on the joint velocity, as ros_control's position controller
        does), in metres. Each of the `physics_steps(dt)` steps h first adds e h to the
        integral, then solves the spring and the damper implicitly (stable for any m and h),

            u⁺ = (m/h · u + K_p e + K_i ∫e) / (m/h + K_d + h K_p),

        caps |u⁺| at `actuator_speed` (the actuator's top speed: the speed limit binds),
        moves x⁺ = x + h u⁺ and stops x at the stroke's ends (u⁺ = 0 there). Gravity is left
        out: the top's weight shared by the limbs sags them together, which does not tilt
        it. The velocity and the integral carry over to the next period. The travel is summed
        apart from the length, so the mean rate it gives stays within the top speed to
        rounding of the travel, not of the length.
        """
        n = self.model.n_legs
        integral = np.array(self.integral, dtype=float).reshape(1, n)
        velocity = np.array(self.actuator_velocity, dtype=float).reshape(1, n)
        rates, saturated = np.zeros((1, n)), np.zeros(1, np.bool_)
        goal = np.array(l_d, dtype=float).reshape(1, n)
        legs = np.array(lengths, dtype=float).reshape(1, n)
        batch(actuate_lanes)(goal, legs, self.actuator_mass, self.actuator_speed,
                             self.model.geometry, dt, integral, velocity, rates,
                             saturated)  # fmt: skip
        self.integral, self.actuator_velocity = integral[0], velocity[0]
        return rates[0], bool(saturated[0])

    def limit(
        self, command: np.ndarray, lengths: np.ndarray, guess: np.ndarray
    ) -> tuple[np.ndarray, bool]:
        """(rates (n,) with every |rate| ≤ the speed limit, whether the limit bound)
        (`limit_lane`).

        Within the limit the command passes unchanged. Beyond it, the command is split at the
        platform state of `lengths` (forward kinematics from `guess`) into its tilt and heave
        parts, c = J ṡ_tilt + J ṡ_heave with ṡ = J⁺ c (J = ∂l/∂state): the tilt part is kept
        whole if it fits, scaled uniformly (its direction kept) if not, and the heave part
        gets the largest share σ ∈ [0, 1] that still fits. The Upu3Up's heave alone can ask
        for ten times the 0.1 m/s; clipping each actuator alone would let it tilt the top.
        Both parts are rates the linkage can follow, so the Upr4's four limbs stay consistent.
        """
        n = self.model.n_legs
        velocity, bound = np.zeros((1, n)), np.zeros(1, np.bool_)
        batch(limit_lanes)(np.array(command, dtype=float).reshape(1, n),
                           np.array(lengths, dtype=float).reshape(1, n),
                           np.array(guess, dtype=float).reshape(1, 3), self.speed_limit,
                           self.model.geometry, velocity, bound)  # fmt: skip
        return velocity[0], bool(bound[0])

    def _lengths(self, state: np.ndarray) -> np.ndarray:
        return as_array(state, "state (actuator lengths)", (self.model.n_legs,))


def platform_builder(
    law: str,
) -> Callable[[Upu3Up | Upr4, PlannerParameters, np.ndarray], PlatformPlanner]:
    """Registry builder: (mechanism, parameters, initial state (3,)) → `PlatformPlanner`."""
    if law not in LAWS:
        raise TwinError(f"platform_builder law: unknown {law!r}; allowed: {list(LAWS)}")

    def build(
        mechanism: Upu3Up | Upr4, p: PlannerParameters, state0: np.ndarray
    ) -> PlatformPlanner:
        model = PlatformModel(mechanism, z_hold=float(np.asarray(state0)[0]))
        if law == "ik":
            return PlatformPlanner(model, "ik", p.actuator_speed)
        return PlatformPlanner(
            model, "pid", p.actuator_speed, p.kp, p.ki, p.kd, actuator_mass=p.actuator_mass
        )

    return build

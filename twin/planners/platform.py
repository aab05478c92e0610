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

import numpy as np
from numpy.typing import ArrayLike

from twin.errors import ConvergenceError, TwinError
from twin.mechanisms.upr4 import Upr4
from twin.mechanisms.upu3up import Upu3Up
from twin.planners.parameters import PlannerParameters
from twin.planners.target import PlannerOutput, TipTarget
from twin.spatial import pose_to_transform, so3_exp
from twin.validation import as_array

LAWS = ("ik", "pid")
#: [m | rad] Gauss-Newton step after which the Upr4's best-fit pose is taken as converged:
#: convergence is quadratic (linear with a tiny rate for slightly inconsistent lengths), so
#: the pose is then within ~1e-12 of the limit, and one Jacobian is saved per step.
FIT_TOL = 1e-8
FIT_MAX_ITER = 30
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


def physics_steps(dt: float) -> int:
    """Steps of the actuator dynamics in a control period dt [s]: the fewest of ≤ 1 ms."""
    return max(1, int(np.ceil(dt / PHYSICS_STEP - 1e-9)))


def proportional_gain(kp: float, dt: float) -> float:
    """[1/s] the sampled gain (1 − e^(−kp·dt))/dt of the loop ė = −kp e: the error a step
    leaves is e^(−kp·dt) of the one before (the continuous loop's, exactly), never negative,
    so the loop neither overshoots nor goes unstable at any dt. ≈ kp for kp·dt ≪ 1."""
    return float(-np.expm1(-kp * dt) / dt)


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
        seed 002 eqs (15)-(18)."""
        state = as_array(state, "state", (3,))
        return self.mechanism.leg_lengths(state[..., 0], state[..., 1], state[..., 2])

    def jacobian(self, state: ArrayLike) -> np.ndarray:
        """∂l/∂state (..., n, 3) [native/native, native/rad]; seed 001 eq (24), Upr4.jacobian."""
        state = as_array(state, "state", (3,))
        return self.mechanism.jacobian(state[..., 0], state[..., 1], state[..., 2])

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

        The result is not clipped to the limits (`clip` does that).
        """
        T = as_array(transform, "transform", (4, 4))
        n = T[..., :3, 2] / np.linalg.norm(T[..., :3, 2], axis=-1, keepdims=True)
        if isinstance(self.mechanism, Upu3Up):
            beta = np.arcsin(np.clip(n[..., 0], -1.0, 1.0))
            alpha = np.arctan2(-n[..., 1], n[..., 2])
            z = np.sum(n * T[..., :3, 3], axis=-1) / self.unit - self.mechanism.l  # eq (13)
            return np.stack([z, alpha, beta], -1)
        roll = -np.arcsin(np.clip(n[..., 1], -1.0, 1.0))
        pitch = np.arctan2(n[..., 0], n[..., 2])
        return np.stack([np.full_like(roll, self.z_hold), roll, pitch], -1)

    def clip(self, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(state clipped to `state_limits`, (...) bool whether any value was clipped)."""
        low, high = self.mechanism.state_limits
        clipped = np.clip(state, low, high)
        return clipped, np.any(clipped != state, axis=-1)

    def fit(self, lengths: np.ndarray, guess: np.ndarray) -> np.ndarray:
        """Actual state (3,) of actuator lengths (n,) [native], warm-started at `guess` (3,).

        Upu3Up: seed 001's Newton-Raphson (`Upu3Up.forward`, eqs (20)-(24)) on the hardware
        envelope. Upr4: four limbs for three DOFs, so independently servoed lengths are in
        general slightly inconsistent; the rigid top takes the least-squares pose (the
        mismatch becomes internal force, not motion): Gauss-Newton on l(x) − L, the
        iteration of `Upr4.forward` without its consistency check.

        Raises:
            TwinError: lengths outside the stroke, or no convergence (`ConvergenceError`).
        """
        if self._envelope is not None:
            return self._envelope.forward(lengths, guess)
        m = self.mechanism
        x = np.array(guess, dtype=float)
        for _ in range(FIT_MAX_ITER):
            residual = m.leg_lengths(*x) - lengths
            J = m.jacobian(*x)
            step = np.linalg.lstsq(J, residual, rcond=None)[0]
            if not np.all(np.isfinite(step)):
                break
            x = x - step
            if np.all(np.abs(step) <= FIT_TOL):
                return x
        raise ConvergenceError(
            f"Upr4 best-fit pose of lengths {np.round(lengths, 6).tolist()} m did not converge "
            f"in {FIT_MAX_ITER} Gauss-Newton steps from {np.round(guess, 6).tolist()}"
        )

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
    that next sample exactly.
    """
    T = np.array(target.transform, dtype=float)
    T[..., :3, :3] = so3_exp(target.twist[..., 3:] * dt) @ T[..., :3, :3]
    T[..., :3, 3] += target.twist[..., :3] * dt
    return T


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

    def desired(self, transform: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
        """(desired state (3,) clipped to the limits, its lengths (n,) within the stroke,
        whether anything was clipped) for a desired ᴮT_P,d (4, 4) [m]."""
        state, clipped = self.model.clip(self.model.desired_state(transform))
        low, high = self.model.stroke
        lengths = self.model.leg_lengths(state)
        inside = np.clip(lengths, low, high)
        return state, inside, bool(clipped) or bool(np.any(inside != lengths))

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
        """Actuator rates (n,) [native/s] for lengths `state` (n,) [native] and the target.

        Diagnostics: `desired_state` (3,), `desired_legs` (n,) [native], `leg_error` (n,)
        e = l_d − l, `clipped` (1 if the desired state or a length was clipped to a limit),
        `saturated` (1 if the speed limit bound).
        """
        if not (np.isfinite(dt) and dt > 0):
            raise TwinError(f"dt must be > 0 s, got {dt!r}")
        lengths = self._lengths(state)
        if not (np.all(np.isfinite(target.transform)) and np.all(np.isfinite(target.twist))):
            nan = np.full(self.model.n_legs, np.nan)
            return PlannerOutput(nan, {"clipped": 0.0, "saturated": 0.0})
        desired_state, l_d, clipped = self.desired(target.transform)
        error = l_d - lengths
        if self.dynamic:
            velocity, saturated = self.actuate(l_d, lengths, dt)
        else:
            if self.law == "ik":
                _, l_next, clipped_next = self.desired(advance_target(target, dt))
                clipped = clipped or clipped_next
                command = (l_next - lengths) / dt  # reach l_d(t + dt) in one step
            else:
                previous = error if self._previous_error is None else self._previous_error
                gain = proportional_gain(self.kp, dt)
                command = gain * error + self.ki * self.integral + self.kd * (error - previous) / dt
            velocity, saturated = self.limit(command, lengths, desired_state)
            if self.law == "pid":
                # Anti-windup by conditional integration: no integral while the limit binds.
                if not saturated:
                    self.integral = self.integral + error * dt
                self._previous_error = error
        return PlannerOutput(
            velocity,
            {
                "desired_state": desired_state,
                "desired_legs": l_d,
                "leg_error": error,
                "clipped": float(clipped),
                "saturated": float(saturated),
            },
        )

    def actuate(self, l_d: np.ndarray, lengths: np.ndarray, dt: float) -> tuple[np.ndarray, bool]:
        r"""Effort-driven actuators over one control period: (mean rates (n,) [native/s] of
        where they went, whether the speed limit bound).

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
        unit = self.model.unit
        n = physics_steps(dt)
        h = dt / n
        inertia = self.actuator_mass / h  # [kg/s]
        low, high = (limit * unit for limit in self.model.stroke)
        top = self.actuator_speed
        start = lengths * unit  # [m]
        travel = np.zeros_like(start)  # [m] x − start
        u = self.actuator_velocity * unit  # [m/s]
        integral = self.integral * unit  # [m·s]
        goal = l_d * unit
        saturated = False
        for _ in range(n):
            e = goal - (start + travel)
            integral = integral + e * h
            u = (inertia * u + EFFORT_KP * e + EFFORT_KI * integral) / (
                inertia + EFFORT_KD + h * EFFORT_KP
            )
            saturated = saturated or bool(np.any(np.abs(u) > top))
            u = np.clip(u, -top, top)
            travel = travel + h * u
            x = start + travel
            stopped = (x < low) | (x > high)
            travel = np.where(x < low, low - start, np.where(x > high, high - start, travel))
            u = np.where(stopped, 0.0, u)
        self.actuator_velocity = u / unit
        self.integral = integral / unit
        return travel / unit / dt, saturated

    def limit(
        self, command: np.ndarray, lengths: np.ndarray, guess: np.ndarray
    ) -> tuple[np.ndarray, bool]:
        """(rates (n,) with every |rate| ≤ the speed limit, whether the limit bound).

        Within the limit the command passes unchanged. Beyond it, the command is split at the
        platform state of `lengths` (forward kinematics from `guess`) into its tilt and heave
        parts, c = J ṡ_tilt + J ṡ_heave with ṡ = J⁺ c (J = ∂l/∂state): the tilt part is kept
        whole if it fits, scaled uniformly (its direction kept) if not, and the heave part
        gets the largest share σ ∈ [0, 1] that still fits. The Upu3Up's heave alone can ask
        for ten times the 0.1 m/s; clipping each actuator alone would let it tilt the top.
        Both parts are rates the linkage can follow, so the Upr4's four limbs stay consistent.
        """
        limit = self.speed_limit
        peak = np.max(np.abs(command))
        if peak <= limit:
            return command, False
        try:
            state = self.model.fit(lengths, guess)  # the encoders' pose
        except TwinError:
            state = guess  # no pose from the encoders: split at the desired state instead
        J = self.model.jacobian(state)  # (n, 3)
        rates = np.linalg.lstsq(J, command, rcond=None)[0]
        tilt = J[:, 1:] @ rates[1:]
        heave = J[:, 0] * rates[0]
        tilt_peak = np.max(np.abs(tilt))
        if tilt_peak >= limit:
            return tilt * (limit / tilt_peak), True
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(heave > 0, (limit - tilt) / heave, (-limit - tilt) / heave)
        share = float(np.min(np.where(heave != 0, room, 1.0), initial=1.0))
        return tilt + min(1.0, max(0.0, share)) * heave, True

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

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
from typing import ClassVar

import numpy as np

from twin.errors import TwinError
from twin.mechanisms.platforms import (
    batch,
)
from twin.mechanisms.upr4 import Upr4
from twin.mechanisms.upu3up import Upu3Up
from twin.planners.parameters import (
    KIND_PLATFORM,
    PlannerParameters,
    parameter_record,
    parameter_row,
)
from twin.planners.platform_model import PlatformModel
from twin.planners.platform_step import (
    ADVANCE,
    LAW_IK,
    LAW_PID,
    LAWS,
    MEMORY_SIZE,
    PLATFORM_MEMORY,
    PLATFORM_PARAMETERS,
    actuate_lanes,
    limit_lanes,
    memory_record,
    plan_lanes,
)
from twin.planners.target import PlannerOutput, TipTarget
from twin.planners.tasks import target_rows
from twin.validation import as_array


def advance_target(target: TipTarget, dt: float) -> np.ndarray:
    """ᴮT_P,d(t + dt) (..., 4, 4): the target moved by its twist, held constant over dt.

    The twist's ω is the desired frame's angular velocity expressed in B, Ṙ_d = [ω]× R_d, so
    R_d(t + dt) = exp(ω dt) R_d; p_d(t + dt) = p_d + ṗ_d dt. With the simulation's targets,
    whose twist is the mean rate to the next sample (`twin.sim.target.held_targets`), this is
    that next sample exactly. By `advance_target_lane` lane by lane (`ADVANCE`), the step the
    engine's "ik" law takes.
    """
    return ADVANCE([target_rows(target)], [float(dt)], [(4, 4)])[0]


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

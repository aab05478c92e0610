"""The small platforms (Upu3Up, Upr4) in a simulation: servo loop, forward kinematics, record.

The rig's state is the actuator lengths, moved by the planner's rates and stopped at the end
of the stroke; the platform state follows by forward kinematics, warm-started from the previous
one (`PlatformModel.fit`: the Upr4's four limbs may disagree slightly, and its top then takes the
least-squares pose, the disagreement being internal strain). The top is asked to hold a level
inertial pose: at t = 0, the inertial position of the top's centre with the base's heading and
no tilt. Lengths and states are in the mechanism's unit (mm for the Upu3Up, m for the Upr4);
poses and tip errors in m and rad.
"""

from __future__ import annotations

import numpy as np

from twin.errors import TwinError
from twin.mechanisms.upr4 import Upr4
from twin.mechanisms.upu3up import Upu3Up
from twin.planners import PlannerParameters, get_planner
from twin.planners.platform import PlatformModel
from twin.sim.base_motion import BaseSamples
from twin.sim.faults import Fault
from twin.sim.metrics import SETTLE, drift, efficacy, finite
from twin.sim.target import held_target, tilt
from twin.spatial import invert_transform, pose_error, pose_to_transform


class PlatformRig:
    """Steps a small platform so that its top stays level (and, Upu3Up, at a fixed height).

    Args:
        mechanism: the Upu3Up or Upr4.
        planner: registry name (`"pid"`, `"ik"`).
        parameters: the planner's knobs.
        initial_state: (3,) platform state at t = 0 [native, rad, rad].
        dt: [s] control period.

    Attributes:
        fault: what went wrong at the last step (`Fault`): a planner velocity that was not
            finite (PLANNER) or forward kinematics that did not converge (KINEMATICS) held the
            previous state; legs stopped at their end stops flag JOINT_LIMIT.
        hold_limits: unused: the actuators' end stops always hold (`joint_limits` matters
            for the hybrid system, whose platform has no end stops of its own in the papers).
    """

    def __init__(
        self,
        mechanism: Upu3Up | Upr4,
        planner: str,
        parameters: PlannerParameters,
        initial_state: np.ndarray,
        dt: float,
    ) -> None:
        self.dt = dt
        self.state = np.array(initial_state, dtype=float)
        self.model = PlatformModel(mechanism, z_hold=float(self.state[0]))
        self.mechanism_name = self.model.name
        self.spec = get_planner(planner, self.mechanism_name)
        self.parameters = parameters
        self.planner = self.spec.build(mechanism, parameters, self.state)
        self.legs = self.model.leg_lengths(self.state)
        self.leg_rates = np.zeros(self.model.n_legs)
        self.held: np.ndarray | None = None  # ᴵT*, fixed at reset
        self.fault = Fault(0)
        self.hold_limits = True

    def reset(self, base: BaseSamples) -> dict[str, np.ndarray]:
        """Fix the held top pose at the base's first sample; the record at t = 0."""
        top = base.transform[0] @ self.model.transform(self.state)
        self.held = pose_to_transform(np.r_[top[:3, 3], 0.0, 0.0, base.pose[0, 5]])
        self.planner.reset(self.legs, held_target(self.held, base, 0, self.dt))
        return self.record(base, 0, {})

    def replan(
        self, planner: str, parameters: PlannerParameters, base: BaseSamples, k: int
    ) -> None:
        """Switch planner or parameters at sample k, keeping the state and the held pose."""
        self.spec = get_planner(planner, self.mechanism_name)
        self.parameters = parameters
        self.planner = self.spec.build(self.model.mechanism, parameters, self.state)
        self.planner.reset(self.legs, held_target(self.held, base, k, self.dt))

    def advance(self, base: BaseSamples, k: int, dt: float) -> dict[str, np.ndarray]:
        """Servo at sample k, move the actuators one dt, return the record at sample k + 1."""
        out = self.planner.step(self.legs, held_target(self.held, base, k, dt), dt)
        v = np.asarray(out.velocity, dtype=float)
        self.fault = Fault(0)
        if not np.all(np.isfinite(v)):
            self.fault = Fault.PLANNER
            return self.hold(base, k, out.diagnostics)
        low, high = self.model.stroke
        lengths = np.clip(self.legs + v * dt, low, high)  # the actuators' end stops
        if np.any(lengths != self.legs + v * dt):
            self.fault |= Fault.JOINT_LIMIT
        try:
            state = self.model.fit(lengths, self.state)
        except TwinError:  # no convergence, or lengths met only outside the workspace
            state = None
        if state is None or not np.all(np.isfinite(state)):
            self.fault |= Fault.KINEMATICS
            return self.hold(base, k, out.diagnostics)
        self.leg_rates = (lengths - self.legs) / dt
        self.state, self.legs = state, lengths
        return self.record(base, k + 1, out.diagnostics)

    def hold(
        self, base: BaseSamples, k: int, diagnostics: dict | None = None
    ) -> dict[str, np.ndarray]:
        """The platform held still for the step from sample k: the record at k + 1."""
        self.leg_rates = np.zeros(self.model.n_legs)
        return self.record(base, k + 1, diagnostics or {})

    def record(self, base: BaseSamples, k: int, diagnostics: dict) -> dict[str, np.ndarray]:
        """The sample at k: base, state, legs, errors against the level target, tilts."""
        T_IB = base.transform[k]
        T_BP = self.model.transform(self.state)
        desired = self.model.desired_state(invert_transform(T_IB) @ self.held)
        rec = {
            "t": base.t[k],
            "base_pose": base.pose[k],
            "state": self.state.copy(),
            "desired_state": desired,
            "legs": self.legs.copy(),
            "leg_rates": self.leg_rates.copy(),
            "tip_error": pose_error(self.model.transform(desired), T_BP),
            "alpha_top": tilt(T_IB[:3, :3] @ T_BP[:3, :3]),
            "alpha_bottom": tilt(T_IB[:3, :3]),
            "clipped": np.float64(diagnostics.get("clipped", 0.0)),
            "saturated": np.float64(diagnostics.get("saturated", 0.0)),
        }
        if isinstance(self.model.mechanism, Upu3Up):
            rec["coupled_displacement"] = self.model.mechanism.coupled_displacement(*self.state)
        return rec


def platform_metrics(series: dict[str, np.ndarray], model: PlatformModel) -> dict:
    """Metrics of a small-platform run from its series (see `PlatformRig.record`).

    Units: state z and legs in the mechanism's unit (mm Upu3Up, m Upr4), angles in degrees,
    `leg_rate_max` in m/s for both, tip position errors in m, orientation errors in degrees,
    η in %.
    """
    t, state, legs = series["t"], series["state"], series["legs"]
    s = slice(min(SETTLE, len(t) - 1), None)
    violated = model.violations(state)
    bad = np.any(np.stack(list(violated.values())), axis=0)
    low, high = model.mechanism.state_limits
    states: dict[str, dict[str, float]] = {}
    for j, name in enumerate(model.mechanism.state_names):
        scale = 1.0 if j == 0 else np.degrees(1.0)
        x = state[:, j]
        states[name] = {
            "min": finite(x[s].min() * scale),
            "max": finite(x[s].max() * scale),
            "margin": finite(min(x[s].min() - low[j], high[j] - x[s].max()) * scale),
            "drift": finite(drift(t, x[:, None])[0] * scale),
        }
    stroke_low, stroke_high = model.stroke
    err = series["tip_error"][s]
    pos_err = np.linalg.norm(err[:, :3], axis=1)
    rot_err = np.degrees(np.linalg.norm(err[:, 3:], axis=1))
    metrics = {
        "violations": int(np.sum(bad)),
        "limit_violations": {name: int(np.sum(v)) for name, v in violated.items()},
        "states": states,
        "legs_min": finite(legs[s].min()),
        "legs_max": finite(legs[s].max()),
        "leg_margin": finite(min(legs[s].min() - stroke_low[0], stroke_high[0] - legs[s].max())),
        "leg_drift": [finite(v) for v in drift(t, legs)],
        "leg_rate_max": finite(np.abs(series["leg_rates"]).max() * model.unit),
        "tip_position_error_rms": finite(np.sqrt(np.mean(pos_err**2))),
        "tip_position_error_max": finite(pos_err.max()),
        "tip_orientation_error_rms": finite(np.sqrt(np.mean(rot_err**2))),
        "tip_orientation_error_max": finite(rot_err.max()),
        "alpha_top_max": finite(np.degrees(series["alpha_top"][s].max())),
        "alpha_bottom_max": finite(np.degrees(series["alpha_bottom"][s].max())),
        "clipped": int(np.sum(series["clipped"] > 0)),
        "saturated": int(np.sum(series["saturated"] > 0)),
        **efficacy(series["alpha_top"], series["alpha_bottom"]),  # seed 002 eq (29)
    }
    if "coupled_displacement" in series:
        peak = np.abs(series["coupled_displacement"][s]).max(axis=0)  # seed 001 eq (15), mm
        metrics["coupled_displacement_max"] = {
            a: finite(v) for a, v in zip("xyz", peak, strict=True)
        }
    return metrics

"""The hybrid boarding system in a simulation: planner, integration and what is recorded."""

from __future__ import annotations

import numpy as np

from twin.mechanisms.hybrid import HybridBoardingSystem
from twin.planners import PlannerParameters, get_planner
from twin.sim.base_motion import BaseSamples
from twin.sim.faults import Fault
from twin.sim.target import held_target, tilt
from twin.spatial import invert_transform, pose_error, pose_to_transform

#: bisection steps of `limit_scale`: the step is shortened to within 2⁻¹² of the limit
LIMIT_BISECTIONS = 12


def limit_scale(
    mechanism: HybridBoardingSystem, xi: np.ndarray, velocity: np.ndarray, dt: float
) -> float:
    """The largest s in [0, 1] such that the step s·velocity·dt carries no joint and no leg
    further past its limit than it already is (a joint at its limit stops there; one beyond
    it, e.g. a start outside the limits, may only come back).

    Args:
        mechanism: the hybrid system.
        xi: (9,) [m, rad] state.
        velocity: (9,) virtual-joint velocity (`HybridBoardingSystem.integrate`).
        dt: [s] step.
    """
    now = mechanism.limit_excess(xi) + 1e-12

    def fits(s: float) -> bool:
        return bool(
            np.all(mechanism.limit_excess(mechanism.integrate(xi, s * velocity, dt)) <= now)
        )

    if fits(1.0):
        return 1.0
    low, high = 0.0, 1.0
    for _ in range(LIMIT_BISECTIONS):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if fits(mid) else (low, mid)
    return low


class HybridRig:
    """Steps the hybrid system so that its gangway tip holds its inertial pose.

    Args:
        mechanism: the hybrid system.
        planner: registry name.
        parameters: the planner's knobs.
        initial_state: (9,) xi at t = 0.
        dt: [s] control period.

    Attributes:
        hold_limits: shorten a step that would carry a joint or leg past its limit
            (`Scenario.joint_limits == "hold"`); else let it pass and count the violation.
        fault: what happened at the last step (`Fault`): a non-finite planner velocity held
            the mechanism (PLANNER), a shortened step (JOINT_LIMIT), damping (SINGULAR).
    """

    def __init__(
        self,
        mechanism: HybridBoardingSystem,
        planner: str,
        parameters: PlannerParameters,
        initial_state: np.ndarray,
        dt: float,
    ) -> None:
        self.mechanism = mechanism
        self.dt = dt
        self.spec = get_planner(planner, "hybrid")
        self.parameters = parameters
        self.xi = np.array(initial_state, dtype=float)
        self.xi0 = self.xi.copy()  # set-points such as q̃2 (seed 000 eq (40)) stay at the start
        self.planner = self.spec.build(mechanism, parameters, self.xi0)
        self.held: np.ndarray | None = None  # ᴵT_E*, fixed at reset
        self._gangway0: np.ndarray | None = None
        self._landing: np.ndarray | None = None
        self.hold_limits = False
        self.fault = Fault(0)

    def reset(self, base: BaseSamples) -> dict[str, np.ndarray]:
        """Fix the held tip pose at the base's first sample; the record at t = 0."""
        T_E = self.mechanism.end_effector(self.xi)
        self.held = base.transform[0] @ T_E
        self.planner.reset(self.xi, held_target(self.held, base, 0, self.dt))
        # landing frame: inertial, x along the initial horizontal gangway direction (seed 004)
        g = self._gangway(base.transform[0])
        heading = np.arctan2(g[1], g[0])
        c, s = np.cos(heading), np.sin(heading)
        self._landing = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        self._gangway0 = self._landing @ g
        return self.record(base, 0, {})

    def replan(
        self, planner: str, parameters: PlannerParameters, base: BaseSamples, k: int
    ) -> None:
        """Switch planner or parameters at sample k, keeping the state and the held pose."""
        self.spec = get_planner(planner, "hybrid")
        self.parameters = parameters
        self.planner = self.spec.build(self.mechanism, parameters, self.xi0)
        self.planner.reset(self.xi, held_target(self.held, base, k, self.dt))

    def _gangway(self, T_IB: np.ndarray) -> np.ndarray:
        """Inertial vector from the luff pivot (DH frame 2) to the tip (3,) [m]."""
        T_IP = T_IB @ pose_to_transform(self.xi[:6])
        links = self.mechanism.gangway.links(self.xi[6:])
        return (T_IP @ links[2])[:3, 3] - (T_IP @ links[1])[:3, 3]

    def advance(self, base: BaseSamples, k: int, dt: float) -> dict[str, np.ndarray]:
        """Plan at sample k, integrate one dt, return the record at sample k + 1."""
        out = self.planner.step(self.xi, held_target(self.held, base, k, dt), dt)
        v = out.velocity
        self.fault = Fault.SINGULAR if out.diagnostics.get("damping", 0.0) > 0 else Fault(0)
        if not np.all(np.isfinite(v)):
            # A planner fault holds the mechanism still rather than letting NaN through.
            self.fault |= Fault.PLANNER
            return self.hold(base, k, out.diagnostics)
        scale = limit_scale(self.mechanism, self.xi, v, dt) if self.hold_limits else 1.0
        if scale < 1.0:
            self.fault |= Fault.JOINT_LIMIT
        self.xi = self.mechanism.integrate(self.xi, scale * v, dt)
        return self.record(base, k + 1, out.diagnostics, scale)

    def hold(
        self, base: BaseSamples, k: int, diagnostics: dict | None = None
    ) -> dict[str, np.ndarray]:
        """The mechanism held still for the step from sample k: the record at k + 1."""
        return self.record(base, k + 1, diagnostics or {}, 0.0)

    def record(
        self, base: BaseSamples, k: int, diagnostics: dict, scale: float = 1.0
    ) -> dict[str, np.ndarray]:
        """The sample at k; `scale`: the fraction of the planner's step taken (1: all)."""
        T_IB = base.transform[k]
        T_E = self.mechanism.end_effector(self.xi)
        error = pose_error(invert_transform(T_IB) @ self.held, T_E)
        g = self._landing @ self._gangway(T_IB)
        g0 = self._gangway0
        # seed 004 §3.1 a: φe = atan2(y, x), θe = atan2(z, x) of the gangway, from t = 0
        phi_e = np.arctan2(g[1], g[0]) - np.arctan2(g0[1], g0[0])
        theta_e = np.arctan2(g[2], g[0]) - np.arctan2(g0[2], g0[0])
        up0 = self.held[:3, 0]  # the tip's x axis is "up" at q = 0
        up = (T_IB @ T_E)[:3, 0]
        rec = {
            "t": base.t[k],
            "base_pose": base.pose[k],
            "xi": self.xi.copy(),
            "legs": self.mechanism.leg_lengths(self.xi),
            "tip_error": error,
            "manipulability": self.mechanism.manipulability(self.xi),
            "phi_e": phi_e,
            "theta_e": theta_e,
            "alpha_top": np.arctan2(np.linalg.norm(np.cross(up, up0)), up @ up0),
            "alpha_bottom": tilt(T_IB[:3, :3]),
        }
        for name in ("weights", "null_space_share", "damping", "velocity_scale", "position_share"):
            if name in diagnostics:
                rec[name] = np.asarray(diagnostics[name], dtype=float)
        rec["limit_scale"] = np.float64(scale)
        return rec

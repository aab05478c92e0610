"""What a run is judged by: limits, tracking, drift, manipulability, end attitude, efficacy.

Every metric is a plain float (JSON-ready) and finite. The first `SETTLE` samples are left
out of min/max and error statistics, as seed 000 §5.3 drops its first 10 points.
"""

from __future__ import annotations

import numpy as np

from twin.mechanisms.hybrid import JOINT_NAMES, HybridBoardingSystem
from twin.planners.platform import PlatformModel

#: samples left out at the start (seed 000 §5.3: "the first 10 data points are removed")
SETTLE = 10

_ANGLES = {"roll", "pitch", "yaw", "q1", "q2"}


def finite(x: float | np.floating) -> float:
    """A finite Python float (metrics are JSON and must never carry NaN)."""
    x = float(x)
    return x if np.isfinite(x) else 0.0


def _extreme(x: np.ndarray) -> float:
    """The signed value of largest magnitude (seed 004 reports φe, θe maxima with sign)."""
    return float(x[np.argmax(np.abs(x))])


def drift(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Least-squares trend of x (N, k) over the run, slope × duration, (k,).

    An oscillation around a steady mean has no drift; PI/WPI's divergence (seed 000 §5.3
    analysis 1) shows as a trend.
    """
    tc = t - t.mean()
    slope = (tc @ (x - x.mean(axis=0))) / max(float(tc @ tc), 1e-300)
    return slope * (t[-1] - t[0])


def efficacy(alpha_top: np.ndarray, alpha_bottom: np.ndarray) -> dict[str, float]:
    """Seed 002 eq (29) as printed and the integral form of SPEC erratum 11 [%].

    As printed: the time mean of (α_bottom − α_top)/α_bottom, over samples where the base
    is tilted at all (α_bottom > 1e-9 rad) — it explodes when α_bottom passes near zero.
    Integral: 1 − ∫|α_top| dt / ∫|α_bottom| dt (uniform dt).
    """
    tilted = alpha_bottom > 1e-9
    printed = (
        np.mean((alpha_bottom[tilted] - alpha_top[tilted]) / alpha_bottom[tilted])
        if np.any(tilted)
        else 0.0
    )
    denominator = np.sum(np.abs(alpha_bottom))
    integral = 1.0 - np.sum(np.abs(alpha_top)) / denominator if denominator > 0 else 0.0
    return {"eta_printed": finite(100 * printed), "eta": finite(100 * integral)}


def hybrid_metrics(
    series: dict[str, np.ndarray], mechanism: HybridBoardingSystem, joint_limits: str = "record"
) -> dict:
    """Metrics of a hybrid-system run from its series (`twin.sim.records.hybrid_records`).

    Violations: samples with a virtual joint or a leg outside its limit. In `record` mode
    (`Scenario.joint_limits`) a joint on its Table 6 limit (to 1e-9) counts too; nothing is
    clamped there, every step is taken whole. In `hold` mode a step stops on the limit by
    design (counted as held: `fault_counts["joint_limit"]`), so only samples beyond count.
    Legs count beyond Table 1's stroke by more than its millimetre precision: the geometry's
    stowed legs, 2.57986 m, are Table 1's 2.58 m.
    """
    xi, legs, t = series["xi"], series["legs"], series["t"]
    lower, upper = mechanism.lower[:, None], mechanism.upper[:, None]
    leg_min, leg_max = mechanism.stewart.leg_min, mechanism.stewart.leg_max
    tol = 5e-4  # Table 1's millimetre precision, as StewartPlatform.check_lengths
    # one row per joint or leg: reductions over time then run along contiguous memory, which
    # is several times faster than over the short rows of a (T, 9) array
    joints_t, legs_t = np.ascontiguousarray(xi.T), np.ascontiguousarray(legs.T)
    if joint_limits == "record":  # at or beyond
        joint_bad = np.any((joints_t <= lower + 1e-9) | (joints_t >= upper - 1e-9), axis=0)
    else:
        joint_bad = np.any((joints_t < lower - 1e-9) | (joints_t > upper + 1e-9), axis=0)
    leg_bad = np.any((legs_t < leg_min - tol) | (legs_t > leg_max + tol), axis=0)
    s = slice(min(SETTLE, len(t) - 1), None)
    err = series["tip_error"][s]
    pos_err = np.linalg.norm(err[:, :3], axis=1)
    rot_err = np.degrees(np.linalg.norm(err[:, 3:], axis=1))
    low, high, trend = joints_t[:, s].min(axis=1), joints_t[:, s].max(axis=1), drift(t, xi)
    legs_low, legs_high = legs_t[:, s].min(), legs_t[:, s].max()
    joints: dict[str, dict[str, float]] = {}
    for j, name in enumerate(JOINT_NAMES):
        scale = np.degrees(1.0) if name in _ANGLES else 1.0
        joints[name] = {
            "min": finite(low[j] * scale),
            "max": finite(high[j] * scale),
            "margin": finite(min(low[j] - lower[j, 0], upper[j, 0] - high[j]) * scale),
            "drift": finite(trend[j] * scale),
        }
    return {
        "violations": int(np.sum(joint_bad | leg_bad)),
        "joint_violations": int(np.sum(joint_bad)),
        "leg_violations": int(np.sum(leg_bad)),
        "table7": {  # seed 000 Table 7's columns: q1, q2 [deg], d3 [m], legs [m]
            "q1_max": joints["q1"]["max"], "q1_min": joints["q1"]["min"],
            "q2_max": joints["q2"]["max"], "q2_min": joints["q2"]["min"],
            "d3_max": joints["d3"]["max"], "d3_min": joints["d3"]["min"],
            "legs_max": finite(legs_high), "legs_min": finite(legs_low),
        },
        "joints": joints,
        "leg_margin": finite(min(legs_low - leg_min, leg_max - legs_high)),
        "leg_drift": [finite(v) for v in drift(t, legs)],
        "tip_position_error_rms": finite(np.sqrt(np.mean(pos_err**2))),
        "tip_position_error_max": finite(pos_err.max()),
        "tip_orientation_error_rms": finite(np.sqrt(np.mean(rot_err**2))),
        "tip_orientation_error_max": finite(rot_err.max()),
        "manipulability_min": finite(series["manipulability"][s].min()),
        "phi_e_max": finite(np.degrees(_extreme(series["phi_e"][s]))),
        "theta_e_max": finite(np.degrees(_extreme(series["theta_e"][s]))),
        **efficacy(series["alpha_top"], series["alpha_bottom"]),
    }  # fmt: skip


def platform_metrics(
    series: dict[str, np.ndarray], model: PlatformModel, joint_limits: str = "record"
) -> dict:
    """Metrics of a small-platform run from its series (`twin.sim.records.platform_records`).

    Units: state z and legs in the mechanism's unit (mm Upu3Up, m Upr4), angles in degrees,
    `leg_rate_max` in m/s for both, tip position errors in m, orientation errors in degrees,
    η in %.

    Violations: the actuators always stop at their end stops and the planner clamps its
    demand to the limits (`clipped`), so a small platform is held at a limit in either mode.
    In `record` mode (`Scenario.joint_limits`) every sample at a limit or beyond it counts
    (`PlatformModel.reached`), and so does every sample whose demand was clamped
    (`limit_violations["clamped"]`); in `hold` mode only samples beyond a limit count, the
    clamped ones being held steps (`fault_counts["joint_limit"]`).
    """
    t, state, legs = series["t"], series["state"], series["legs"]
    s = slice(min(SETTLE, len(t) - 1), None)
    if joint_limits == "record":
        violated = model.reached(state, legs)
        violated["clamped"] = series["clipped"] > 0
    else:
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

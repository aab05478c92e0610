"""What a run is judged by: limits, tracking, drift, manipulability, end attitude, efficacy.

Every metric is a plain float (JSON-ready) and finite. The first `SETTLE` samples are left
out of min/max and error statistics, as seed 000 §5.3 drops its first 10 points.

The hybrid system's numbers are reduced by a compiled pass over every lane at once
(`twin.sim.kernels.metrics`); this module names them, converts them to the reported units and
keeps them finite. The small platforms' are numpy, lane by lane.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from twin.compiled import pick_runner
from twin.mechanisms.hybrid import JOINT_NAMES, HybridBoardingSystem
from twin.planners.platform import PlatformModel
from twin.sim.kernels import metrics as kernel
from twin.sim.kernels.metrics import SETTLE

_ANGLES = {"roll", "pitch", "yaw", "q1", "q2"}
_DEGREES = math.degrees(1.0)


def finite(x: float | np.floating) -> float:
    """A finite Python float (metrics are JSON and must never carry NaN)."""
    x = float(x)
    return x if math.isfinite(x) else 0.0


def drift(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Least-squares trend of x (N, k) over the run, slope × duration, (k,) in x's unit
    (`twin.sim.kernels.metrics.drift_lane`, compiled where numba imports).

    An oscillation around a steady mean has no drift; PI/WPI's divergence (seed 000 §5.3
    analysis 1) shows as a trend.
    """
    x = np.ascontiguousarray(x, dtype=float)
    out = np.empty(x.shape[1])
    kernel.compiled_series_reductions().drift(np.ascontiguousarray(t, dtype=float), x, out)
    return out


def efficacy(alpha_top: np.ndarray, alpha_bottom: np.ndarray) -> dict[str, float]:
    """Seed 002 eq (29) as printed and the integral form of SPEC erratum 11 [%]
    (`twin.sim.kernels.metrics.efficacy_sums`, compiled where numba imports).

    As printed: the time mean of (α_bottom − α_top)/α_bottom, over samples where the base
    is tilted at all (α_bottom > 1e-9 rad) — it explodes when α_bottom passes near zero.
    Integral: 1 − ∫|α_top| dt / ∫|α_bottom| dt (uniform dt).
    """
    out = np.empty(2)
    kernel.compiled_series_reductions().efficacy(
        np.ascontiguousarray(alpha_top, dtype=float),
        np.ascontiguousarray(alpha_bottom, dtype=float),
        out,
    )
    return efficacy_percent(out[0], out[1])


def efficacy_percent(printed: float, integral: float) -> dict[str, float]:
    """The two efficacies (`efficacy`) as fractions [-] → the reported dict [%], finite."""
    return {"eta_printed": finite(100 * printed), "eta": finite(100 * integral)}


def hybrid_metrics(
    series: dict[str, np.ndarray],
    mechanism: HybridBoardingSystem,
    joint_limits: str = "record",
    compiled: bool = True,
) -> dict:
    """Metrics of a hybrid-system run from its series (`twin.sim.records.hybrid_records`).

    Violations: samples with a virtual joint or a leg outside its limit. In `record` mode
    (`Scenario.joint_limits`) a joint on its Table 6 limit (to 1e-9) counts too; nothing is
    clamped there, every step is taken whole. In `hold` mode a step stops on the limit by
    design (counted as held: `fault_counts["joint_limit"]`), so only samples beyond count.
    Legs count beyond Table 1's stroke by more than its millimetre precision: the geometry's
    stowed legs, 2.57986 m, are Table 1's 2.58 m.

    The reduction is `hybrid_metrics_lanes` on this one lane: compiled (where numba imports),
    or with compiled=False interpreted, as the engine runs its kernels; the same numbers.
    """
    lane = {key: series[key][None] for key in kernel.REDUCED}
    ends = np.array([len(series["t"])])
    return hybrid_metrics_lanes(lane, ends, mechanism, [joint_limits], compiled)[0]


def hybrid_metrics_lanes(
    data: dict[str, np.ndarray],
    ends: np.ndarray,
    mechanism: HybridBoardingSystem,
    joint_limits: Sequence[str],
    compiled: bool,
) -> list[dict]:
    """`hybrid_metrics` of N lanes at once, from their series as (N, C, ...) arrays (a batch
    run's history, read in place): one compiled pass, parallel over lanes
    (`twin.sim.kernels.metrics.run_hybrid_reductions`), then each lane's dict.

    Args:
        data: at least the keys of `twin.sim.kernels.metrics.REDUCED`, (N, C, ...) each.
        ends: (N,) each lane's samples (1 ≤ end ≤ C), from t = 0.
        mechanism: the lanes' hybrid system (its joint limits and stroke).
        joint_limits: (N,) each lane's `Scenario.joint_limits`.
        compiled: numba's runner (parallel over several lanes), or the interpreted one.

    Returns:
        One metrics dict per lane, as `hybrid_metrics` of its series up to its end.
    """
    ends = np.asarray(ends, dtype=np.int64)
    hold = np.array([mode == "hold" for mode in joint_limits], dtype=bool)
    rows = np.empty((len(ends), kernel.N_ROW))
    run = pick_runner(
        kernel.compiled_hybrid_reductions, kernel.run_hybrid_reductions, compiled, len(ends)
    )
    stewart = mechanism.stewart
    run(*(np.ascontiguousarray(data[key], dtype=float) for key in kernel.REDUCED), ends, hold,
        mechanism.lower, mechanism.upper, float(stewart.leg_min), float(stewart.leg_max),
        rows)  # fmt: skip
    return [hybrid_metrics_from(row, mechanism) for row in rows.tolist()]


class HybridReduction:
    """The hybrid system's metrics of N lanes reduced chunk by chunk, as the chunks are stepped:
    each lane's accumulator row (`twin.sim.kernels.metrics`, N_ACC floats) is all it keeps, so
    its memory does not depend on the run's length, and its metrics are `hybrid_metrics_lanes`'
    of the same samples, to the bit (the same running sums, in the same order).

    Args:
        mechanism: the lanes' hybrid system (its joint limits and stroke).
        ends: (N,) each lane's samples (≥ 1), from t = 0: its samples past its end are not added.
        joint_limits: (N,) each lane's `Scenario.joint_limits`.
        compiled: numba's runner (parallel over several lanes), or the interpreted one.
    """

    def __init__(
        self,
        mechanism: HybridBoardingSystem,
        ends: np.ndarray,
        joint_limits: Sequence[str],
        compiled: bool,
    ) -> None:
        self.mechanism = mechanism
        self.ends = np.asarray(ends, dtype=np.int64)
        self.hold = np.array([mode == "hold" for mode in joint_limits], dtype=bool)
        self.acc = np.empty((len(self.ends), kernel.N_ACC))
        for row, end in zip(self.acc, self.ends.tolist(), strict=True):
            kernel.hybrid_begin_lane(row, end)
        self._run = pick_runner(
            kernel.compiled_hybrid_add, kernel.run_hybrid_add, compiled, len(self.ends)
        )

    @property
    def seen(self) -> np.ndarray:
        """(N,) samples added so far per lane."""
        return self.acc[:, kernel.A_SEEN].astype(np.int64)

    def add(self, records: dict[str, np.ndarray], start: int) -> None:
        """Add samples start … start + S − 1 of every lane (each up to its end), the next ones.

        Args:
            records: at least the keys of `twin.sim.kernels.metrics.REDUCED`, (N, S, ...) each.
            start: the index of the chunk's first sample (0: t = 0).

        Raises:
            ValueError: samples that do not follow those already added.
        """
        S = records["t"].shape[1]
        counts = np.clip(self.ends - start, 0, S)
        wanted = np.minimum(self.ends, start)
        if np.any(self.seen != wanted):
            raise ValueError(f"reduction: samples from {start} on, after {self.seen.tolist()}")
        stewart = self.mechanism.stewart
        self._run(*(np.ascontiguousarray(records[key], dtype=float) for key in kernel.REDUCED),
                  counts, self.hold, self.mechanism.lower, self.mechanism.upper,
                  float(stewart.leg_min), float(stewart.leg_max), self.acc)  # fmt: skip

    def results(self) -> list[dict]:
        """Every lane's metrics dict (`hybrid_metrics_from`), as `hybrid_metrics_lanes` gives
        them for the samples added (every lane's, up to its end).

        Raises:
            ValueError: a lane that has not had all its samples.
        """
        if np.any(self.seen != self.ends):
            raise ValueError(f"reduction: lanes have {self.seen.tolist()} of "
                             f"{self.ends.tolist()} samples")  # fmt: skip
        rows = np.empty((len(self.ends), kernel.N_ROW))
        for acc, row in zip(self.acc, rows, strict=True):
            kernel.hybrid_finish_lane(acc, row)
        return [hybrid_metrics_from(row, self.mechanism) for row in rows.tolist()]


def hybrid_metrics_from(row: Sequence[float], mechanism: HybridBoardingSystem) -> dict:
    """A lane's metrics dict from its row of reductions (`twin.sim.kernels.metrics`, N_ROW):
    counts as ints; joints q1, q2, roll, pitch, yaw in degrees, x, y, z, d3 and legs in m; tip
    position errors in m, orientation errors in degrees; φe, θe in degrees; η in %."""
    lower, upper = mechanism.lower.tolist(), mechanism.upper.tolist()  # floats: cheap to index
    leg_min, leg_max = mechanism.stewart.leg_min, mechanism.stewart.leg_max
    joints: dict[str, dict[str, float]] = {}
    for j, name in enumerate(JOINT_NAMES):
        scale = _DEGREES if name in _ANGLES else 1.0
        low, high = row[kernel.R_JOINT_MIN + j], row[kernel.R_JOINT_MAX + j]
        joints[name] = {
            "min": finite(low * scale),
            "max": finite(high * scale),
            "margin": finite(min(low - lower[j], upper[j] - high) * scale),
            "drift": finite(row[kernel.R_JOINT_DRIFT + j] * scale),
        }
    legs_low, legs_high = row[kernel.R_LEGS_MIN], row[kernel.R_LEGS_MAX]
    leg_drift = row[kernel.R_LEG_DRIFT : kernel.R_LEG_DRIFT + kernel.N_LEGS]
    return {
        "violations": int(row[kernel.R_VIOLATIONS]),
        "joint_violations": int(row[kernel.R_JOINT_VIOLATIONS]),
        "leg_violations": int(row[kernel.R_LEG_VIOLATIONS]),
        "table7": {  # seed 000 Table 7's columns: q1, q2 [deg], d3 [m], legs [m]
            "q1_max": joints["q1"]["max"], "q1_min": joints["q1"]["min"],
            "q2_max": joints["q2"]["max"], "q2_min": joints["q2"]["min"],
            "d3_max": joints["d3"]["max"], "d3_min": joints["d3"]["min"],
            "legs_max": finite(legs_high), "legs_min": finite(legs_low),
        },
        "joints": joints,
        "leg_margin": finite(min(legs_low - leg_min, leg_max - legs_high)),
        "leg_drift": [finite(v) for v in leg_drift],
        "tip_position_error_rms": finite(row[kernel.R_POSITION_RMS]),
        "tip_position_error_max": finite(row[kernel.R_POSITION_MAX]),
        "tip_orientation_error_rms": finite(row[kernel.R_ORIENTATION_RMS] * _DEGREES),
        "tip_orientation_error_max": finite(row[kernel.R_ORIENTATION_MAX] * _DEGREES),
        "manipulability_min": finite(row[kernel.R_MANIPULABILITY_MIN]),
        "phi_e_max": finite(row[kernel.R_PHI_E] * _DEGREES),
        "theta_e_max": finite(row[kernel.R_THETA_E] * _DEGREES),
        **efficacy_percent(row[kernel.R_ETA_PRINTED], row[kernel.R_ETA]),
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
        violated = model.violations(state, legs)  # the actuators', held at their stops
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

"""What a run is judged by: limits, tracking, drift, manipulability, end attitude, efficacy.

Every metric is a plain float (JSON-ready) and finite. The first `SETTLE` samples are left
out of min/max and error statistics, as seed 000 §5.3 drops its first 10 points.

The hybrid system's numbers are reduced by a compiled pass over every lane at once
(`twin.sim.kernels.metrics`); this module names them, converts them to the reported units and
keeps them finite. The small platforms' are reduced the same way (`PlatformReduction`): each
sample's limit flags in numpy, the running sums compiled.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from twin.compiled import pick_runner
from twin.mechanisms.hybrid import JOINT_NAMES, HybridBoardingSystem
from twin.mechanisms.upu3up import Upu3Up
from twin.planners.parameters import as_records
from twin.planners.platform_model import PlatformModel
from twin.sim.kernels import metrics as kernel
from twin.sim.kernels.metrics import SETTLE as SETTLE  # re-exported: claims, scripts

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
    return [hybrid_metrics_from(row, mechanism) for row in as_records(rows, kernel.HYBRID_ROW)]


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
        return as_records(self.acc, kernel.HYBRID_ACCUMULATOR)["seen"].astype(np.int64)

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
        # read in place: a chunk's records are strided views (its states and the record runner's
        # arrays from sample 1 on, the scalars' columns, t broadcast over the lanes), which a
        # contiguous copy would duplicate, 27 floats a sample
        self._run(*(np.asarray(records[key], dtype=float) for key in kernel.REDUCED),
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
        return [hybrid_metrics_from(row, self.mechanism)
                for row in as_records(rows, kernel.HYBRID_ROW)]  # fmt: skip


def hybrid_metrics_from(row: np.record, mechanism: HybridBoardingSystem) -> dict:
    """A lane's metrics dict from its row of reductions (`twin.sim.kernels.metrics.HYBRID_ROW`):
    counts as ints; joints q1, q2, roll, pitch, yaw in degrees, x, y, z, d3 and legs in m; tip
    position errors in m, orientation errors in degrees; φe, θe in degrees; η in %."""
    lower, upper = mechanism.lower.tolist(), mechanism.upper.tolist()  # floats: cheap to index
    leg_min, leg_max = mechanism.stewart.leg_min, mechanism.stewart.leg_max
    joints: dict[str, dict[str, float]] = {}
    for j, name in enumerate(JOINT_NAMES):
        scale = _DEGREES if name in _ANGLES else 1.0
        low, high = float(row.joint_min[j]), float(row.joint_max[j])
        joints[name] = {
            "min": finite(low * scale),
            "max": finite(high * scale),
            "margin": finite(min(low - lower[j], upper[j] - high) * scale),
            "drift": finite(row.joint_drift[j] * scale),
        }
    legs_low, legs_high = float(row.legs_min), float(row.legs_max)
    return {
        "violations": int(row.violations),
        "joint_violations": int(row.joint_violations),
        "leg_violations": int(row.leg_violations),
        "table7": {  # seed 000 Table 7's columns: q1, q2 [deg], d3 [m], legs [m]
            "q1_max": joints["q1"]["max"], "q1_min": joints["q1"]["min"],
            "q2_max": joints["q2"]["max"], "q2_min": joints["q2"]["min"],
            "d3_max": joints["d3"]["max"], "d3_min": joints["d3"]["min"],
            "legs_max": finite(legs_high), "legs_min": finite(legs_low),
        },
        "joints": joints,
        "leg_margin": finite(min(legs_low - leg_min, leg_max - legs_high)),
        "leg_drift": [finite(v) for v in row.leg_drift],
        "tip_position_error_rms": finite(row.position_rms),
        "tip_position_error_max": finite(row.position_max),
        "tip_orientation_error_rms": finite(row.orientation_rms * _DEGREES),
        "tip_orientation_error_max": finite(row.orientation_max * _DEGREES),
        "manipulability_min": finite(row.manipulability_min),
        "phi_e_max": finite(row.phi_e * _DEGREES),
        "theta_e_max": finite(row.theta_e * _DEGREES),
        **efficacy_percent(row.eta_printed, row.eta),
        "first_bound": first_bound(row.bound_t, hybrid_bound_name(row.bound)),
    }  # fmt: skip


def hybrid_bound_name(code: float) -> str | None:
    """The limit of a `twin.sim.kernels.metrics.hybrid_first_bound` code: "joint d3 (upper)",
    "leg 4 (lower)" (legs numbered 1-6 in the hinge order of seed 000 eq (1)); None for 0 (no
    violation)."""
    c = int(code) - 1
    if c < 0:
        return None
    side = "upper" if c % 2 else "lower"
    if c < 2 * kernel.N_JOINTS:
        return f"joint {JOINT_NAMES[c // 2]} ({side})"
    return f"leg {(c - 2 * kernel.N_JOINTS) // 2 + 1} ({side})"


def first_bound(t: float, limit: str | None) -> dict[str, Any] | None:
    """A run's first bound as its metrics give it: {"t": [s] its first violating sample,
    "limit": the limit that sample violates}, or None for a run that violates none."""
    return None if limit is None else {"t": finite(t), "limit": limit}


def platform_metrics(
    series: dict[str, np.ndarray],
    model: PlatformModel,
    joint_limits: str = "record",
    compiled: bool = True,
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

    The reduction is `PlatformReduction`'s, the series as one chunk: compiled (where numba
    imports) or with compiled=False interpreted; the same numbers.
    """
    reduction = PlatformReduction([model], np.array([len(series["t"])]), [joint_limits],
                                  compiled)  # fmt: skip
    reduction.add({key: np.asarray(values)[None] for key, values in series.items()}, 0)
    return reduction.results()[0]


def platform_metrics_lanes(
    data: dict[str, np.ndarray],
    ends: np.ndarray,
    models: Sequence[PlatformModel],
    joint_limits: Sequence[str],
    compiled: bool,
) -> list[dict]:
    """`platform_metrics` of N lanes at once from their series as (N, C, ...) arrays (a batch
    run's history, read in place), lane n over its first ends[n] samples: one chunk of
    `PlatformReduction`, one compiled pass over the lanes."""
    ends = np.asarray(ends, dtype=np.int64)
    reduction = PlatformReduction(models, ends, joint_limits, compiled)
    reduction.add({key: values[:, : int(ends.max())] for key, values in data.items()}, 0)
    return reduction.results()


class PlatformReduction:
    """The 3UPU_UP's or 4-UPR's metrics of N lanes reduced chunk by chunk, as the chunks are
    stepped (`platform_metrics` is one chunk of it): each lane's accumulator row
    (`twin.sim.kernels.metrics.platform_add_lane`, N_PLATFORM_ACC floats, a count per limit
    kind among them) is all it keeps, so its memory does not depend on the run's length.

    Each sample's limit flags are `PlatformModel.reached` (record mode, with the clamped
    demand) or `PlatformModel.violations` (hold mode) of the chunk's states and actuator
    lengths, in numpy; they read the mechanism's limits only, so one model serves every lane.

    Args:
        models: (N,) each lane's `PlatformModel` (one mechanism).
        ends: (N,) each lane's samples (≥ 1), from t = 0: its samples past its end are not added.
        joint_limits: (N,) each lane's `Scenario.joint_limits`.
        compiled: numba's runner (parallel over several lanes), or the interpreted one.
    """

    def __init__(
        self,
        models: Sequence[PlatformModel],
        ends: np.ndarray,
        joint_limits: Sequence[str],
        compiled: bool,
    ) -> None:
        self.models = list(models)
        self.model = self.models[0]
        self.ends = np.asarray(ends, dtype=np.int64)
        self.hold = np.array([mode == "hold" for mode in joint_limits], dtype=bool)
        # the limit kinds, in `violations`' order, then the clamped demand (record mode's)
        probe = self.model.violations(np.zeros(3), self.model.stroke[0])
        self.kinds = [*probe, "clamped"]
        if len(self.kinds) > kernel.MAX_LIMIT_KINDS:  # pragma: no cover - a new mechanism's
            raise ValueError(f"reduction: {len(self.kinds)} limit kinds, at most "
                             f"{kernel.MAX_LIMIT_KINDS} are counted")  # fmt: skip
        self.acc = np.empty((len(self.ends), kernel.N_PLATFORM_ACC))
        for row, end in zip(self.acc, self.ends.tolist(), strict=True):
            kernel.platform_begin_lane(row, end)
        self._run = pick_runner(
            kernel.compiled_platform_add, kernel.run_platform_add, compiled, len(self.ends)
        )
        self._finish = kernel.compiled_platform_finish() if compiled else kernel.run_platform_finish

    @property
    def seen(self) -> np.ndarray:
        """(N,) samples added so far per lane."""
        return as_records(self.acc, kernel.PLATFORM_ACCUMULATOR)["seen"].astype(np.int64)

    def flags(self, records: dict[str, np.ndarray]) -> np.ndarray:
        """(N, S, kinds) bool: each limit kind violated at each sample of a chunk (class doc)."""
        state, legs = records["state"], records["legs"]
        flags = np.zeros((*state.shape[:2], len(self.kinds)), dtype=bool)
        for hold in (False, True):
            lanes = np.flatnonzero(self.hold == hold)
            if not len(lanes):
                continue
            if hold:  # the actuators', held at their stops
                violated = self.model.violations(state[lanes], legs[lanes])
            else:
                violated = self.model.reached(state[lanes], legs[lanes])
                violated["clamped"] = records["clipped"][lanes] > 0
            for j, name in enumerate(self.kinds):
                if name in violated:
                    flags[lanes, :, j] = violated[name]
        return flags

    def add(self, records: dict[str, np.ndarray], start: int) -> None:
        """Add samples start … start + S − 1 of every lane (each up to its end), the next ones.

        Args:
            records: at least the keys of `twin.sim.kernels.metrics.PLATFORM_REDUCED` (and the
                Upu3Up's coupled_displacement), (N, S, ...) each.
            start: the index of the chunk's first sample (0: t = 0).

        Raises:
            ValueError: samples that do not follow those already added.
        """
        S = records["t"].shape[1]
        counts = np.clip(self.ends - start, 0, S)
        if np.any(self.seen != np.minimum(self.ends, start)):
            raise ValueError(f"reduction: samples from {start} on, after {self.seen.tolist()}")
        coupled = records.get("coupled_displacement")
        if coupled is None:
            coupled = np.empty((len(self.ends), S, 0))
        self._run(*(np.ascontiguousarray(records[key], dtype=float)
                    for key in kernel.PLATFORM_REDUCED),
                  np.ascontiguousarray(coupled, dtype=float), self.flags(records), counts,
                  self.acc)  # fmt: skip

    def results(self) -> list[dict]:
        """Every lane's metrics dict, as `platform_metrics` of the samples added (every lane's,
        up to its end).

        Raises:
            ValueError: a lane that has not had all its samples.
        """
        if np.any(self.seen != self.ends):
            raise ValueError(f"reduction: lanes have {self.seen.tolist()} of "
                             f"{self.ends.tolist()} samples")  # fmt: skip
        rows = np.empty((len(self.ends), kernel.N_PLATFORM_ROW))
        self._finish(self.acc, self.model.n_legs, rows)
        return [
            platform_metrics_from(acc, row, model, self.kinds, bool(hold))
            for acc, row, model, hold in zip(as_records(self.acc, kernel.PLATFORM_ACCUMULATOR),
                                             as_records(rows, kernel.PLATFORM_ROW), self.models,
                                             self.hold.tolist(), strict=True)
        ]  # fmt: skip


def platform_metrics_from(
    acc: np.record,
    row: np.record,
    model: PlatformModel,
    kinds: Sequence[str],
    hold: bool,
) -> dict:
    """A small platform lane's metrics dict (`platform_metrics`) from its accumulator row acc
    and its finished row (`twin.sim.kernels.metrics.PLATFORM_ACCUMULATOR`, `.PLATFORM_ROW`):
    counts as ints; state
    z and legs in the mechanism's unit, angles in degrees, `leg_rate_max` in m/s, tip position
    errors in m, orientation errors in degrees, η in %."""
    low, high = model.mechanism.state_limits
    states: dict[str, dict[str, float]] = {}
    for j, name in enumerate(model.mechanism.state_names):
        scale = 1.0 if j == 0 else _DEGREES
        x_min, x_max = float(acc.state_min[j]), float(acc.state_max[j])
        states[name] = {
            "min": finite(x_min * scale),
            "max": finite(x_max * scale),
            "margin": finite(min(x_min - low[j], high[j] - x_max) * scale),
            "drift": finite(row.state_drift[j] * scale),
        }
    stroke_low, stroke_high = model.stroke
    legs_low, legs_high = float(acc.legs_min), float(acc.legs_max)
    counted = kinds[:-1] if hold else kinds  # the clamped demand counts in record mode alone
    n_legs = model.n_legs
    metrics = {
        "violations": int(acc.violations),
        "limit_violations": {name: int(acc.kinds[j])
                             for j, name in enumerate(counted)},
        "states": states,
        "legs_min": finite(legs_low),
        "legs_max": finite(legs_high),
        "leg_margin": finite(min(legs_low - stroke_low[0], stroke_high[0] - legs_high)),
        "leg_drift": [finite(v) for v in row.leg_drift[:n_legs]],
        "leg_rate_max": finite(acc.rate_max * model.unit),
        "tip_position_error_rms": finite(row.position_rms),
        "tip_position_error_max": finite(acc.tip.position_max),
        "tip_orientation_error_rms": finite(row.orientation_rms * _DEGREES),
        "tip_orientation_error_max": finite(acc.tip.orientation_max * _DEGREES),
        "alpha_top_max": finite(acc.alpha_top_max * _DEGREES),
        "alpha_bottom_max": finite(acc.alpha_bottom_max * _DEGREES),
        "clipped": int(acc.clipped),
        "saturated": int(acc.saturated),
        **efficacy_percent(row.eta_printed, row.eta),  # seed 002 eq (29)
        # the first limit kind its first violating sample violates (kinds' names, as above)
        "first_bound": first_bound(acc.bound_t, kinds[int(acc.bound) - 1]
                                   if acc.bound > 0 else None),
    }  # fmt: skip
    if isinstance(model.mechanism, Upu3Up):  # seed 001 eq (15), mm
        peak = acc.coupled_max
        metrics["coupled_displacement_max"] = {
            a: finite(v) for a, v in zip("xyz", peak, strict=True)
        }
    return metrics


#: a chunk-by-chunk reduction of a mechanism's lanes (`twin.sim.engine.Simulation`'s
#: keep="metrics")
Reduction = HybridReduction | PlatformReduction

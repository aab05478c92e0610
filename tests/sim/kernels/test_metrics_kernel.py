"""The compiled reduction of the hybrid system's metrics (`twin.sim.kernels.metrics`) against
the numpy formulas it replaced, stated here as the oracle; compiled against interpreted; lanes
of different lengths in one call."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from twin.mechanisms.hybrid import JOINT_NAMES, HybridBoardingSystem
from twin.sim import simulate
from twin.sim.kernels import metrics as kernel
from twin.sim.lanes import numba_available
from twin.sim.metrics import SETTLE, hybrid_metrics, hybrid_metrics_lanes

H = HybridBoardingSystem()
ANGLES = {"roll", "pitch", "yaw", "q1", "q2"}


# ----------------------------------------------------------------------- the numpy oracle


def oracle_drift(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Least-squares slope of each column of x (T, k) over t, times the duration."""
    tc = t - t.mean()
    return (tc @ (x - x.mean(axis=0))) / max(float(tc @ tc), 1e-300) * (t[-1] - t[0])


def oracle_metrics(series: dict[str, np.ndarray], joint_limits: str) -> dict:
    """The hybrid metrics as numpy computed them before the compiled reduction."""

    def finite(x: float) -> float:
        return float(x) if np.isfinite(x) else 0.0

    def extreme(x: np.ndarray) -> float:
        return float(x[np.argmax(np.abs(x))])

    xi, legs, t = series["xi"], series["legs"], series["t"]
    lower, upper = H.lower, H.upper
    leg_min, leg_max = H.stewart.leg_min, H.stewart.leg_max
    if joint_limits == "record":
        joint_bad = np.any((xi <= lower + 1e-9) | (xi >= upper - 1e-9), axis=1)
    else:
        joint_bad = np.any((xi < lower - 1e-9) | (xi > upper + 1e-9), axis=1)
    leg_bad = np.any((legs < leg_min - 5e-4) | (legs > leg_max + 5e-4), axis=1)
    s = slice(min(SETTLE, len(t) - 1), None)
    err = series["tip_error"][s]
    pos_err = np.linalg.norm(err[:, :3], axis=1)
    rot_err = np.degrees(np.linalg.norm(err[:, 3:], axis=1))
    low, high, trend = xi[s].min(axis=0), xi[s].max(axis=0), oracle_drift(t, xi)
    joints = {}
    for j, name in enumerate(JOINT_NAMES):
        scale = np.degrees(1.0) if name in ANGLES else 1.0
        joints[name] = {
            "min": finite(low[j] * scale),
            "max": finite(high[j] * scale),
            "margin": finite(min(low[j] - lower[j], upper[j] - high[j]) * scale),
            "drift": finite(trend[j] * scale),
        }
    top, bottom = series["alpha_top"], series["alpha_bottom"]
    tilted = bottom > 1e-9
    printed = np.mean((bottom[tilted] - top[tilted]) / bottom[tilted]) if tilted.any() else 0.0
    denominator = np.sum(np.abs(bottom))
    integral = 1.0 - np.sum(np.abs(top)) / denominator if denominator > 0 else 0.0
    return {
        "violations": int(np.sum(joint_bad | leg_bad)),
        "joint_violations": int(np.sum(joint_bad)),
        "leg_violations": int(np.sum(leg_bad)),
        "table7": {
            "q1_max": joints["q1"]["max"], "q1_min": joints["q1"]["min"],
            "q2_max": joints["q2"]["max"], "q2_min": joints["q2"]["min"],
            "d3_max": joints["d3"]["max"], "d3_min": joints["d3"]["min"],
            "legs_max": finite(legs[s].max()), "legs_min": finite(legs[s].min()),
        },
        "joints": joints,
        "leg_margin": finite(min(legs[s].min() - leg_min, leg_max - legs[s].max())),
        "leg_drift": [finite(v) for v in oracle_drift(t, legs)],
        "tip_position_error_rms": finite(np.sqrt(np.mean(pos_err**2))),
        "tip_position_error_max": finite(pos_err.max()),
        "tip_orientation_error_rms": finite(np.sqrt(np.mean(rot_err**2))),
        "tip_orientation_error_max": finite(rot_err.max()),
        "manipulability_min": finite(series["manipulability"][s].min()),
        "phi_e_max": finite(np.degrees(extreme(series["phi_e"][s]))),
        "theta_e_max": finite(np.degrees(extreme(series["theta_e"][s]))),
        "eta_printed": finite(100 * printed),
        "eta": finite(100 * integral),
        "first_bound": oracle_first_bound(series, joint_bad | leg_bad, joint_limits),
    }  # fmt: skip


def oracle_first_bound(series: dict[str, np.ndarray], bad: np.ndarray, joint_limits: str) -> Any:
    """The first violating sample's time and the limit it passes furthest (share of range;
    the first of joints lower/upper in order, then legs, on a tie), or None."""
    if not bad.any():
        return None
    k = int(np.argmax(bad))
    x, legs = series["xi"][k], series["legs"][k]
    leg_min, leg_max = H.stewart.leg_min, H.stewart.leg_max
    past = np.stack([H.lower - x, x - H.upper], axis=1)
    flagged = past > 1e-9 if joint_limits == "hold" else past >= -1e-9
    shares = np.where(flagged, past / (H.upper - H.lower)[:, None], -np.inf).ravel()
    leg_past = np.stack([leg_min - legs, legs - leg_max], axis=1)
    leg_shares = np.where(leg_past > 5e-4, leg_past / (leg_max - leg_min), -np.inf).ravel()
    c = int(np.argmax(np.concatenate([shares, leg_shares])))
    side = ("lower", "upper")[c % 2]
    name = f"joint {JOINT_NAMES[c // 2]}" if c < 18 else f"leg {(c - 18) // 2 + 1}"
    return {"t": float(series["t"][k]), "limit": f"{name} ({side})"}


def leaves(value, path: str = "") -> dict:
    """path → leaf of nested dicts and lists."""
    if isinstance(value, dict):
        return {p: v for k, x in value.items() for p, v in leaves(x, f"{path}/{k}").items()}
    if isinstance(value, list):
        return {p: v for i, x in enumerate(value) for p, v in leaves(x, f"{path}/{i}").items()}
    return {path: value}


def assert_matches_oracle(got: dict, series: dict[str, np.ndarray], joint_limits: str) -> None:
    """Keys, order and types as the oracle's; counts, min/max and extremes equal; sums to
    1e-12 relative. A drift is a cancelling sum, so its error is relative to the range of its
    series (a flat joint's drift is rounding either way)."""
    want = oracle_metrics(series, joint_limits)
    got_leaves, want_leaves = leaves(got), leaves(want)
    assert list(got_leaves) == list(want_leaves)
    scales = [np.degrees(1.0) if name in ANGLES else 1.0 for name in JOINT_NAMES]
    ranges = {f"/joints/{name}/drift": np.ptp(series["xi"][:, j]) * scales[j]
              for j, name in enumerate(JOINT_NAMES)}  # fmt: skip
    ranges |= {f"/leg_drift/{j}": np.ptp(series["legs"][:, j]) for j in range(6)}
    exact = ("violations", "min", "max", "margin", "legs_max", "legs_min", "error_max", "_e_max",
             "first_bound", "/t", "/limit")  # fmt: skip
    for path, value in want_leaves.items():
        assert type(got_leaves[path]) is type(value), path
        if path.endswith(exact):
            assert got_leaves[path] == value, path
        else:
            tolerance = 1e-12 * (abs(value) + ranges.get(path, 0.0))
            assert abs(got_leaves[path] - value) <= tolerance, (path, got_leaves[path], value)


# ------------------------------------------------------------------------------- the runs


@pytest.fixture(scope="module")
def runs() -> list[tuple[dict, str]]:
    """(series, joint_limits) of MTMP and PI in a rough sea, recording and holding limits."""
    return [
        (simulate({"planner": planner, "sea_state": 7, "duration": 10.0, "seed": 2,
                   "joint_limits": mode}).series, mode)
        for planner in ("mtmp", "pi") for mode in ("record", "hold")
    ]  # fmt: skip


def test_runs_reduce_to_the_numpy_metrics(runs: list) -> None:
    """Each run's metrics from the compiled reduction are the numpy formulas' (violations in
    both modes among them)."""
    assert any(hybrid_metrics(s, H, mode)["violations"] > 0 for s, mode in runs)
    for series, mode in runs:
        assert_matches_oracle(hybrid_metrics(series, H, mode), series, mode)


def synthetic(T: int, seed: int) -> dict[str, np.ndarray]:
    """A series of T samples around the working state, inside every limit."""
    rng = np.random.default_rng(seed)
    t = np.arange(T) * 0.05
    xi = H.working_state + 0.01 * rng.standard_normal((T, 9)) + 1e-3 * t[:, None]
    return {
        "t": t, "xi": xi, "legs": 3.3 + 0.02 * rng.standard_normal((T, 6)),
        "tip_error": 1e-3 * rng.standard_normal((T, 6)),
        "manipulability": 0.5 + 0.1 * rng.random(T),
        "phi_e": 0.05 * rng.standard_normal(T), "theta_e": 0.05 * rng.standard_normal(T),
        "alpha_top": 0.01 * rng.random(T), "alpha_bottom": 0.05 * rng.random(T),
    }  # fmt: skip


@pytest.mark.parametrize("T", [1, 2, SETTLE, SETTLE + 1, 200])
def test_short_series_and_edge_cases(T: int) -> None:
    """T ≤ SETTLE judges the last sample alone; a tie in |φe| takes the first (np.argmax); a
    base never tilted gives η = 0 both ways; a joint on a limit counts in record mode only."""
    series = synthetic(T, T)
    first = min(SETTLE, T - 1)
    series["phi_e"][first:] = 0.0
    series["phi_e"][-1] = 0.2
    if T - first >= 2:  # a tie: -0.2 comes first
        series["phi_e"][first] = -0.2
    series["alpha_bottom"][:] = 0.0
    series["xi"][0, 6] = H.upper[6]  # q1 on its limit
    for mode in ("record", "hold"):
        got = hybrid_metrics(series, H, mode)
        assert_matches_oracle(got, series, mode)
        assert got["joint_violations"] == (mode == "record")
    got = hybrid_metrics(series, H)
    assert got["phi_e_max"] == pytest.approx(np.degrees(-0.2 if T - first >= 2 else 0.2))
    assert got["eta"] == got["eta_printed"] == 0.0
    if T == 1:
        assert got["leg_drift"] == [0.0] * 6


def stacked(series: list[dict[str, np.ndarray]]) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Lanes as (N, C, ...) arrays, each padded past its end with values that would show."""
    ends = np.array([len(s["t"]) for s in series])
    data = {}
    for key in kernel.REDUCED:
        shape = (len(series), ends.max() + 3, *series[0][key].shape[1:])
        data[key] = np.full(shape, 1e6)
        for n, s in enumerate(series):
            data[key][n, : ends[n]] = s[key]
    return data, ends


@pytest.mark.parametrize("compiled", [False, True])
def test_lanes_of_different_lengths_in_one_call(runs: list, compiled: bool) -> None:
    """Every lane reads its own first `end` samples only, in its own mode, compiled (parallel)
    or interpreted: each equals the lane alone."""
    lanes = [(s, mode) for s, mode in runs] + [(synthetic(T, T), "record") for T in (5, 57)]
    data, ends = stacked([s for s, _ in lanes])
    modes = [mode for _, mode in lanes]
    got = hybrid_metrics_lanes(data, ends, H, modes, compiled=compiled)
    for metrics, (series, mode) in zip(got, lanes, strict=True):
        assert metrics == hybrid_metrics(series, H, mode)


@pytest.mark.skipif(not numba_available(), reason="numba not installed")
def test_compiled_serial_parallel_and_interpreted_runners_agree_to_the_bit(runs: list) -> None:
    """No fast-math, sums in order: the three runners give the same rows."""
    data, ends = stacked([s for s, _ in runs] + [synthetic(33, 1)])
    hold = np.array([mode == "hold" for _, mode in runs] + [False])
    limits = (H.lower, H.upper, H.stewart.leg_min, H.stewart.leg_max)
    rows = []
    for run in (kernel.run_hybrid_reductions, kernel.compiled_hybrid_reductions(False),
                kernel.compiled_hybrid_reductions(True)):  # fmt: skip
        out = np.empty((len(ends), kernel.N_ROW))
        run(*(data[key] for key in kernel.REDUCED), ends, hold, *limits, out)
        rows.append(out)
    np.testing.assert_array_equal(rows[1], rows[0])
    np.testing.assert_array_equal(rows[2], rows[0])


@pytest.mark.parametrize("compiled", [False, True])
def test_the_first_bound_is_the_limit_reached_first_not_the_one_passed_furthest(
    compiled: bool,
) -> None:
    """d3 a millimetre past its upper limit at sample 20 (t = 1 s), leg 4 half a metre past its
    lower stroke from sample 30: the run bound first on d3 although it passed leg 4 further;
    with both at sample 20, the leg (the larger share of its range); before the judged samples
    (k < SETTLE) too; chunked as one run."""
    series = synthetic(60, 3)
    d3 = JOINT_NAMES.index("d3")
    series["xi"][20, d3] = H.upper[d3] + 1e-3
    series["legs"][30:, 3] = H.stewart.leg_min - 0.5
    for mode in ("record", "hold"):
        got = hybrid_metrics(series, H, mode, compiled=compiled)
        assert got["first_bound"] == {"t": 1.0, "limit": "joint d3 (upper)"}
        assert_matches_oracle(got, series, mode)
    series["legs"][20, 3] = H.stewart.leg_min - 0.5
    got = hybrid_metrics(series, H, compiled=compiled)
    assert got["first_bound"] == {"t": 1.0, "limit": "leg 4 (lower)"}
    series["xi"][2, 0] = H.lower[0] - 0.1  # x below its limit at sample 2, before SETTLE
    assert hybrid_metrics(series, H, compiled=compiled)["first_bound"] == {
        "t": 0.1, "limit": "joint x (lower)"}
    assert hybrid_metrics(synthetic(60, 3), H, compiled=compiled)["first_bound"] is None

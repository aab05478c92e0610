"""The small platforms' metrics reduced as they go (`twin.sim.metrics.PlatformReduction`, issue 28
item 6): against the numpy formulas they replaced, stated here as the oracle; chunk by chunk
against the whole series; compiled against interpreted; lanes of different lengths in one call."""

from __future__ import annotations

import numpy as np
import pytest

from twin.planners.platform_model import PlatformModel
from twin.planners.registry import PLANNERS
from twin.sim import Simulation
from twin.sim.metrics import SETTLE, PlatformReduction, platform_metrics, platform_metrics_lanes

from .kernels.test_metrics_kernel import leaves, oracle_drift

#: every planner of each small platform, both joint-limit modes, at sea state 9 (limits reached)
LANES = [
    {"mechanism": mechanism, "planner": name, "joint_limits": mode, "sea_state": 9, "seed": 2,
     "duration": 4.0 + 0.35 * i}
    for mechanism in ("upu3up", "upr4")
    for i, name in enumerate(sorted(n for n, s in PLANNERS.items() if mechanism in s.mechanisms))
    for mode in ("record", "hold")
]  # fmt: skip


def oracle_metrics(series: dict[str, np.ndarray], model: PlatformModel, joint_limits: str) -> dict:
    """The small platforms' metrics as numpy computed them over a whole series before the
    running reduction."""

    def finite(x: float) -> float:
        return float(x) if np.isfinite(x) else 0.0

    t, state, legs = series["t"], series["state"], series["legs"]
    s = slice(min(SETTLE, len(t) - 1), None)
    if joint_limits == "record":
        violated = model.reached(state, legs)
        violated["clamped"] = series["clipped"] > 0
    else:
        violated = model.violations(state, legs)
    bad = np.any(np.stack(list(violated.values())), axis=0)
    low, high = model.mechanism.state_limits
    states = {}
    for j, name in enumerate(model.mechanism.state_names):
        scale = 1.0 if j == 0 else np.degrees(1.0)
        x = state[:, j]
        states[name] = {
            "min": finite(x[s].min() * scale),
            "max": finite(x[s].max() * scale),
            "margin": finite(min(x[s].min() - low[j], high[j] - x[s].max()) * scale),
            "drift": finite(oracle_drift(t, x[:, None])[0] * scale),
        }
    stroke_low, stroke_high = model.stroke
    err = series["tip_error"][s]
    pos_err = np.linalg.norm(err[:, :3], axis=1)
    rot_err = np.degrees(np.linalg.norm(err[:, 3:], axis=1))
    top, bottom = series["alpha_top"], series["alpha_bottom"]
    tilted = bottom > 1e-9
    printed = np.mean((bottom[tilted] - top[tilted]) / bottom[tilted]) if tilted.any() else 0.0
    denominator = np.sum(np.abs(bottom))
    integral = 1.0 - np.sum(np.abs(top)) / denominator if denominator > 0 else 0.0
    metrics = {
        "violations": int(np.sum(bad)),
        "limit_violations": {name: int(np.sum(v)) for name, v in violated.items()},
        "states": states,
        "legs_min": finite(legs[s].min()),
        "legs_max": finite(legs[s].max()),
        "leg_margin": finite(min(legs[s].min() - stroke_low[0], stroke_high[0] - legs[s].max())),
        "leg_drift": [finite(v) for v in oracle_drift(t, legs)],
        "leg_rate_max": finite(np.abs(series["leg_rates"]).max() * model.unit),
        "tip_position_error_rms": finite(np.sqrt(np.mean(pos_err**2))),
        "tip_position_error_max": finite(pos_err.max()),
        "tip_orientation_error_rms": finite(np.sqrt(np.mean(rot_err**2))),
        "tip_orientation_error_max": finite(rot_err.max()),
        "alpha_top_max": finite(np.degrees(top[s].max())),
        "alpha_bottom_max": finite(np.degrees(bottom[s].max())),
        "clipped": int(np.sum(series["clipped"] > 0)),
        "saturated": int(np.sum(series["saturated"] > 0)),
        "eta_printed": finite(100 * printed),
        "eta": finite(100 * integral),
        "first_bound": None,
    }
    if bad.any():  # the first violating sample, the first kind it violates
        k = int(np.argmax(bad))
        kind = next(name for name, v in violated.items() if v[k])
        metrics["first_bound"] = {"t": float(t[k]), "limit": kind}
    if "coupled_displacement" in series:
        peak = np.abs(series["coupled_displacement"][s]).max(axis=0)
        metrics["coupled_displacement_max"] = {
            a: finite(v) for a, v in zip("xyz", peak, strict=True)
        }
    return metrics


def assert_matches_oracle(
    got: dict, series: dict[str, np.ndarray], model: PlatformModel, joint_limits: str
) -> None:
    """Keys, order and types as the oracle's; counts, min/max, margins and maxima equal; sums to
    1e-12 relative (a drift's relative to its series' magnitude: a cancelling sum, and a state
    held still, the Upr4's z, has a drift of rounding alone)."""
    want = oracle_metrics(series, model, joint_limits)
    got_leaves, want_leaves = leaves(got), leaves(want)
    assert list(got_leaves) == list(want_leaves)
    scales = [1.0, np.degrees(1.0), np.degrees(1.0)]
    size = {f"/states/{name}/drift": np.abs(series["state"][:, j]).max() * scales[j]
            for j, name in enumerate(model.mechanism.state_names)}  # fmt: skip
    size |= {f"/leg_drift/{j}": np.abs(series["legs"][:, j]).max() for j in range(model.n_legs)}
    exact = ("violations", "min", "max", "margin", "clipped", "saturated", "/x", "/y", "/z",
             "first_bound", "/t", "/limit")  # fmt: skip
    for path, value in want_leaves.items():
        assert type(got_leaves[path]) is type(value), path
        if path.endswith(exact) or path.startswith("/limit_violations"):
            assert got_leaves[path] == value, path
        else:
            tolerance = 1e-12 * (abs(value) + size.get(path, 0.0))
            assert abs(got_leaves[path] - value) <= tolerance, (path, got_leaves[path], value)


@pytest.fixture(scope="module")
def runs() -> list[tuple[dict, dict, Simulation]]:
    """(scenario, series, its Simulation) of every lane of LANES, whole series kept."""
    out = []
    for mechanism in ("upu3up", "upr4"):
        lanes = [lane for lane in LANES if lane["mechanism"] == mechanism]
        simulation = Simulation(lanes)
        simulation.run()
        out += [(lane, simulation.series(i), simulation) for i, lane in enumerate(lanes)]
    return out


def model_of(simulation: Simulation, lane: int) -> PlatformModel:
    return simulation.lanes.models[lane]  # type: ignore[attr-defined]  # PlatformLanes'


def test_every_platform_planner_reduces_to_the_numpy_metrics(runs: list) -> None:
    """Both mechanisms, every planner, record and hold: the reduction is the numpy formulas'
    (violations among them, and each mode's limit kinds: the clamped demand in record mode)."""
    assert sum(platform_metrics(s, model_of(sim, 0))["violations"] > 0 for _, s, sim in runs)
    for i, (lane, series, simulation) in enumerate(runs):
        lane_index = [x for x in LANES if x["mechanism"] == lane["mechanism"]].index(lane)
        model = model_of(simulation, lane_index)
        got = platform_metrics(series, model, lane["joint_limits"])
        assert_matches_oracle(got, series, model, lane["joint_limits"])
        assert ("clamped" in got["limit_violations"]) == (lane["joint_limits"] == "record"), i


@pytest.mark.parametrize("compiled", [False, True])
def test_chunk_by_chunk_equals_the_whole_series_to_the_bit(runs: list, compiled: bool) -> None:
    """Fed in uneven chunks (one inside the settling samples), lanes of different lengths in
    one reduction give `platform_metrics` of each whole series exactly, compiled or not; lanes
    reduced at once from (N, C, ...) arrays (`platform_metrics_lanes`) too."""
    for mechanism in ("upu3up", "upr4"):
        mine = [(lane, s, sim) for lane, s, sim in runs if lane["mechanism"] == mechanism]
        simulation = mine[0][2]
        models = simulation.lanes.models  # type: ignore[attr-defined]  # PlatformLanes'
        ends = np.array([len(s["t"]) for _, s, _ in mine])
        modes = [lane["joint_limits"] for lane, _, _ in mine]
        data = simulation.history.data
        reduction = PlatformReduction(models, ends, modes, compiled)
        start = 0
        for size in [3, 5, 1, 17, 64, 7, 29, 1000]:
            reduction.add({key: v[:, start : start + size] for key, v in data.items()}, start)
            start += size
        want = [platform_metrics(s, models[n], modes[n], compiled)
                for n, (_, s, _) in enumerate(mine)]  # fmt: skip
        assert reduction.results() == want
        assert platform_metrics_lanes(data, ends, models, modes, compiled) == want


def test_a_platform_reduction_takes_samples_in_order_and_gives_metrics_at_the_end(
    runs: list,
) -> None:
    """Samples out of order and metrics before the end are refused."""
    _, series, simulation = runs[0]
    T = len(series["t"])
    reduction = PlatformReduction([model_of(simulation, 0)], np.array([T]), ["record"], True)
    chunk = {key: v[None] for key, v in series.items()}
    with pytest.raises(ValueError, match="samples from 5 on"):
        reduction.add({key: v[:, 5:] for key, v in chunk.items()}, 5)
    reduction.add({key: v[:, :12] for key, v in chunk.items()}, 0)
    with pytest.raises(ValueError, match=f"have \\[12\\] of \\[{T}\\] samples"):
        reduction.results()

"""`HybridLanes` and `PlatformLanes` implement the engine's `Lanes` protocol
(twin/sim/protocols.py): by their members, their call signatures, and what the engine gets
back when it drives them."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conformance import conformance
from twin.sim.engine import LANES, Simulation
from twin.sim.lanes import HybridLanes, PlatformLanes
from twin.sim.metrics import HybridReduction, PlatformReduction
from twin.sim.protocols import Lanes, ReducingLanes

#: two lanes with different planners, so `keys` has two families to tell apart (hybrid)
SCENARIOS = {
    "hybrid": [{"planner": "mtmp"}, {"planner": "dwa"}],
    "upu3up": [{"planner": "pid"}, {"planner": "ik"}],
    "upr4": [{"planner": "pid"}, {"planner": "ik"}],
}


def simulation(mechanism: str) -> Simulation:
    """Two lanes of `mechanism`, interpreted (nothing to compile)."""
    base = {"mechanism": mechanism, "duration": 0.2, "seed": 1}
    return Simulation([{**base, **s} for s in SCENARIOS[mechanism]], engine="python")


def test_the_engine_knows_both_lane_classes() -> None:
    """The lane registry maps hybrid to HybridLanes and both platforms to PlatformLanes."""
    assert set(LANES.values()) == {HybridLanes, PlatformLanes}
    assert LANES["hybrid"] is HybridLanes
    assert LANES["upu3up"] is LANES["upr4"] is PlatformLanes


@pytest.mark.parametrize("mechanism", sorted(SCENARIOS))
def test_lanes_implement_the_protocol(mechanism: str) -> None:
    """Each mechanism's lanes conform to the Lanes protocol (and hybrid's to ReducingLanes) with the
    shapes it promises."""
    sim = simulation(mechanism)
    lanes = sim.lanes
    assert isinstance(lanes, Lanes)
    assert conformance(lanes, Lanes) == []
    N = sim.n_lanes
    assert lanes.kind == ("hybrid" if mechanism == "hybrid" else "platform")
    assert lanes.x0.shape[0] == N and np.array_equal(lanes.x0, sim.x)
    assert lanes.held.shape == (N, 4, 4)
    np.testing.assert_allclose(lanes.held[:, 3], np.tile([0.0, 0.0, 0.0, 1.0], (N, 1)))
    assert isinstance(lanes.n_diagnostics, int) and lanes.n_diagnostics > 0
    assert (lanes.extra is None) == (mechanism == "hybrid")
    for s in sim.scenarios:  # a lane's diagnostics are among every family's
        assert lanes.keys(s.planner_name) <= lanes.diagnostics
    # keep="metrics": the lanes make their own running metrics; the hybrid's reduce as they
    # record (the engine asks the protocol, never the class)
    hybrid = mechanism == "hybrid"
    reduction = lanes.reduction(np.array([5, 3]), ["record", "hold"])
    assert isinstance(reduction, HybridReduction if hybrid else PlatformReduction)
    assert reduction.ends.tolist() == [5, 3] and reduction.hold.tolist() == [False, True]
    assert isinstance(lanes, ReducingLanes) == hybrid
    if hybrid:
        assert conformance(lanes, ReducingLanes) == []


@pytest.mark.parametrize("mechanism", sorted(SCENARIOS))
def test_the_engine_drives_lanes_through_the_protocol(mechanism: str) -> None:
    """What `Simulation` calls (`pack`, `run`, `records`, `initial_records`, `metrics`,
    `metrics_lanes`) gives what the protocol says: the state under `state_key`, one row per
    lane and sample, metrics per lane."""
    sim = simulation(mechanism)
    lanes = sim.lanes
    start = lanes.initial_records(sim._block.poses[:, :1], sim.x)
    assert start[lanes.state_key].shape == (sim.n_lanes, 1, sim.x.shape[1])
    steps = sim.advance(3)
    assert steps == 3
    series = sim.series(1)
    assert series[lanes.state_key].shape == (4, sim.x.shape[1])
    assert np.all(np.isfinite(series[lanes.state_key]))
    one = lanes.metrics(series, 1, sim.scenarios[1].joint_limits)
    assert isinstance(one, dict) and one
    every = [r.metrics for r in sim.results()]
    assert len(every) == sim.n_lanes
    assert set(every[1]) >= set(one)
    hybrid = mechanism == "hybrid"
    if hybrid:  # another family's diagnostics are left out of a lane's series
        assert "position_share" in sim.series(1) and "position_share" not in sim.series(0)
        assert "null_space_share" in sim.series(0) and "null_space_share" not in sim.series(1)


"""Numerical faults injected into running simulations: each is held, damped or clamped,
flagged and counted; no record ever holds NaN; the live loop goes on (twin/sim/faults.py)."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest

from tests.figures import record
from tests.timing import scaled
from twin.planners.parameters import as_record
from twin.sim import Simulation
from twin.sim.base_motion import BaseMotion
from twin.sim.faults import Fault, FaultLog, hold_invalid, hold_nonfinite
from twin.sim.kernels.layout import COMMON_PARAMETERS
from twin.sim.live import LiveSession

#: [s] the window of simulated time whose base motion is NaN
WINDOW = (1.0, 1.5)


def all_finite(series: dict[str, np.ndarray]) -> bool:
    return all(np.all(np.isfinite(v)) for v in series.values() if v.dtype.kind == "f")


@pytest.mark.parametrize("mechanism", ["hybrid", "upu3up", "upr4"])
def test_nan_base_motion_holds_the_last_good_pose_and_is_flagged(
    nan_sea: Callable[..., None], mechanism: str
) -> None:
    """A NaN base-motion window holds the last good pose, counts one fault per step touching it,
    logs one event, and the run stays finite."""
    nan_sea(*WINDOW)
    sim = Simulation({"mechanism": mechanism, "sea_state": 4, "duration": 3.0})
    run = sim.run()
    t, base = run.series["t"], run.series["base_pose"]
    assert all_finite(run.series)
    inside = (t >= WINDOW[0] - 1e-9) & (t <= WINDOW[1] + 1e-9)
    last_good = np.flatnonzero(t < WINDOW[0] - 1e-9)[-1]
    np.testing.assert_array_equal(
        base[inside], np.broadcast_to(base[last_good], base[inside].shape)
    )
    assert not np.array_equal(base[-1], base[last_good])  # the sea moves again afterwards
    # a step reads its start and end sample: the window's samples and the one step before it
    assert run.metrics["fault_counts"]["base_motion"] == inside.sum() + 1
    assert run.metrics["faults"] == inside.sum() + 1
    assert sim.faults[0].events[0].kinds == ("base_motion",)
    event = sim.faults[0].events[0]
    assert (event.start, event.end) == pytest.approx((WINDOW[0], WINDOW[1] + 0.05))
    json.dumps(run.metrics, allow_nan=False)
    record(f"fault_nan_base_{mechanism}", steps=int(inside.sum() + 1), held=run.metrics["faults"])


def test_a_sea_that_raises_is_held_like_nan(monkeypatch: pytest.MonkeyPatch) -> None:
    # a live session's history: base motion is sampled 256 steps (12.8 s) ahead
    """A sea whose evaluation raises is held at the last good pose like NaN, the run finite and the
    faults counted."""
    sim = Simulation({"sea_state": 3, "duration": 20.0}, history_limit=1000)

    def broken(*args: object, **kwargs: object) -> np.ndarray:
        raise FloatingPointError("overflow in the RAO interpolation")

    monkeypatch.setattr(BaseMotion, "poses", broken)
    monkeypatch.setattr(BaseMotion, "uniform_poses", staticmethod(broken))
    run = sim.run()  # the second chunk (t > 12.8 s) cannot be evaluated
    assert all_finite(run.series) and run.metrics["fault_counts"]["base_motion"] > 100
    held = run.series["base_pose"][run.series["t"] > 13.0]
    assert np.all(held == held[0])


@pytest.mark.parametrize("mechanism", ["hybrid", "upu3up", "upr4"])
def test_a_planner_fault_holds_the_state_for_the_step(
    nan_target: Callable[..., None], mechanism: str
) -> None:
    """A non-finite planner velocity (a NaN target twist at step 4, injected): the state is
    held for that step, flagged PLANNER and counted; the next steps move on; nothing NaN."""
    nan_target(4)
    sim = Simulation({"mechanism": mechanism, "sea_state": 4, "duration": 1.0})
    run = sim.run()
    x = run.series["xi" if mechanism == "hybrid" else "state"]
    np.testing.assert_array_equal(x[5], x[4])
    assert not np.array_equal(x[6], x[5])
    assert run.metrics["fault_counts"]["planner"] == 1 and run.metrics["faults"] == 1
    assert sim.faults[0].events[-1].kinds == ("planner",)
    assert all_finite(run.series)


@pytest.mark.parametrize("mechanism", ["upu3up", "upr4"])
def test_platform_forward_kinematics_that_fails_holds_the_platform(mechanism: str) -> None:
    """Actuator lengths no pose meets (one actuator's encoder jumps to the far end of its
    stroke): forward kinematics fails, the platform is held and KINEMATICS is flagged; the
    run goes on, finite."""
    sim = Simulation({"mechanism": mechanism, "planner": "ik", "sea_state": 4, "duration": 1.0})
    sim.advance(2)
    low, high = sim.lanes.model.stroke
    sim.lanes.extra[0, 0] = high[0]  # one leg at full stroke, the others mid-way
    sim.lanes.extra[0, 1] = low[1]
    sim.advance(1)
    flagged = sim.faults[0].counts["kinematics"] + sim.faults[0].counts["planner"]
    run = sim.run()
    state = run.series["state"]
    if sim.faults[0].counts["kinematics"]:
        np.testing.assert_array_equal(state[3], state[2])
    assert flagged >= 1 and all_finite(run.series)


def test_a_near_singular_jacobian_is_damped_and_flagged() -> None:
    """With the damping threshold ε raised above every singular value of J_W (the packed
    planner's ε set to 10), damped least squares engages at every step: the velocity stays
    finite and bounded, and every step is flagged singular."""
    sim = Simulation({"planner": "mtmp", "sea_state": 4, "duration": 2.0})
    epsilon = _epsilon_row(sim)
    sim.prm[:, epsilon] = 10.0
    run = sim.run()
    assert all_finite(run.series)
    assert run.metrics["fault_counts"]["singular"] == len(run.series["t"])
    assert np.all(run.series["damping"] > 0)
    # the 9-DOF step stays physical: below 1 m/s and 1 rad/s on every virtual joint
    rates = np.abs(np.diff(run.series["xi"], axis=0)) / 0.05
    assert rates.max() < 1.0
    record("fault_near_singular", steps=len(run.series["t"]), max_rate=float(rates.max()))


def _epsilon_row(sim: Simulation) -> int:
    """The prm row holding ε: the offset of the field `epsilon` of the differential record."""
    from twin.planners.families import DIFFERENTIAL_PARAMETERS

    del sim  # Unused: every differential lane's row has the same fields.
    return DIFFERENTIAL_PARAMETERS.fields["epsilon"][1] // 8


def test_holding_at_the_limits_stops_legs_at_their_stroke() -> None:
    """PI drives the legs out of their stroke (Table 7); with `joint_limits="hold"` each such
    step is shortened at the limit and flagged, and no leg ever passes it."""
    # γ 3.3 and 200 components (the former defaults): a sea in which PI leaves the stroke
    # within 40 s, which the DNV γ = 1 sea of 800 components at sea state 4 does not
    scenario = {"planner": "pi", "sea_state": 4, "duration": 40.0, "gamma": 3.3,
                "n_components": 200}  # fmt: skip
    free = Simulation(scenario).run()
    held = Simulation({**scenario, "joint_limits": "hold"}).run()
    assert free.series["legs"].max() > 4.18 + 0.05  # PI alone leaves the stroke
    legs = held.series["legs"]
    assert legs.max() <= 4.18 + 1e-9 and legs.min() >= 2.58 - 1e-9
    assert held.metrics["violations"] == 0
    limited = held.metrics["fault_counts"]["joint_limit"]
    assert limited > 0 and limited == np.sum(held.series["limit_scale"] < 1)
    assert held.metrics["faults"] == 0  # shortened steps are not holds
    record("fault_joint_limit", steps=len(legs), limited=int(limited))


def test_joint_limits_switch_live_without_a_restart() -> None:
    """Switching joint_limits to hold mid-run changes the packed parameter without restarting the
    run."""
    sim = Simulation({"planner": "pi", "sea_state": 4, "duration": 40.0})
    for _ in range(10):
        sim.step()
    sim.update({"joint_limits": "hold"})
    assert as_record(sim.prm[0], COMMON_PARAMETERS).hold == 1.0 and sim.k == 10


# -- the pure pieces ------------------------------------------------------------------------------


def test_hold_invalid_carries_the_last_good_pose_across_batches() -> None:
    """hold_invalid replaces each non-finite pose with the last good one (carried in across
    batches), per lane."""
    pose = np.arange(30.0).reshape(5, 6)
    pose[0], pose[3], pose[4] = np.nan, np.inf, np.nan
    out, bad = hold_invalid(pose, last_good=np.full(6, 7.0))
    assert bad.tolist() == [True, False, False, True, True]
    np.testing.assert_array_equal(out[0], np.full(6, 7.0))
    np.testing.assert_array_equal(out[3], out[2])
    np.testing.assert_array_equal(out[4], out[2])
    np.testing.assert_array_equal(out[1:3], np.arange(6.0, 18.0).reshape(2, 6))
    # lanes at once: each holds its own last good pose, and a good lane is left alone
    lanes, bad = hold_invalid(np.stack([pose, np.ones((5, 6))]), np.stack([np.full(6, 7.0),
                                                                          np.zeros(6)]))
    np.testing.assert_array_equal(lanes[0], out)
    np.testing.assert_array_equal(lanes[1], np.ones((5, 6)))
    assert bad.tolist() == [[True, False, False, True, True], [False] * 5]


def test_hold_nonfinite_fills_from_the_sample_before() -> None:
    """Two lanes, three samples: a NaN takes the previous sample's value (the history's newest
    for the first sample, then the chunk's own), an inf with no finite value before takes 0;
    only the rows touched are reported."""
    previous = {"a": np.array([[1.0, 2.0], [7.0, np.nan]]), "b": np.array([3.0, 4.0])}
    records = {
        "a": np.array([[[np.nan, 5.0], [6.0, np.nan], [1.0, 1.0]],
                       [[8.0, np.inf], [9.0, 9.0], [9.0, 9.0]]]),
        "b": np.array([[4.0, 4.0, 4.0], [np.nan, 5.0, 5.0]]),
    }  # fmt: skip
    rows = hold_nonfinite(records, previous)
    assert rows.tolist() == [[True, True, False], [True, False, False]]
    assert records["a"][0].tolist() == [[1.0, 5.0], [6.0, 5.0], [1.0, 1.0]]
    assert records["a"][1, 0].tolist() == [8.0, 0.0] and records["b"][1, 0] == 4.0
    untouched = {"a": np.ones((2, 2, 2)), "b": np.ones((2, 2))}
    assert not hold_nonfinite(untouched, previous).any()


def test_hold_nonfinite_on_views_of_shared_arrays() -> None:
    """Records that are views of one array (the kernel's diagnostics, say) are held alike: a
    NaN in the array but outside every view changes nothing, one inside a view is held."""
    diag = np.ones((2, 4, 3))
    diag[1, 3, 2] = np.nan  # outside both views below
    records = {"a": diag[:, :3, 0], "b": diag[:, :3, 1:2]}
    previous = {"a": np.zeros(2), "b": np.zeros((2, 1))}
    assert not hold_nonfinite(records, previous).any()
    diag[0, 1, 1] = np.inf
    rows = hold_nonfinite(records, previous)
    assert rows.tolist() == [[False, True, False], [False, False, False]]
    assert diag[0, 1, 1] == 1.0 and np.isnan(diag[1, 3, 2])


@pytest.mark.parametrize("seed", range(5))
def test_fault_log_of_a_chunk_equals_step_by_step(seed: int) -> None:
    """`add_chunk` gives `add`'s counts, holds and events, across chunk edges, whatever the
    mix of faults (including long runs that push old events out)."""
    rng = np.random.default_rng(seed)
    choices = [0, 0, 0, 1, 2, 8, 16, 24, 3]
    bits = np.array(rng.choice(choices, size=400))
    bits[100:180] = 8  # a long run
    t = 0.05 * np.arange(1, 401)
    one, many = FaultLog(keep=6), FaultLog(keep=6)
    for ti, b in zip(t, bits, strict=True):
        one.add(float(ti), Fault(int(b)))
    for start in range(0, 400, 37):
        many.add_chunk(t[start : start + 37], bits[start : start + 37])
    assert many.summary() == one.summary()


def test_fault_log_merges_a_running_fault_and_bounds_its_events() -> None:
    """FaultLog merges consecutive faults of one kind into an event, keeps at most `keep` events,
    and counts every hold."""
    log = FaultLog(keep=3)
    for k in range(10):
        log.add(0.1 * k, Fault.BASE_MOTION)
    assert len(log.events) == 1
    assert (log.events[0].start, log.events[0].end) == pytest.approx((0.0, 0.9))
    for k in range(10):
        log.add(1.0 + k, Fault.PLANNER if k % 2 else Fault.SINGULAR)
    assert len(log.events) == 3 and log.counts["planner"] == 5 and log.counts["singular"] == 5
    assert log.holds == 15
    json.dumps(log.summary(), allow_nan=False)


# -- the live session -----------------------------------------------------------------------------


@pytest.fixture
def live() -> Iterator[LiveSession]:
    session = LiveSession({"sea_state": 4})
    yield session
    session.stop()


def test_live_session_reports_faults_and_never_nan(
    nan_sea: Callable[..., None], live: LiveSession
) -> None:
    """A live session over a NaN sea reports the base-motion faults and event in its JSON snapshot
    and serves no NaN."""
    nan_sea(0.5, 1.0)
    live.reset()  # the patched sea from t = 0
    live.pause()
    live.step(60)
    snapshot = live.snapshot()
    assert snapshot["faults"]["counts"]["base_motion"] == 12
    assert snapshot["faults"]["events"][0]["kinds"] == ["base_motion"]
    json.dumps(snapshot, allow_nan=False)  # what the REST API serves
    assert all_finite(live.series())


def test_the_live_loop_survives_a_step_that_raises(live: LiveSession) -> None:
    """An unexpected error inside a step is logged and counted; simulated time goes on."""
    advance, calls = live._sim.advance, []

    def flaky(n: int) -> int:
        calls.append(1)
        if len(calls) == 3:
            raise RuntimeError("a bug")
        return advance(n)

    live._sim.advance = flaky
    live.start()
    deadline = time.monotonic() + scaled(5)
    while (live.loop_errors == 0 or live.snapshot()["t"] < 0.5) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert live.loop_errors == 1 and live.snapshot()["t"] >= 0.5
    assert live.snapshot()["faults"]["loop_errors"] == 1

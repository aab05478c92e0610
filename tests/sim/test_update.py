"""Changing a running simulation: takes effect on the next step, bad values change nothing."""

from __future__ import annotations

import numpy as np
import pytest

from twin.sim import Simulation

BASE = {"mechanism": "hybrid", "planner": "wpi", "sea_state": 3, "duration": 30.0}


def run(sim: Simulation, n: int) -> None:
    for _ in range(n):
        sim.step()


def test_parameter_change_applies_on_the_next_step() -> None:
    """β changed at step 50 gives the same run as a fresh planner with that β from there on:
    the platform/gangway split changes immediately (seed 000 eq (28))."""
    changed = Simulation(BASE)
    run(changed, 50)
    assert changed.update({"beta": 0.2}) == {"beta"}
    run(changed, 50)
    unchanged = Simulation(BASE)
    run(unchanged, 100)
    a, b = changed.series()["xi"], unchanged.series()["xi"]
    np.testing.assert_array_equal(a[:51], b[:51])  # identical up to the change
    share = lambda xi: np.abs(np.diff(xi[:, 8])).sum()  # noqa: E731 - telescope travel
    assert share(a[51:]) > 1.5 * share(b[51:])  # lower β hands more to the gangway
    assert changed.scenario.beta == 0.2


def test_bad_update_raises_and_changes_nothing() -> None:
    """A bad update raises ValueError and leaves the scenario unchanged; changing dt asks for a new
    simulation."""
    sim = Simulation(BASE)
    run(sim, 5)
    before = sim.scenario
    for bad in ({"beta": 2.0}, {"k_e": float("nan")}, {"planner": "pid"}, {"nope": 1}):
        with pytest.raises(ValueError):
            sim.update(bad)
        assert sim.scenario is before
    with pytest.raises(ValueError, match="new simulation"):
        sim.update({"dt": 0.02})
    run(sim, 5)  # still steps


def test_sea_change_keeps_running_and_the_tip_recovers() -> None:
    """A new sea state re-synthesises the sea mid-run; the tip re-converges within a second."""
    sim = Simulation({**BASE, "planner": "mtmp"})
    run(sim, 100)
    sim.update({"sea_state": 4, "seed": 7})
    records = [sim.step() for _ in range(100)]
    errors = np.array([np.linalg.norm(r["tip_error"][:3]) for r in records])
    assert np.all(np.isfinite(errors))
    assert errors[20:].max() < 1e-3


def test_history_limit_is_a_ring_buffer() -> None:
    """With history_limit 50 the history keeps the newest 50 samples, oldest first."""
    sim = Simulation(BASE, history_limit=50)
    run(sim, 120)
    assert len(sim.history) == 50
    t = sim.series()["t"]
    np.testing.assert_allclose(t, np.arange(71, 121) * 0.05)  # the newest 50, oldest first


def test_a_sea_change_that_fails_changes_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """The new sea is built before any state moves: if building it raises, the scenario,
    the sea and the step count stay as they were."""
    from twin.sim.base_motion import BaseMotion

    sim = Simulation({"sea_state": 3, "duration": 10.0})
    run(sim, 5)
    before = (sim.scenario, sim.base_motion, sim.k)

    def broken(cls, scenarios):
        raise ValueError("tp: the RAO table does not reach this frequency")

    monkeypatch.setattr(BaseMotion, "many", classmethod(broken))
    with pytest.raises(ValueError, match="RAO table"):
        sim.update({"sea_state": 6, "beta": 0.2})
    assert (sim.scenario, sim.base_motion, sim.k) == before and sim.scenario.beta == 0.7


def test_a_calm_sea_keeps_its_period_in_range_and_runs() -> None:
    """hs = 0 without tp: the fully developed tp (0 s) is kept at the 1 s floor."""
    sim = Simulation({"sea_state": 3, "duration": 1.0})
    sim.update({"hs": 0.0})
    assert sim.scenario.sea() == (0.0, 1.0)
    result = sim.run()
    assert np.all(np.isfinite(result.series["xi"]))
    np.testing.assert_allclose(result.series["base_pose"][-1], result.series["base_pose"][-2])

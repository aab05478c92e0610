"""LiveSession: pacing, patches between steps, bad input changes nothing, never NaN."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from twin.sim.live import LiveSession


@pytest.fixture
def live() -> LiveSession:
    return LiveSession({"sea_state": 3})


def test_advance_paces_simulated_time_to_wall_time_times_speed(live: LiveSession) -> None:
    """advance steps simulated time equal to the wall time given times the speed."""
    assert live.advance(0.5) == 10  # 0.5 s at dt 0.05
    live.patch({"speed": 4.0})
    assert live.advance(0.25) == 20
    assert live.snapshot()["t"] == pytest.approx(1.5)


def test_pause_play_and_single_step(live: LiveSession) -> None:
    """Paused, advance steps nothing and step moves one dt; playing, advance steps again."""
    live.pause()
    assert live.advance(1.0) == 0
    live.step()
    assert live.snapshot()["t"] == pytest.approx(0.05)
    live.play()
    assert live.advance(0.1) == 2


def test_patch_takes_effect_and_bad_patch_changes_nothing(live: LiveSession) -> None:
    """A valid patch takes effect; each bad patch raises ValueError and changes nothing."""
    live.advance(1.0)
    assert live.patch({"beta": 0.3, "speed": 2.0}) == {"beta", "speed"}
    assert live.scenario.beta == 0.3 and live.controls.speed == 2.0
    before = live.snapshot()
    for bad in ({"beta": -1}, {"speed": 100}, {"k_c": float("nan")}, {"planner": "nope"},
                {"bogus": 1}):  # fmt: skip
        with pytest.raises(ValueError):
            live.patch(bad)
    after = live.snapshot()
    assert {k: after[k] for k in ("beta", "speed", "planner", "t")} == {
        k: before[k] for k in ("beta", "speed", "planner", "t")
    }


def test_mechanism_change_restarts(live: LiveSession) -> None:
    """Patching the mechanism restarts the session at t = 0 with a new version and finite legs."""
    live.advance(1.0)
    version = live.version
    live.patch({"mechanism": "upr4", "planner": "pid"})
    assert live.version == version + 1 and live.snapshot()["t"] == 0.0
    live.advance(0.5)
    assert np.all(np.isfinite(live.latest()["legs"]))


def test_stall_drops_time_instead_of_spiralling(live: LiveSession) -> None:
    """After a stall, advance catches up at most MAX_CATCH_UP steps and owes nothing afterwards."""
    assert live.advance(60.0) == 40  # MAX_CATCH_UP
    assert live.advance(0.0) == 0  # nothing owed afterwards


def test_background_loop_runs_in_real_time() -> None:
    """The background loop keeps simulated time near wall time (0.5-1.3 s after 1 s), values
    finite."""
    live = LiveSession({"sea_state": 3}, tick=0.01)
    live.start()
    try:
        time.sleep(1.0)
    finally:
        live.stop()
    t = live.snapshot()["t"]
    assert 0.5 <= t <= 1.3  # paced to the wall clock, not as fast as possible
    assert all(np.all(np.isfinite(v)) for v in live.latest().values())


def test_vessel_speed_and_sim_speed_are_separate_knobs(live: LiveSession) -> None:
    """`forward_speed` is the vessel's [m/s]; `speed` is simulated/wall time."""
    live.patch({"forward_speed": 2.0, "speed": 3.0})
    assert live.scenario.forward_speed == 2.0
    assert live.controls.speed == 3.0
    snapshot = live.snapshot()
    assert (snapshot["forward_speed"], snapshot["speed"]) == (2.0, 3.0)


def test_a_tick_that_cannot_keep_up_stops_at_its_budget(live: LiveSession) -> None:
    """Owed 40 steps with a budget that one chunk of steps already spends: that chunk is
    taken, the rest dropped, so the lock is free again within about one chunk."""
    taken = live.advance(2.0, budget=1e-9)
    assert 1 <= taken < 40
    assert live.advance(0.0) == 0  # the rest is not owed


def test_playing_is_strictly_a_bool_and_empty_names_change_nothing(live: LiveSession) -> None:
    """A non-bool playing, an empty name or a run-only field raises ValueError and leaves the
    snapshot unchanged."""
    before = live.snapshot()
    for bad in ({"playing": "false"}, {"playing": 0}, {"playing": None}, {"planner": ""},
                {"planner": "", "beta": 0.2}, {"mechanism": ""}, {"duration": 5.0},
                {"mechanism": "upr4", "planner": ""}):  # fmt: skip
        with pytest.raises(ValueError):
            live.patch(bad)
    assert live.snapshot() == before
    assert live.patch({"playing": False}) == {"playing"} and not live.controls.playing


def test_step_lets_go_of_the_lock_between_chunks_and_stops_at_its_cap(
    live: LiveSession, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`step(n)` holds the lock one chunk at a time: a reader waiting for it gets it within a
    chunk; past `max_seconds` it stops, saying how many steps it took."""
    advance = LiveSession._advance

    def slow(self: LiveSession, n: int) -> None:
        time.sleep(0.002 * n)
        advance(self, n)

    monkeypatch.setattr(LiveSession, "_advance", slow)
    waits: list[float] = []

    def reader() -> None:
        for _ in range(5):
            start = time.perf_counter()
            live.snapshot()
            waits.append(time.perf_counter() - start)
            time.sleep(0.02)

    thread = threading.Thread(target=reader)
    thread.start()
    taken = live.step(1000, max_seconds=0.25)
    thread.join()
    assert 0 < taken < 1000 and live.snapshot()["t"] == pytest.approx(taken * 0.05)
    assert len(waits) == 5 and max(waits) < 0.15, waits  # a chunk is 16 × 2 ms
    assert live.step(3) == 3

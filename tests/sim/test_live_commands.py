"""The live session's writers go through a command queue that its own thread applies; a change
that restarts the simulation builds the new `Simulation` outside the lock (issue 29, item 6)."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from twin.sim.live import LiveSession


@pytest.fixture
def running() -> Iterator[LiveSession]:
    """A paused session whose loop thread runs (it applies the commands)."""
    session = LiveSession({"sea_state": 3})
    session.pause()
    session.start()
    yield session
    session.stop()


def test_a_patch_from_another_thread_is_applied_by_the_session_thread(
    running: LiveSession,
) -> None:
    """A caller's patch (a GUI callback, a REST handler) is applied on the loop's thread, and
    the caller gets its outcome: the changed names, or the error."""
    appliers: list[str] = []
    update = running._sim.update

    def recording(*args: object, **kwargs: object) -> set[str]:
        appliers.append(threading.current_thread().name)
        return update(*args, **kwargs)  # type: ignore[arg-type]

    running._sim.update = recording  # type: ignore[method-assign]
    assert running.patch({"beta": 0.4}) == {"beta"}
    assert appliers == ["twin-live"] and running.scenario.beta == 0.4
    with pytest.raises(ValueError, match="beta"):  # a pydantic error is one
        running.patch({"beta": 5.0})
    assert running.scenario.beta == 0.4  # nothing changed


def test_a_restart_builds_its_simulation_outside_the_lock(running: LiveSession) -> None:
    """While the new Simulation of a mechanism switch is being built, readers still read the
    old one (the lock is free); the swap then shows the new mechanism at once."""
    building, release = threading.Event(), threading.Event()
    build = running._build
    free_while_building: list[bool] = []

    def slow_build(*args: object) -> object:
        building.set()
        release.wait(30.0)
        return build(*args)  # type: ignore[arg-type]

    running._build = slow_build  # type: ignore[method-assign]
    writer = threading.Thread(
        target=running.patch, args=({"mechanism": "upr4", "planner": None},), daemon=True
    )
    writer.start()
    assert building.wait(30.0)

    def read() -> None:
        free_while_building.append(running.view()["scenario"].mechanism == "hybrid")

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    reader.join(10.0)
    release.set()
    writer.join(60.0)
    assert free_while_building == [True]  # the reader was not held up by the build
    assert running.scenario.mechanism == "upr4" and running.version == 1


def test_commands_left_when_the_loop_stops_are_applied(running: LiveSession) -> None:
    """Without a running loop (stopped), a writer applies its change itself."""
    running.stop()
    running.patch({"playing": True, "beta": 0.5})
    assert running.controls.playing and running.scenario.beta == 0.5

"""The panel's comparison lane and the replay of a stored run."""

from __future__ import annotations

import numpy as np
import pytest

from tests.web.support import free_port, wait_for
from tests.web.viewer.support import caught_up, connect
from twin.mechanisms.urdf import joint_configuration
from twin.sim.live import LiveSession
from twin.web.access import Access
from twin.web.viewer import (
    start_viewer,
)


def test_the_panel_compares_planners_and_replays_a_stored_run(
    session: LiveSession, tmp_path
) -> None:
    """Compare with adds the ghost (a second URDF on the same base) and dashed plot lines;
    none removes it. A stored run chosen and watched replays; Back to live returns."""
    from twin.sim import Scenario, simulate
    from twin.web.store import RunStore

    with RunStore(tmp_path / "runs.sqlite") as store:
        scenario = Scenario(duration=2.0, planner="wpi")
        run = store.create(scenario)
        store.finish(run.id, simulate(scenario))
        viewer = start_viewer(session, access=Access(), port=free_port(), store=store)
        try:
            client, panel = connect(viewer)
            client.update(client.wait_widget("Compare with"), value="pi")
            assert wait_for(lambda: session.compare_planner == "pi")
            # the ghost, its label and its trail are added one after another: wait for each
            for name in ("/base/ghost", "/ghost_label", "/ghost_trail"):
                assert wait_for(lambda name=name: viewer.server.scene.get_handle_by_name(name)
                                is not None, 5.0), name  # fmt: skip
            assert viewer.scene.ghost is not None
            assert wait_for(lambda: any("· pi" in str(s.get("label"))
                                        for p in viewer.gui.plots for s in p.series), 5.0)
            session.step(3)
            assert wait_for(caught_up(viewer, session))
            ghost_cfg = joint_configuration(session.mechanism, session.latest(1)["xi"])
            assert viewer.scene.last.ghost.cfg == pytest.approx(
                {k: float(v) for k, v in ghost_cfg.items()})  # fmt: skip
            # the ghost draws its own tip-error trail, at the main trail's magnification
            scene = viewer.scene
            before = np.array(scene.ghost_trail.handle.points)
            session.step(20)
            assert wait_for(caught_up(viewer, session))
            after = np.array(scene.ghost_trail.handle.points)
            assert np.abs(after - before).max() > 0.0
            newest = scene.last.held[:3, 3] + scene.trail_scale * scene._tip_deviation(
                scene.last.ghost)
            np.testing.assert_allclose(after[-1, 1], newest, atol=1e-9)
            assert np.abs(after[-1, 1] - np.array(scene.trail.handle.points)[-1, 1]).max() > 0.0
            client.update(client.wait_widget("Compare with"), value="none")
            assert wait_for(lambda: viewer.scene.ghost is None, 5.0)
            assert viewer.server.scene.get_handle_by_name("/ghost_trail") is None
            assert viewer.scene.ghost_trail is None

            assert wait_for(lambda: len(panel.settings["replay_run"].options) == 2, 10.0)
            choice = panel.settings["replay_run"].options[1]
            client.update(client.wait_widget("Stored run"), value=choice)
            assert wait_for(lambda: panel.settings["replay_run"].value == choice)
            client.update(client.wait_widget("Watch in 3D"), value=True)
            assert wait_for(lambda: (session.replaying or {}).get("run_id") == run.id)
            assert wait_for(lambda: session.scenario.planner == "wpi")
            assert wait_for(lambda: panel.settings["replay_t"].max == 2.0, 5.0)
            client.update(client.wait_widget("Back to live"), value=True)
            assert wait_for(lambda: session.replaying is None)
            client.close()
        finally:
            viewer.stop()

"""Operability sweeps from the panel."""

from __future__ import annotations

import pytest

from tests.web.support import free_port, wait_for
from tests.web.viewer.support import connect
from twin.sim.live import LiveSession
from twin.web.access import Access
from twin.web.viewer import (
    SWEEP_SETTINGS,
    start_viewer,
    sweep_text,
)


def test_the_sweep_grid_comes_from_the_panel(session: LiveSession, tmp_path) -> None:
    """A browser's Operability settings (Hs and Tp cells and spans, seeds, run length) are the
    grid of the sweep it starts, around the current sea, and it is told how many runs that
    is; a grid `spec_around` refuses (a hostile value past a slider's range) starts nothing and
    says why."""
    from twin.runs.sweep import SweepSpec
    from twin.web.jobs import SweepRunner
    from twin.web.store import RunStore

    with RunStore(tmp_path / "runs.sqlite") as store:
        # a runner never started: the sweep stays queued, its spec as the panel submitted it
        viewer = start_viewer(
            session, access=Access(), port=free_port(), store=store, sweeps=SweepRunner(store)
        )
        try:
            client, panel = connect(viewer)
            assert {name: panel.settings[name].value for name in SWEEP_SETTINGS} == {
                "sweep_hs_points": 5, "sweep_hs_span": 50.0, "sweep_tp_points": 3,
                "sweep_tp_span": 2.0, "sweep_seeds": 2, "sweep_duration": 60.0,
            }  # fmt: skip
            # past the slider's range, as a script could send: refused by name, nothing stored
            client.update(client.wait_widget("Tp cells"), value=12)
            assert wait_for(lambda: panel.settings["sweep_tp_points"].value == 12)
            client.update(client.wait_widget("Run sweep"), value=True)
            assert wait_for(lambda: any("Sweep not started: tp_points: got 12" in n
                                        for n in client.notifications()), 5.0)  # fmt: skip
            assert store.pending("sweeps") == 0 and viewer.gui.sweep_id is None
            assert not viewer.gui.submitting

            chosen = {"Hs cells": 7, "Hs span [±%]": 30.0, "Tp cells": 5, "Tp span [± s]": 1.0,
                      "Seeds per cell": 3, "Run length [s]": 20.0}  # fmt: skip
            for label, value in chosen.items():
                client.update(client.wait_widget(label), value=value)
            assert wait_for(lambda: [panel.settings[name].value for name in SWEEP_SETTINGS]
                            == list(chosen.values()))  # fmt: skip
            client.update(client.wait_widget("Run sweep"), value=True)
            # `submitting` while the panel submits it (no second sweep meanwhile), then its id
            assert wait_for(lambda: viewer.gui.sweep_id is not None, 10.0)
            assert not viewer.gui.submitting
            sweep = store.get_sweep(viewer.gui.sweep_id)
            spec = SweepSpec(**sweep.spec)
            hs, tp = session.scenario.sea()
            assert (len(spec.hs), len(spec.tp), spec.seeds, spec.duration) == (7, 5, 3, 20.0)
            assert hs in spec.hs and tp in spec.tp  # the current sea is a cell
            assert (spec.hs[0], spec.hs[-1]) == pytest.approx((0.7 * hs, 1.3 * hs), rel=5e-3)
            assert (spec.tp[0], spec.tp[-1]) == pytest.approx((tp - 1.0, tp + 1.0), rel=5e-3)
            assert sweep.total == 7 * 5 * 3 and store.pending("sweeps") == 1
            assert wait_for(lambda: any("Hs 7 × Tp 5 cells × 3 seeds = 105 runs of 20 s" in n
                                        for n in client.notifications()), 5.0)  # fmt: skip
            # a second press while it is followed starts nothing, and says so
            client.update(client.wait_widget("Run sweep"), value=True)
            assert wait_for(lambda: any("A sweep is running" in n
                                        for n in client.notifications()), 5.0)  # fmt: skip
            assert store.pending("sweeps") == 1 and viewer.gui.sweep_id == sweep.id
            client.close()
        finally:
            viewer.stop()


def test_sweep_text_counts_rightly_and_explains_a_cell() -> None:
    """One seed, one run: singular; the sea to 0.1 m and 0.1 s; short link texts; and why a
    cell can differ from the live run."""
    one = sweep_text("0123456789ab", 1, 1, 60.0, (1.8765, 6.84717), "http://h/api/sweeps/x")
    assert "1 run, 1 seed per cell" in one and "1 seeds" not in one and "1 runs" not in one
    assert "Hs 1.9 m, Tp 6.8 s" in one and "6.84717" not in one
    assert "[sweep 01234567](http://h/api/sweeps/x)" in one
    assert "[heatmap PNG](http://h/api/sweeps/x/heatmap.png)" in one
    assert "can differ from the live run" in one
    many = sweep_text("0123456789ab", 30, 2, 60.0, (1.0, 6.0), "http://h/api/sweeps/x")
    assert "30 runs, 2 seeds per cell" in many


def test_no_sweep_starts_while_one_is_being_submitted(session: LiveSession, tmp_path) -> None:
    """While a browser's sweep is being submitted (`submitting`, under the GUI's lock), another
    press starts nothing and is told one is starting; once it is done, a press starts one."""
    from twin.web.jobs import SweepRunner
    from twin.web.store import RunStore

    with RunStore(tmp_path / "runs.sqlite") as store:
        viewer = start_viewer(
            session, access=Access(), port=free_port(), store=store, sweeps=SweepRunner(store)
        )
        try:
            client, _ = connect(viewer)
            with viewer.gui._lock:  # as another browser's press, mid-submission
                viewer.gui.submitting = True
            client.update(client.wait_widget("Run sweep"), value=True)
            assert wait_for(lambda: any("A sweep is starting" in n
                                        for n in client.notifications()), 5.0)  # fmt: skip
            assert store.pending("sweeps") == 0 and viewer.gui.sweep_id is None
            with viewer.gui._lock:
                viewer.gui.submitting = False
            client.update(client.wait_widget("Run sweep"), value=True)
            assert wait_for(lambda: viewer.gui.sweep_id is not None, 10.0)
            assert wait_for(lambda: not viewer.gui.submitting, 5.0)
            assert store.pending("sweeps") == 1
            client.close()
        finally:
            viewer.stop()

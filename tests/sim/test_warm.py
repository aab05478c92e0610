"""`twin.sim.engine.warm` leaves nothing to compile: after it, a run of any planner on any
mechanism, one lane or several, keeping its series or its metrics alone, compiles no kernel
(a server that says it is ready is)."""

from __future__ import annotations

import pytest

from twin.planners.registry import PLANNERS
from twin.sim.engine import KEEPS, Simulation, warm

numba = pytest.importorskip("numba")


def test_after_warm_no_run_compiles_a_kernel() -> None:
    """After warm(), no run of any planner, serial or parallel, series or metrics, compiles a
    kernel."""
    from numba.core import event

    warm()  # from numba's disk cache where the suite's warm-up filled it
    compiled: list[str] = []

    class Compiles(event.Listener):
        """numba emits "numba:compile" on a real compile only, not on a load from its cache."""

        def on_start(self, ev: event.Event) -> None:
            compiled.append(str(ev.data.get("dispatcher")))

        def on_end(self, ev: event.Event) -> None:
            pass

    runs = []
    with event.install_listener("numba:compile", Compiles()):
        for name, spec in PLANNERS.items():
            for mechanism in spec.mechanisms:
                lane = {"mechanism": mechanism, "planner": name, "duration": 0.1}
                for lanes in ([lane], [lane, {**lane, "seed": 1}]):  # serial and parallel
                    for keep in KEEPS:  # a series kept, or the metrics reduced as stepped
                        Simulation(lanes, keep=keep).run()
                        runs.append((mechanism, name, len(lanes), keep))
    assert len(runs) >= 4 * len(PLANNERS)  # every planner ran, both ways
    assert compiled == [], f"kernels compiled after warm(): {compiled}"

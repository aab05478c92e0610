"""The hybrid runner hands a differential step's tip and pose error to the records
(`twin.sim.kernels.records.hand_over`): what the records make of them equals, bit for bit, what
they compute from the states alone, for every lane kind, from sample 0 or 1."""

from __future__ import annotations

import numpy as np
import pytest

from twin.planners.parameters import as_records
from twin.sim import Simulation
from twin.sim.kernels import hybrid_runner, layout
from twin.sim.kernels.records import N_TIP, compiled_records, keep_records, run_hybrid_records
from twin.sim.records import record_arrays

SCENARIOS = [
    {"planner": "mtmp", "sea_state": 6, "duration": 2.0},
    {"planner": "dwa", "sea_state": 6, "duration": 2.0, "seed": 3},
    {"planner": "pi", "sea_state": 6, "duration": 2.0, "seed": 5, "joint_limits": "hold"},
]


@pytest.mark.parametrize("first", [0, 1])
@pytest.mark.parametrize("engine", ["numba", "python"])
def test_handed_tips_give_the_records_computed_alone(first: int, engine: str) -> None:
    """Records from the tips the runner hands over equal those computed alone, bit for bit, from the
    first kept step."""
    sim = Simulation(SCENARIOS)
    lanes, N, m = sim.lanes, sim.n_lanes, sim.n_steps
    targets = sim.targets(sim._block, 0, m, end=True)
    compiled = engine == "numba"
    run = hybrid_runner.compiled_hybrid(True) if compiled else hybrid_runner.run_hybrid
    records = compiled_records(True) if compiled else run_hybrid_records
    xs = np.empty((N, m + 1, 9))
    xs[:, 0] = sim.x
    diag = np.zeros((N, m + 1, layout.N_HYBRID_DIAGNOSTICS))
    faults = np.zeros((N, m), dtype=np.int64)
    errors, tips = np.full((N, m + 1, 6), np.nan), np.full((N, m + 1, N_TIP), np.nan)
    run(xs, targets, sim.prm, sim.memory.copy(), lanes.const, sim.dt, diag, faults, first,
        errors, tips)  # fmt: skip
    differential = as_records(sim.prm, layout.COMMON_PARAMETERS)["kind"] == layout.KIND_DIFFERENTIAL
    assert differential.tolist() == [True, False, True]
    for n in range(N):  # handed over: a differential lane's rows first … m − 1, nothing else
        handed = np.isfinite(tips[n]).all(axis=1)
        assert handed.tolist() == [bool(differential[n]) and first <= k < m for k in range(m + 1)]
    frames = (lanes.held, lanes.landing, lanes.gangway0)
    out = {}
    for label, given in (("handed", np.where(differential, m, 0)), ("alone", np.zeros(N, int))):
        legs, errs, scalars = record_arrays(N, m + 1)
        errs[:] = errors  # the rows handed over; the records fill the rest
        records(targets, xs, first, given, *frames, lanes.const, legs, errs, scalars, tips,
                *keep_records(N))  # fmt: skip
        out[label] = legs, errs, scalars
    for got, want in zip(out["handed"], out["alone"], strict=True):
        assert np.isfinite(got[:, first:]).all()
        np.testing.assert_array_equal(got[:, first:], want[:, first:])
    assert np.abs(out["alone"][1][:, first:]).max() > 1e-4  # the tip errs: the sea is felt

"""Runs layer, above the engine (`twin.sim`): where many runs are orchestrated and judged.

- `executor`: the one Dask executor of runs and sweeps (a LocalCluster, a scheduler's address,
  or in-process), budgets and priorities; `heap`: the garbage collector of its long-running
  processes;
- `sweep`: operability sweeps over a grid of sea states;
- `claims`: the papers' claims recomputed from runs.

It imports `twin.sim` and the layers below; `twin.sim` never imports it (tests/test_imports.py).
"""

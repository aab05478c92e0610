"""A finished run: the scenario, its series and metrics, and their export."""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twin.sim.scenario import Scenario


def flat_columns(series: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """One 1-D column per scalar: `xi` (N, 9) becomes `xi_0` … `xi_8`."""
    columns: dict[str, np.ndarray] = {}
    for key, values in series.items():
        values = np.asarray(values)
        if values.ndim == 1:
            columns[key] = values
        else:
            flat = values.reshape(len(values), -1)
            for j in range(flat.shape[1]):
                columns[f"{key}_{j}"] = flat[:, j]
    return columns


@dataclass
class SimulationResult:
    """Attributes:
    scenario: what was run.
    series: name → (N, ...) arrays; at least `t`, `base_pose` and, for the hybrid system,
        `xi` (N, 9) and `legs` (N, 6).
    metrics: name → JSON-ready values (docs/simulation.md).
    """

    scenario: Scenario
    series: dict[str, np.ndarray]
    metrics: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: scenario, metrics and series as nested lists."""
        return {
            "scenario": self.scenario.model_dump(),
            "metrics": self.metrics,
            "series": {k: np.asarray(v).tolist() for k, v in self.series.items()},
        }

    def to_json(self, path: str | Path) -> Path:
        path = _writable(path)
        path.write_text(json.dumps(self.to_dict()))
        return path

    def to_csv(self, path: str | Path) -> Path:
        """One row per sample, one column per scalar (`flat_columns`)."""
        path = _writable(path)
        columns = flat_columns(self.series)
        with path.open("w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(columns)
            writer.writerows(zip(*(c.tolist() for c in columns.values()), strict=True))
        return path

    def to_parquet(self, path: str | Path) -> Path:
        """Flat columns as a Parquet table, the scenario and metrics in its metadata."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        path = _writable(path)
        table = pa.table(flat_columns(self.series))
        table = table.replace_schema_metadata(
            {"scenario": self.scenario.model_dump_json(), "metrics": json.dumps(self.metrics)}
        )
        pq.write_table(table, path)
        return path


def _writable(path: str | Path) -> Path:
    """`path` as a Path whose folder exists (made if missing: `out/run.csv` on a fresh clone)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return path

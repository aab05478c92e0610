"""scripts/engine_dump.py, the issue-41 before/after check, notices a change in engine numbers."""

from __future__ import annotations

import importlib.util
import pickle
from pathlib import Path
from types import ModuleType

import numpy as np

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "engine_dump.py"


def load() -> ModuleType:
    """The script as a module."""
    spec = importlib.util.spec_from_file_location("engine_dump", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def write(path: Path, tip: float, faults: int) -> Path:
    """A one-run dump whose tip series ends at `tip` and whose metrics count `faults`."""
    run = ({"planner": "pi", "mechanism": "hybrid"},
           {"tip": np.array([0.0, tip]), "t": np.array([0.0, 0.01])},
           {"tip_max": tip, "faults": faults})
    path.write_bytes(pickle.dumps([run]))
    return path


def test_compare_passes_equal_dumps_and_fails_a_float_change_or_a_count_change(
        tmp_path: Path) -> None:
    """Equal dumps pass; a series value 1e-9 off, or an integer metric changed, fails."""
    script = load()
    base = write(tmp_path / "a.pkl", 1.0, 0)
    assert script.compare(base, write(tmp_path / "b.pkl", 1.0, 0), 1e-12) == 0
    assert script.compare(base, write(tmp_path / "c.pkl", 1.0 + 1e-9, 0), 1e-12) == 1
    assert script.compare(base, write(tmp_path / "d.pkl", 1.0, 1), 1e-12) == 1


def test_the_scenarios_cover_every_planner_of_every_mechanism() -> None:
    """Each registered planner appears for each mechanism it serves, in both joint-limit modes."""
    from twin.planners.registry import PLANNERS

    chosen = load().scenarios()
    pairs = {(s["mechanism"], s["planner"], s["joint_limits"]) for s in chosen}
    for name, spec in PLANNERS.items():
        for mechanism in spec.mechanisms:
            assert (mechanism, name, "hold") in pairs and (mechanism, name, "record") in pairs

"""The rated-sea bisection of scripts/rated_sea.py (issue 38 item 8) on synthetic operability."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def _rated_sea() -> ModuleType:
    spec = importlib.util.spec_from_file_location("rated_sea", ROOT / "scripts" / "rated_sea.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_bisection_brackets_each_curves_crossing() -> None:
    """On random falling logistic curves the rated Hs is within half the final bracket of each
    curve's own 50 % crossing, and every curve's evaluation stays within [low, high]."""
    module = _rated_sea()
    rng = np.random.default_rng(7)
    centre = rng.uniform(0.5, 7.5, 20)
    width = rng.uniform(0.05, 1.0, 20)
    seen: list[np.ndarray] = []

    def operability(hs: np.ndarray) -> np.ndarray:
        seen.append(hs.copy())
        return 1.0 / (1.0 + np.exp((hs - centre) / width))

    low, high, steps = 0.25, 8.0, 10
    rated, status = module.rated_hs(operability, low, high, steps, centre.size)
    assert np.all(status == 0)
    assert np.all(np.abs(rated - centre) <= 0.5 * (high - low) / 2**steps + 1e-12)
    assert all(np.all((h >= low) & (h <= high)) for h in seen)


def test_curves_outside_the_range_are_flagged_at_its_ends() -> None:
    """A curve under the level already at `low` rates `low` (status −1); one still over it at
    `high` rates `high` (status +1, a lower bound); a crossing inside is status 0."""
    module = _rated_sea()
    centre = np.array([-1.0, 20.0, 3.0])

    def operability(hs: np.ndarray) -> np.ndarray:
        return (hs < centre).astype(float)

    rated, status = module.rated_hs(operability, 0.25, 8.0, 8, 3)
    assert status.tolist() == [-1, 1, 0]
    assert rated[0] == 0.25 and rated[1] == 8.0 and abs(rated[2] - 3.0) < 0.02


def test_error_stays_within_each_steps_half_bracket() -> None:
    """After s halvings a step curve's rated Hs lies within (high − low)/2^(s+1) of its
    crossing, for every s: each halving keeps the crossing inside the bracket."""
    module = _rated_sea()
    crossing = np.array([2.345, 6.789])

    def operability(hs: np.ndarray) -> np.ndarray:
        return np.where(hs <= crossing, 0.9, 0.1)

    for steps in range(12):
        rated = module.rated_hs(operability, 0.25, 8.0, steps, 2)[0]
        assert np.all(np.abs(rated - crossing) <= 7.75 / 2 ** (steps + 1) + 1e-12)


def test_bad_range_is_refused() -> None:
    """An empty range or a negative step count is a ValueError naming what is allowed."""
    module = _rated_sea()
    with pytest.raises(ValueError, match="low < high"):
        module.rated_hs(lambda hs: hs, 3.0, 3.0, 4, 1)

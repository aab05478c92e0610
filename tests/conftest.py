"""Shared fixtures: the SPEC's paths and random states inside each mechanism's workspace."""

from __future__ import annotations

import numpy as np
import pytest

from twin.mechanisms import HybridBoardingSystem


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20231123)


def random_hybrid_states(rng: np.random.Generator, n: int, shrink: float = 0.5) -> np.ndarray:
    """n virtual-joint states (n, 9) uniformly within `shrink` of the Table 6 ranges about the
    working state, keeping only those whose legs are inside Table 1."""
    h = HybridBoardingSystem()
    w = h.working_state
    lo, hi = w + shrink * (h.lower - w), w + shrink * (h.upper - w)
    kept: list[np.ndarray] = []
    while sum(map(len, kept)) < n:
        draw = rng.uniform(lo, hi, size=(4 * n, 9))
        kept.append(draw[h.within_limits(draw)])
    return np.concatenate(kept)[:n]

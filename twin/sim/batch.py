"""Many scenarios at once: `simulate_many` runs them as lanes of the one engine.

Kept as a module because scripts import `twin.sim.batch.simulate_many`; the engine is
`twin.sim.engine`.
"""

from __future__ import annotations

from twin.sim.engine import MAX_LANES, simulate_many
from twin.sim.lanes import ENGINES, numba_available

__all__ = ["ENGINES", "MAX_LANES", "numba_available", "simulate_many"]

"""Simulation layer: scenarios, the stepping engine, metrics and export."""

from __future__ import annotations

from twin.sim.engine import Simulation, simulate, simulate_many
from twin.sim.presets import PAPER_PRESETS
from twin.sim.result import SimulationResult
from twin.sim.scenario import MAX_DURATION, MAX_STEPS, Scenario

__all__ = [
    "MAX_DURATION",
    "MAX_STEPS",
    "PAPER_PRESETS",
    "Scenario",
    "Simulation",
    "SimulationResult",
    "simulate",
    "simulate_many",
]

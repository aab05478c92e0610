"""Simulation layer: scenarios, the stepping engine, metrics and export."""

from __future__ import annotations

from twin.sim.engine import Simulation, simulate
from twin.sim.result import SimulationResult
from twin.sim.scenario import MAX_DURATION, MAX_STEPS, Scenario

__all__ = ["MAX_DURATION", "MAX_STEPS", "Scenario", "Simulation", "SimulationResult", "simulate"]

"""Loop gains sampled exactly: what a continuous gain becomes in a loop stepped every dt.

A planner that asks for the rate k e and integrates it over a step of dt leaves (1 − k dt) e of
the error: the loop overshoots once k dt > 1 and diverges once k dt > 2. The zero-order-hold
discretisation of ė = −k e (Franklin, Powell & Workman, *Digital Control of Dynamic Systems*,
3rd ed., 1998, §4.3) leaves e^(−k dt) e instead: the gain (1 − e^(−k dt)) / dt per step is the
continuous loop's, exactly, at every dt (docs/decisions.md, "Sampled loop gains").
"""

from __future__ import annotations

import numpy as np

from twin.compiled import register_jitable


@register_jitable
def proportional_gain(k: float, dt: float) -> float:
    """[1/s] the sampled gain (1 − e^(−k·dt))/dt of the loop ė = −k e (k [1/s], dt [s]): the
    error a step leaves is e^(−k·dt) of the one before, never negative, so the loop neither
    overshoots nor goes unstable at any dt. ≈ k for k·dt ≪ 1; k itself for dt ≤ 0 (the
    continuous loop, for callers that ask for a rate without a step)."""
    if dt <= 0.0:
        return k
    return float(-np.expm1(-k * dt) / dt)

"""What a planner is asked to do: the desired tip motion in the mechanism's base frame."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class TipTarget:
    """Desired end-effector motion at one instant, in the mechanism base frame B.

    Attributes:
        transform: (..., 4, 4) ᴮT_E,d, desired tip pose.
        twist: (..., 6) [m/s, rad/s] ᴮξ̇_d = [ᴮṗ_E,d; ᴮω_E,d], its time derivative.
    """

    transform: np.ndarray
    twist: np.ndarray


@dataclass
class PlannerOutput:
    """A planner step's result.

    Attributes:
        velocity: (..., n) joint velocities (for the hybrid system: platform body twist in P
            [m/s, rad/s], then q̇1 [rad/s], q̇2 [rad/s], ḋ3 [m/s]).
        diagnostics: name → array; at least `task_error` (..., 6) when a tip task exists.
    """

    velocity: np.ndarray
    diagnostics: dict[str, Any] = field(default_factory=dict)

"""The panel's widgets: numeric knobs whose range, step, default and hint come from one place,
their pydantic fields (`PlannerParameters`, `Scenario`, `LiveControls`); the dropdowns'
choices; and `assign`, which sets a widget's property without letting one broken widget stop
the rest of a panel.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, SupportsFloat, cast, get_args

import annotated_types as at
import numpy as np
from pydantic import BaseModel

from twin.sim.live import LiveControls
from twin.sim.registries import PLANNERS, PlannerParameters
from twin.sim.scenario import Scenario

log = logging.getLogger(__name__)

#: where the shared readout, status lines and heatmap sit in their folders (after the
#: browsers' own widgets)
READOUT_ORDER = 100.0


def assign(handle: Any, name: str, value: Any) -> None:
    """Set a widget's property; a widget its browser broke for itself (a hostile message can
    mark its own handle removed, say) is skipped, so the rest of its panel still follows."""
    try:
        setattr(handle, name, value)
    except (RuntimeError, TypeError, ValueError, AttributeError):
        log.debug("widget property %s not set", name, exc_info=True)

LABELS = {
    "k_e": "k_e [1/s]",
    "beta": "β",
    "l": "l",
    "k_c": "k_c",
    "sigma": "σ [deg]",
    "q1_rate_max": "q̇1,max [deg/s]",
    "yaw_hold": "yaw hold",
    "k_a2": "k_a2 [1/s]",
    "damping": "λ_max",
    "kp": "kp [1/s]",
    "ki": "ki [1/s²]",
    "kd": "kd",
    "actuator_speed": "actuator speed [m/s]",
    "actuator_mass": "actuator mass [kg]",
    "w_orientation": "w orientation (qp)",
    "w_secondary": "w secondary (qp)",
    "limit_gain": "limit gain (qp)",
    "qp_damping": "μ (qp)",
}


@dataclass(frozen=True)


class Knob:
    """A numeric field as a widget: range, step and default from its pydantic constraints.

    Attributes:
        name: field name (a `session.patch` key).
        label: widget label.
        min: lowest value (a strict bound `gt` becomes `gt + step`).
        max: highest value.
        step: slider step.
        default: the field's default.
        hint: the field's description.
    """

    name: str
    label: str
    min: float
    max: float
    step: float
    default: float
    hint: str

    @property
    def slider(self) -> bool:
        """Whether the default lies on the slider's grid; if not (ki = 8e-4 on 0-200), the
        knob is a number box, which keeps any value."""
        ratio = self.default / self.step
        return abs(ratio - round(ratio)) < 1e-6

    @property
    def number_step(self) -> float:
        """Step of the number box: a tenth of the default's order of magnitude."""
        return 10.0 ** (np.floor(np.log10(abs(self.default))) - 1) if self.default else self.step


def knob(model: type[BaseModel], name: str, label: str, step: float | None = None) -> Knob:
    """The `Knob` of a bounded numeric field of `model`.

    Args:
        model: a pydantic model class (`Scenario`, `PlannerParameters`, `LiveControls`).
        name: the field.
        label: the widget label.
        step: slider step; default a power of ten giving ≥ 100 steps over the range.
    """
    info = model.model_fields[name]
    low: float | None = None
    high: float | None = None
    strict = False
    for constraint in info.metadata:
        if isinstance(constraint, at.Ge):
            low = float(cast(SupportsFloat, constraint.ge))
        elif isinstance(constraint, at.Gt):
            low, strict = float(cast(SupportsFloat, constraint.gt)), True
        elif isinstance(constraint, at.Le):
            high = float(cast(SupportsFloat, constraint.le))
        elif isinstance(constraint, at.Lt):
            high = float(cast(SupportsFloat, constraint.lt))
    if low is None or high is None:
        raise ValueError(f"{model.__name__}.{name} needs lower and upper bounds for a widget")
    step = step or 10.0 ** np.floor(np.log10((high - low) / 100.0))
    return Knob(
        name=name,
        label=label,
        min=float(low + step if strict else low),
        max=float(high),
        step=float(step),
        default=float(info.default),
        hint=info.description or "",
    )


#: every planner knob, in the order of `PlannerParameters` (a field without a label above
#: shows under its own name)
PLANNER_KNOBS = tuple(
    knob(PlannerParameters, name, LABELS.get(name, name.replace("_", " ")))
    for name in PlannerParameters.model_fields
)
SEA_KNOBS = (
    knob(Scenario, "sea_state", "Sea state (WMO)", step=0.1),
    knob(Scenario, "heading", "Wave heading [deg] (180 from ahead, 90 from stbd, 270 from port)"),
)
SPEED_KNOB = knob(LiveControls, "speed", "Sim speed ×", step=0.25)
MECHANISM_NAMES: tuple[str, ...] = get_args(Scenario.model_fields["mechanism"].annotation)
SPECTRA: tuple[str, ...] = get_args(Scenario.model_fields["spectrum"].annotation)
JOINT_LIMITS: tuple[str, ...] = get_args(Scenario.model_fields["joint_limits"].annotation)


def planners_for(mechanism: str) -> tuple[str, ...]:
    """Registry names of the planners that plan for `mechanism`."""
    return tuple(name for name, spec in PLANNERS.items() if mechanism in spec.mechanisms)

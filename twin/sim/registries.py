"""What the layers above the engine read of the layers below it: the registries of mechanisms,
planners, sea states and vessels, and the few models the 3D viewer draws with.

`twin.web` (the REST models and the viewer) imports these names from here and never
`twin.mechanisms`, `twin.planners`, `twin.sea` or `twin.vessel` themselves
(tests/test_imports.py), so a change below the engine is met by the engine's layer alone.
"""

from __future__ import annotations

from twin.mechanisms import MECHANISMS
from twin.mechanisms.hybrid import JOINT_NAMES as HYBRID_JOINT_NAMES
from twin.mechanisms.limits import LEG_PAST
from twin.mechanisms.urdf import joint_configuration, leg_joint_names
from twin.planners import PLANNERS, PlannerParameters, get_planner
from twin.sea.components import WaveComponents
from twin.sea.sea_states import WMO_SEA_STATES
from twin.sea.surface import gerstner_points
from twin.vessel import MOUNTS
from twin.vessel.bem import GRIDS as HULL_GRIDS
from twin.vessel.hulls import HULLS, Hull, wetted_surface, wigley_half_breadth
from twin.vessel.rao import available_raos

__all__ = [
    "HULLS",
    "HULL_GRIDS",
    "HYBRID_JOINT_NAMES",
    "LEG_PAST",
    "MECHANISMS",
    "MOUNTS",
    "PLANNERS",
    "WMO_SEA_STATES",
    "Hull",
    "PlannerParameters",
    "WaveComponents",
    "available_raos",
    "gerstner_points",
    "get_planner",
    "joint_configuration",
    "leg_joint_names",
    "wetted_surface",
    "wigley_half_breadth",
]

"""The planner registry: names every other layer uses, what each fits and which knobs it reads."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from twin.errors import TwinError
from twin.mechanisms.hybrid import HybridBoardingSystem
from twin.planners.allocation import AllocationPlanner
from twin.planners.differential import DifferentialPlanner
from twin.planners.families import FAMILY_DIAGNOSTICS
from twin.planners.limits import SlewPriority, VelocityLimit
from twin.planners.parameters import PlannerParameters
from twin.planners.platform import platform_builder
from twin.planners.protocols import Planner
from twin.planners.qp import QPPlanner, qp_planner
from twin.planners.tasks import JointPostureTask, TipPoseTask
from twin.planners.weights import BetaSplit, JointLimitWeights, ProductWeights

#: Virtual-joint rate limits of the hybrid system, [m/s] ×3, [rad/s] ×3, q̇1, q̇2 [rad/s],
#: ḋ3 [m/s]. The papers give none; these are typical of hydraulic W2W gangways and Stewart
#: motion bases (docs/planners.md) and bind only in the roughest seas.
HYBRID_RATE_LIMITS = np.array([1.0, 1.0, 1.0, 0.5, 0.5, 0.5, 0.35, 0.35, 1.0])


@dataclass(frozen=True)
class PlannerSpec:
    """A planner's registry entry.

    Attributes:
        name: registry key (`"mtmp"`, …).
        title: human-readable name.
        mechanisms: registry names of the mechanisms it plans for.
        parameters: the `PlannerParameters` fields it reads.
        source: paper and equations.
        build: (mechanism, parameters, initial state) → a `Planner` (`reset`, `step`).
        family: the kernel family its planners pack for (`FAMILY_DIAGNOSTICS`' keys; the
            built planner's own `family`): how the engine packs and runs its lanes.
        diagnostics: the series its lanes record; None: all of its family's.
    """

    name: str
    title: str
    mechanisms: tuple[str, ...]
    parameters: tuple[str, ...]
    source: str
    build: Callable[[Any, PlannerParameters, np.ndarray], Planner]
    family: str
    diagnostics: frozenset[str] | None = None

    def __post_init__(self) -> None:
        if self.family not in FAMILY_DIAGNOSTICS:
            raise TwinError(f"planner {self.name!r}: unknown family {self.family!r}; "
                            f"allowed: {sorted(FAMILY_DIAGNOSTICS)}")  # fmt: skip
        extra = (self.diagnostics or frozenset()) - FAMILY_DIAGNOSTICS[self.family]
        if extra:
            raise TwinError(f"planner {self.name!r}: diagnostics {sorted(extra)} are not its "
                            f"family's {sorted(FAMILY_DIAGNOSTICS[self.family])}")  # fmt: skip

    @property
    def series_diagnostics(self) -> frozenset[str]:
        """The diagnostics its lanes record: its own list, else its family's."""
        return FAMILY_DIAGNOSTICS[self.family] if self.diagnostics is None else self.diagnostics


def _differential(
    weights: str,
) -> Callable[[HybridBoardingSystem, PlannerParameters, np.ndarray], DifferentialPlanner]:
    def build(
        h: HybridBoardingSystem, p: PlannerParameters, xi0: np.ndarray
    ) -> DifferentialPlanner:
        tip = TipPoseTask(h, gain=p.k_e)
        planner = partial(
            DifferentialPlanner,
            velocity_limit=VelocityLimit(HYBRID_RATE_LIMITS),
            damping_max=p.damping,
        )
        if weights == "none":
            return planner(tip)
        split = BetaSplit(p.beta, p.l)
        if weights == "beta":
            return planner(tip, split)
        scale = np.r_[np.ones(8), p.k_c]  # eq (37): k_c on the telescope
        return planner(
            tip,
            ProductWeights((split, JointLimitWeights(h.lower, h.upper, scale))),
            secondary=(JointPostureTask(index=7, setpoint=float(xi0[7]), gain=p.k_a2),),
            slew_priority=SlewPriority(
                h.lower[6],
                h.upper[6],
                np.deg2rad(p.sigma),
                np.deg2rad(p.q1_rate_max),
                yaw_hold=p.yaw_hold,
            ),
        )

    return build


def _qp(h: HybridBoardingSystem, p: PlannerParameters, xi0: np.ndarray) -> QPPlanner:
    """The `qp` planner: q2 held at its start (seed 000 eq (40)), the limits hard."""
    return qp_planner(
        h, k_e=p.k_e, w_orientation=p.w_orientation, w_secondary=p.w_secondary,
        limit_gain=p.limit_gain, beta=p.beta, l=p.l, k_a2=p.k_a2, yaw_hold=p.yaw_hold,
        damping=p.qp_damping, q2_setpoint=float(xi0[7]), rate_limit=HYBRID_RATE_LIMITS,
    )  # fmt: skip


def _allocation(
    method: str,
) -> Callable[[HybridBoardingSystem, PlannerParameters, np.ndarray], AllocationPlanner]:
    def build(h: HybridBoardingSystem, p: PlannerParameters, xi0: np.ndarray) -> AllocationPlanner:
        del p, xi0  # Unused: seed 004's methods have no knobs.
        return AllocationPlanner(h, method)

    return build


PLANNERS: dict[str, PlannerSpec] = {
    spec.name: spec
    for spec in (
        PlannerSpec(
            "pi",
            "pseudo-inverse",
            ("hybrid",),
            ("k_e", "damping"),
            "seed 000 eq (26), closed loop eq (34)",
            _differential("none"),
            "differential",
        ),
        PlannerSpec(
            "wpi",
            "weighted pseudo-inverse",
            ("hybrid",),
            ("k_e", "beta", "l", "damping"),
            "seed 000 eqs (27)-(32)",
            _differential("beta"),
            "differential",
        ),
        PlannerSpec(
            "mtmp",
            "multi-task motion planning",
            ("hybrid",),
            ("k_e", "beta", "l", "k_c", "sigma", "q1_rate_max", "yaw_hold", "k_a2", "damping"),
            "seed 000 eqs (33)-(40), Algorithm 1",
            _differential("mtmp"),
            "differential",
        ),
        PlannerSpec(
            "dwa", "dynamic weight allocation", ("hybrid",), (), "seed 004 §3", _allocation("dwa"),
            "allocation",
        ),
        PlannerSpec(
            "conv1",
            "conventional method 1 (platform alone)",
            ("hybrid",),
            (),
            "seed 004 §4 a",
            _allocation("conv1"),
            "allocation",
        ),
        PlannerSpec(
            "conv2",
            "conventional method 2 (platform orientation, gangway position)",
            ("hybrid",),
            (),
            "seed 004 §4 b",
            _allocation("conv2"),
            "allocation",
        ),
        PlannerSpec(
            "qp",
            "quadratic program with hard limits (beyond the papers)",
            ("hybrid",),
            (
                "k_e",
                "w_orientation",
                "w_secondary",
                "limit_gain",
                "qp_damping",
                "beta",
                "l",
                "k_a2",
                "yaw_hold",
            ),
            "issue 15: task-based differential IK (as mink, pink) on seed 000 eqs (24), (34), "
            "(39)-(40) and Algorithm 1, legs and Table 6 as hard limits",
            _qp,
            "qp",
        ),
        PlannerSpec(
            "pid",
            "actuator PID position loop",
            ("upu3up", "upr4"),
            ("kp", "ki", "kd", "actuator_speed", "actuator_mass"),
            "seed 002 §5, Fig. 11",
            platform_builder("pid"),
            "platform",
        ),
        PlannerSpec(
            "ik",
            "ideal position servo (inverse kinematics)",
            ("upu3up", "upr4"),
            ("actuator_speed",),
            "seed 001 eqs (16)-(19), seed 002 eqs (15)-(18)",
            platform_builder("ik"),
            "platform",
        ),
    )
}


def get_planner(name: str, mechanism: str) -> PlannerSpec:
    """The registry entry, or a TwinError listing what is allowed for `mechanism`."""
    allowed = sorted(n for n, s in PLANNERS.items() if mechanism in s.mechanisms)
    if name not in PLANNERS:
        raise TwinError(f"planner: unknown name {name!r}; allowed for {mechanism!r}: {allowed}")
    if mechanism not in PLANNERS[name].mechanisms:
        raise TwinError(
            f"planner: {name!r} does not plan for mechanism {mechanism!r}; allowed: {allowed}"
        )
    return PLANNERS[name]

"""Every registry planner and every part it is composed of implement the planner layer's
protocols (twin/planners/protocols.py), by their members, their call signatures and what
their calls return."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator

import numpy as np
import pytest

from tests.conformance import conformance
from twin.mechanisms import MECHANISMS
from twin.planners import (
    PLANNERS,
    BetaSplit,
    JointLimitWeights,
    JointPostureTask,
    Limit,
    Planner,
    PlannerOutput,
    PlannerParameters,
    PlatformModel,
    PlatformYawTask,
    ProductWeights,
    SecondaryTask,
    SlewPriority,
    TargetTask,
    Task,
    TipPoseTask,
    TipTarget,
    VelocityLimit,
    VelocityScaler,
    VelocityShaper,
    Weight,
)
from twin.planners.qp import JointLimit, LegStrokeLimit, RateLimit

#: the protocol each kind of part implements
PART_PROTOCOLS: dict[type, type] = {
    TipPoseTask: TargetTask,
    JointPostureTask: SecondaryTask,
    PlatformYawTask: SecondaryTask,
    BetaSplit: Weight,
    JointLimitWeights: Weight,
    ProductWeights: Weight,
    SlewPriority: VelocityShaper,
    VelocityLimit: VelocityScaler,
    LegStrokeLimit: Limit,
    JointLimit: Limit,
}
#: planner layer objects a planner holds that are data, not parts with behaviour: the small
#: platform's model (its planner's rig) and the QP's box of rates (numbers the QP reads)
DATA = (PlatformModel, RateLimit)

CASES = [(name, mechanism) for name, spec in PLANNERS.items() for mechanism in spec.mechanisms]


def built(name: str, mechanism: str) -> tuple[object, np.ndarray, TipTarget, object]:
    """(the registry's planner at the defaults, its state, a target to hold, the mechanism):
    the hybrid system's virtual joints and its tip where it is; a small platform's actuator
    lengths and its top where it is."""
    machine = MECHANISMS[mechanism]()
    x0 = np.asarray(machine.working_state, dtype=float)
    planner = PLANNERS[name].build(machine, PlannerParameters(), x0)
    if mechanism == "hybrid":
        state, transform = x0, machine.end_effector(x0)
    else:
        model = PlatformModel(machine, z_hold=float(x0[0]))
        state, transform = model.leg_lengths(x0), model.transform(x0)
    return planner, state, TipTarget(transform, np.zeros(6)), machine


def parts(obj: object) -> Iterator[object]:
    """Every object of the planner layer that `obj` holds, at any depth (fields, tuples)."""
    values = (
        [getattr(obj, f.name) for f in dataclasses.fields(obj)]
        if dataclasses.is_dataclass(obj)
        else list(vars(obj).values())
        if hasattr(obj, "__dict__")
        else []
    )
    for value in values:
        for item in value if isinstance(value, tuple) else (value,):
            if type(item).__module__.startswith("twin.planners."):
                yield item
                yield from parts(item)


@pytest.mark.parametrize(("name", "mechanism"), CASES)
def test_registry_planner_is_a_planner(name: str, mechanism: str) -> None:
    """Every registry planner conforms to the Planner protocol and steps to a finite velocity of the
    state's shape."""
    planner, state, target, _ = built(name, mechanism)
    assert isinstance(planner, Planner)
    assert conformance(planner, Planner) == []
    planner.reset(state, target)
    out = planner.step(state, target, 0.05)
    assert isinstance(out, PlannerOutput)
    assert np.shape(out.velocity) == state.shape
    assert np.all(np.isfinite(out.velocity))


@pytest.mark.parametrize(("name", "mechanism"), CASES)
def test_every_part_implements_its_protocol(name: str, mechanism: str) -> None:
    """Every part of every registry planner has a protocol and conforms to it."""
    planner, *_ = built(name, mechanism)
    for part in parts(planner):
        if isinstance(part, DATA):
            continue
        # a new kind of part needs a protocol (and a line in PART_PROTOCOLS)
        assert type(part) in PART_PROTOCOLS, f"{name}: {type(part).__name__} has no protocol"
        protocol = PART_PROTOCOLS[type(part)]
        assert isinstance(part, protocol), (name, type(part).__name__, protocol.__name__)
        assert conformance(part, protocol) == [], name


def test_the_registry_composes_every_kind_of_part() -> None:
    """The walk above sees parts at all: across the registry every protocol has one."""
    seen = {
        PART_PROTOCOLS[type(p)]
        for name, mechanism in CASES
        for p in parts(built(name, mechanism)[0])
        if type(p) in PART_PROTOCOLS
    }
    assert seen == {TargetTask, SecondaryTask, Weight, Limit, VelocityShaper, VelocityScaler}
    assert all(issubclass(p, Task) for p in (TargetTask, SecondaryTask))


def hybrid_parts() -> tuple[dict[type, list[object]], np.ndarray, TipTarget]:
    """The hybrid planners' parts by protocol, at a state off the working one."""
    found: dict[type, list[object]] = {}
    for name, mechanism in CASES:
        if mechanism == "hybrid":
            for p in parts(built(name, mechanism)[0]):
                if type(p) in PART_PROTOCOLS:
                    found.setdefault(PART_PROTOCOLS[type(p)], []).append(p)
    _, xi, target, machine = built("mtmp", "hybrid")
    xi = xi + np.r_[0.05, -0.04, 0.03, 0.02, -0.03, 0.04, 0.01, -0.02, 0.1]
    assert machine.within_limits(xi)
    return found, xi, target


def test_parts_return_what_their_protocols_promise() -> None:
    """Tasks, weights, limits, shapers and scalers return the shapes and signs their protocols
    promise, finite."""
    found, xi, target = hybrid_parts()
    n = xi.shape[-1]
    for task in found[TargetTask] + found[SecondaryTask]:
        J = task.jacobian(xi)
        assert J.ndim == 2 and J.shape[1] == n and np.all(np.isfinite(J))
        if isinstance(task, TargetTask):
            demand, error = task.demand(xi, target)
            assert demand.shape == error.shape == task.error(xi, target).shape == J.shape[:1]
            # off the target: the tip is away from where it was held, so e ≠ 0
            assert np.linalg.norm(error) > 1e-6
        else:
            assert task.demand(xi).shape == J.shape[:1]
    for weight in found[Weight]:
        w = weight(xi)
        assert w.shape == xi.shape and np.all(w >= 0) and np.all(np.isfinite(w))
    for limit in found[Limit]:
        C, lower, upper = limit.rows(xi, 0.05)
        assert C.shape[1] == n and lower.shape == upper.shape == C.shape[:1]
        assert np.all(lower <= upper)  # inside the limits the rows admit v = 0
        assert np.all(lower <= 0) and np.all(upper >= 0)
    v = np.linspace(-2.0, 2.0, n)
    for shaper in found[VelocityShaper]:
        assert shaper(xi, v).shape == v.shape
    for scaler in found[VelocityScaler]:
        scaled, scale = scaler(v)
        assert 0 < scale < 1  # v exceeds the hybrid system's rate limits
        np.testing.assert_allclose(scaled, v * scale)


class _NoReset:
    def step(self, xi: np.ndarray, target: TipTarget, dt: float) -> PlannerOutput:
        return PlannerOutput(np.zeros_like(xi))


class _StepWithoutDt(_NoReset):
    def reset(self, xi: np.ndarray, target: TipTarget) -> None:
        del xi, target

    def step(self, xi: np.ndarray, target: TipTarget) -> PlannerOutput:
        return PlannerOutput(np.zeros_like(xi))


def test_conformance_names_what_is_missing_or_mis_signed() -> None:
    """conformance names a missing method and a method with the wrong number of arguments, which
    isinstance misses."""
    assert not isinstance(_NoReset(), Planner)
    assert conformance(_NoReset(), Planner) == ["_NoReset has no 'reset'"]
    assert isinstance(_StepWithoutDt(), Planner)  # isinstance sees only the names
    (problem,) = conformance(_StepWithoutDt(), Planner)
    assert "step takes 2-2 positional arguments" in problem and "3-3" in problem

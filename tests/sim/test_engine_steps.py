"""The engine's (`twin.sim.engine.Simulation`) steps judged on their own, step by step.

A run's samples must keep the step's contract, checked here from the outcome by independent
statements (`tests.sim.oracle`), not against a second stepping of the same code:

- hybrid, `hold`: every step either whole (s = 1) or shortened to the longest that keeps every
  joint and leg no further past its limit, to the bisection's resolution measured from the
  run (`Guard`); integration on SE(3) by scipy's `expm`; `record`: never shortened, and the
  limits are passed; qp: its own limits keep the run inside them, no step shortened;
- small platforms: the lengths inside the stroke, the state the fit of its lengths;
- the held targets the kernels read: `held_target` of the held pose on the scenario's sea;
- every mid-run change (knobs, planner, joint-limit mode, sea) keeps the contract in the mode
  then in force, leaves the steps before it alone and changes the run after it; an injected
  planner fault (a NaN target) or a failed base motion holds the run as it says.

The planner's velocity itself is held to the papers' tables and properties in tests/planners
(the objects' `step` is the engine's step code) and to Pinocchio in
tests/sim/test_pinocchio_peer.py.

Runs are 3 s at dt = 0.05 (60 steps). The hybrid system starts towards its joint limits in a
rough sea, so `hold` mode shortens steps and `record` mode passes the limits; the Upr4 starts
near full stroke with a fast PID (its end stops hold), the Upu3Up meets its speed limit.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

import numpy as np
import pytest

from tests.sim.oracle import (
    FIT_TOL,
    Guard,
    assert_platform_steps,
    held_target,
    limit_excess,
    pack_target,
    resolution_of,
)
from twin.mechanisms import HybridBoardingSystem
from twin.planners import PlatformModel, get_planner
from twin.sim.base_motion import BaseMotion, BaseSamples
from twin.sim.engine import Simulation
from twin.sim.scenario import Scenario
from twin.spatial import pose_to_transform

DT = 0.05
DURATION = 3.0
STEPS = round(DURATION / DT)
#: the step at which a run is changed or a fault injected
K = 20
H = HybridBoardingSystem()
GUARD = Guard(H, DT)
#: the platform yaw, q1 and q2 60 % of the way from the working state to their upper limits:
#: in sea state 7 every planner meets a limit within 3 s, and keeps moving in `hold` mode
NEAR_LIMITS = list(
    H.working_state + 0.6 * np.r_[np.zeros(5), 1, 1, 1, 0] * (H.upper - H.working_state)
)

HYBRID = ("pi", "wpi", "mtmp", "dwa", "conv1", "conv2", "qp")
#: (mechanism, planner, joint_limits): every planner of every mechanism in both modes (the
#: small platforms' end stops hold in either, so one mode each here;
#: `test_platform_joint_limits_move_nothing` runs `record` too)
CASES = [("hybrid", p, mode) for p in HYBRID for mode in ("record", "hold")] + [
    (m, p, "hold") for m in ("upu3up", "upr4") for p in ("pid", "ik")
]
IDS = ["-".join(case) for case in CASES]
PLATFORMS = [case for case in CASES if case[0] != "hybrid"]
#: the scenario fields of each mechanism's runs (γ 3.3 and 200 components, the former
#: defaults: seas known to carry every case to its limits)
SEA = dict(gamma=3.3, n_components=200)
FIELDS = {
    "hybrid": dict(sea_state=7, seed=1, initial_state=NEAR_LIMITS, **SEA),
    "upu3up": dict(sea_state=9, seed=1, **SEA),
    "upr4": dict(sea_state=9, seed=1, kp=30.0, initial_state=[0.84, 0.0, 0.0], **SEA),
}
#: a planner switch for each planner, across families where there are two
SWITCH = {"pi": "mtmp", "wpi": "dwa", "mtmp": "conv1", "dwa": "pi", "conv1": "conv2",
          "conv2": "qp", "qp": "wpi", "pid": "ik", "ik": "pid"}  # fmt: skip


def scenario(mechanism: str, planner: str, joint_limits: str) -> dict:
    return dict(mechanism=mechanism, planner=planner, joint_limits=joint_limits,
                duration=DURATION, dt=DT, **FIELDS[mechanism])  # fmt: skip


def states_of(sim: Simulation) -> np.ndarray:
    return sim.series()["xi" if sim.lanes.kind == "hybrid" else "state"]


def assert_steps(
    sim: Simulation, modes: list[str], planners: list[str], held: tuple[int, ...] = ()
) -> None:
    """Every step of lane 0 keeps the step's contract in its joint-limit mode and for its
    planner (`modes`, `planners`: per step), and the fault counts say so; the steps `held`
    (a planner fault injected) hold the state exactly, scale 0."""
    series, counts = sim.series(), dict(sim.faults[0].counts)
    assert len(modes) == len(planners) == series["t"].size - 1
    faulted = np.zeros(len(modes), dtype=bool)
    faulted[list(held)] = True
    assert counts["planner"] == faulted.sum()
    if sim.lanes.kind != "hybrid":
        model = sim.lanes.models[0]
        assert_platform_steps(model, series["state"], series["legs"], held=faulted)
        limited = np.any(np.isin(series["legs"][1:], np.ravel(model.stroke)), -1)
        assert counts["joint_limit"] <= np.count_nonzero(limited)
        return
    xs, scales = series["xi"], series["limit_scale"][1:]
    shortened = (scales < 1.0) & ~faulted
    resolution = guard_resolution()
    assert np.all(scales / resolution == np.round(scales / resolution))
    for k, (mode, planner) in enumerate(zip(modes, planners, strict=True)):
        if faulted[k]:
            np.testing.assert_array_equal(xs[k + 1], xs[k])
            assert scales[k] == 0.0
        elif planner == "qp":  # its limits are its own: never a step to shorten
            assert scales[k] == 1.0
            assert np.all(limit_excess(H, xs[k + 1]) <= limit_excess(H, xs[k]) + FIT_TOL)
        else:
            hold = mode == "hold"
            GUARD.check(xs[k], xs[k + 1], float(scales[k]), None, hold, resolution=resolution)
    assert counts["joint_limit"] == np.count_nonzero(shortened)


def finish(sim: Simulation) -> None:
    sim.run()
    assert sim.k == STEPS


@cache
def plain_run(case: tuple[str, str, str]) -> dict[str, np.ndarray]:
    """The series of the case's plain run (cached: first called before a fault is injected)."""
    sim = Simulation(scenario(*case))
    finish(sim)
    return sim.series()


def baseline(case: tuple[str, str, str]) -> np.ndarray:
    """The engine's states of the case's plain run (what a change must change)."""
    return plain_run(case)["xi" if case[0] == "hybrid" else "state"]


@cache
def guard_resolution() -> float:
    """The joint-limit guard's resolution, measured from the outcomes of the plain `hold` runs
    of the hybrid's guarded planners (`resolution_of`)."""
    cases = [c for c in CASES if c[0] == "hybrid" and c[2] == "hold" and c[1] != "qp"]
    return resolution_of(np.concatenate([plain_run(c)["limit_scale"][1:] for c in cases]))


def assert_changed(sim: Simulation, case: tuple[str, str, str], at: int = K) -> None:
    """The change made a difference after step `at` and none before."""
    states = states_of(sim)
    np.testing.assert_array_equal(states[: at + 1], baseline(case)[: at + 1])
    assert np.abs(states[at + 1 :] - baseline(case)[at + 1 :]).max() > 1e-6


# ----------------------------------------------------------------------------------- tests


def test_the_guard_is_fine_and_its_steps_the_longest() -> None:
    """The guard's resolution, measured from its outcomes (0 < s < 1 in the plain `hold`
    runs), is finer than 1e-3 of a step; those runs shorten enough steps to measure it."""
    assert guard_resolution() <= 1e-3


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_run_keeps_the_step_contract(case: tuple[str, str, str]) -> None:
    """A 3 s run: every step as the guard, the integrator and the actuators allow; the limits
    are met as the mode says (hybrid: `hold` shortens steps and passes no limit it was inside,
    `record` passes them; qp: its limits bind and it passes none; Upr4: the end stops hold)."""
    sim = Simulation(scenario(*case))
    finish(sim)
    mechanism, planner, mode = case
    assert_steps(sim, [mode] * STEPS, [planner] * STEPS)
    counts, series = sim.faults[0].counts, sim.series()
    if planner == "qp":
        assert not np.any([limit_excess(H, x) > 0 for x in series["xi"]])
        assert series["qp_active"].max() > 0
    elif mechanism == "hybrid":
        passed = np.any([limit_excess(H, x) > 1e-9 for x in series["xi"]])  # fmt: skip
        assert (counts["joint_limit"] > 0, passed) == (
            (True, False) if mode == "hold" else (False, True)
        )
    elif mechanism == "upr4":
        assert counts["joint_limit"] > 0
    else:
        assert series["saturated"].sum() > 10


def update_cases() -> list:
    out = []
    for case, name in zip(CASES, IDS, strict=True):
        mechanism, planner, mode = case
        if mechanism == "hybrid":
            changes = [{"beta": 0.3, "k_e": 15.0}, {"planner": SWITCH[planner]},
                       {"joint_limits": "hold" if mode == "record" else "record"}]  # fmt: skip
        else:
            changes = [{"kp": 3.0, "actuator_speed": 0.005}, {"planner": SWITCH[planner]}]
        changes += [{"sea_state": 5}, {"sea_state": 5, "planner": SWITCH[planner]}]
        out += [pytest.param(case, c, id=f"{name}-{'-'.join(c)}") for c in changes]
    return out


@pytest.mark.parametrize(("case", "changes"), update_cases())
def test_update_keeps_the_step_contract(case: tuple[str, str, str], changes: dict) -> None:
    """Knobs, planner, joint-limit mode or sea changed after K steps: the steps before K are
    the plain run's, the change changes the run after it (where the planner reads what
    changed), and every step keeps the contract of the mode and planner then in force; a new
    sea is sampled from K on."""
    mechanism, planner, mode = case
    sim = Simulation(scenario(*case))
    sim.advance(K)
    assert sim.update(changes) == set(changes)
    if "sea_state" in changes:
        assert sim._block.start == K  # the new sea's block
    finish(sim)
    after = {**dict(planner=planner, joint_limits=mode), **changes}
    assert_steps(sim, [mode] * K + [after["joint_limits"]] * (STEPS - K),
                 [planner] * K + [after["planner"]] * (STEPS - K))  # fmt: skip
    reads = set(get_planner(planner, mechanism).parameters) | {"planner", "joint_limits",
                                                               "sea_state"}  # fmt: skip
    if planner == "qp":  # it keeps its limits itself: `hold` never has a step to shorten
        reads.discard("joint_limits")
    if set(changes) & reads:  # a knob the planner does not read: a reset, maybe a no-op
        assert_changed(sim, case)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_nan_target_holds_the_step(
    case: tuple[str, str, str], nan_target: Callable[..., None]
) -> None:
    """A NaN twist in the target of step K: the engine holds the state for that step exactly
    (limit scale 0) and flags one PLANNER fault; every other step keeps the contract and the
    run moves on."""
    guard_resolution()  # measured (and cached) on the unbroken runs first
    nan_target(K)
    sim = Simulation(scenario(*case))
    finish(sim)
    states = states_of(sim)
    assert np.any(states[K + 2 :] != states[K + 1])  # moving again
    assert_steps(sim, [case[2]] * STEPS, [case[1]] * STEPS, held=(K,))


@pytest.mark.parametrize("case", PLATFORMS, ids=["-".join(case) for case in PLATFORMS])
def test_platform_joint_limits_move_nothing(case: tuple[str, str, str]) -> None:
    """A small platform's end stops hold in either joint-limit mode: a run in `record`, and a
    `hold` run switched to `record` at K (no rebuild: the PID's integral and the actuator
    lengths carry on), equal the `hold` run sample for sample. The mode shows only in the
    metrics: `record` counts every clamped sample as a violation, `hold` counts them as held
    steps instead."""
    mechanism, planner, _ = case
    recorded = Simulation(scenario(mechanism, planner, "record"))
    finish(recorded)
    switched = Simulation(scenario(*case))
    switched.advance(K)
    assert switched.update({"joint_limits": "record"}) == {"joint_limits"}
    finish(switched)
    held = Simulation(scenario(*case))
    held.run()
    assert_steps(held, ["hold"] * STEPS, [planner] * STEPS)
    for sim in (recorded, switched):
        got = sim.series()
        for key, value in held.series().items():
            np.testing.assert_array_equal(got[key], value, err_msg=key)
        assert dict(sim.faults[0].counts) == dict(held.faults[0].counts)
    record, hold = recorded.result().metrics, held.result().metrics
    assert record["limit_violations"]["clamped"] == record["clipped"] > 0
    assert record["violations"] > hold["violations"]
    assert hold["fault_counts"]["joint_limit"] == record["clipped"]


def block_rows(sim: Simulation, start: int, stop: int) -> np.ndarray:
    """The held target rows (stop − start, 18) the engine hands its kernels for steps
    start … stop − 1 of lane 0, from its current block of base samples."""
    block = sim._block
    assert block.start <= start and stop <= block.start + block.steps
    return sim.targets(block, start - block.start, stop - start)[0]


#: the base samples whose pose is NaN in `test_base_motion_fault_holds_the_target`: 2.1 …
#: 2.5 s, where every case moves (in `hold` mode pi, wpi, mtmp and conv1 stand still on their
#: limits, step scale 0, from about 0.3 s to 2 s or later: a held target there changes nothing)
BASE_FAULT = (42, 50)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_base_motion_fault_holds_the_target(
    case: tuple[str, str, str], nan_sea: Callable[..., None]
) -> None:
    """The base motion fails (NaN poses from `BaseMotion.uniform_poses` and `poses`) at samples
    42 … 50: the engine hands its kernels `held_target` of the last good pose (sample 41) for
    every step that reads a failed sample (computed here from the unbroken sea: a still
    target), flags those ten steps BASE_MOTION, and every step keeps the contract; the run is
    the plain run's up to the failure and not after it."""
    first, last = BASE_FAULT
    t = np.arange(STEPS + 1) * DT
    s = Scenario(**scenario(*case))
    poses = BaseMotion.of(s).poses(t)
    plain = baseline(case)  # cached now, before the sea fails: later it would be the broken run
    guard_resolution()  # likewise
    nan_sea(first * DT, last * DT)
    sim = Simulation(s)
    rows = block_rows(sim, 0, STEPS)
    finish(sim)
    assert sim.faults[0].counts["base_motion"] == last - first + 2
    assert_steps(sim, [case[2]] * STEPS, [case[1]] * STEPS)
    poses[first : last + 1] = poses[first - 1]
    base = BaseSamples(t, poses, pose_to_transform(poses))
    for k, row in enumerate(rows):
        want = pack_target(held_target(sim.held[0], base, k, DT))
        np.testing.assert_allclose(row, want, rtol=0, atol=1e-9, err_msg=f"step {k}")
    assert not np.any(rows[first - 1 : last, 12:])  # a still target: no twist
    states = states_of(sim)
    np.testing.assert_array_equal(states[:first], plain[:first])
    assert np.abs(states[first:] - plain[first:]).max() > 1e-6


def held_pose(mechanism: object, x0: np.ndarray, base: BaseSamples) -> np.ndarray:
    """ᴵT* as the rigs' reset fixed it at the base's first sample: the hybrid's tip; a small
    platform's top, level, with the base's heading."""
    T_IB0 = base.transform[0]
    if isinstance(mechanism, HybridBoardingSystem):
        return T_IB0 @ mechanism.end_effector(x0)
    top = T_IB0 @ PlatformModel(mechanism, z_hold=float(x0[0])).transform(x0)
    return pose_to_transform(np.r_[top[:3, 3], 0.0, 0.0, base.pose[0, 5]])


@pytest.mark.parametrize("mechanism", ["hybrid", "upu3up", "upr4"])
def test_targets_are_the_held_targets(mechanism: str) -> None:
    """The rows the engine hands the kernels are `held_target` (scipy's rotation logarithm)
    of the held pose on the scenario's own base motion, before and after a sea change at K."""
    planner = {"hybrid": "wpi"}.get(mechanism, "pid")
    s = Scenario(**scenario(mechanism, planner, "hold"))
    sim = Simulation(s)
    sim.advance(K)
    rows = [block_rows(sim, 0, K)]
    sim.update({"sea_state": 5})
    rows.append(block_rows(sim, K, STEPS))
    finish(sim)
    t = np.arange(STEPS + 1) * DT
    before = BaseMotion.of(s).sample(t)
    after = BaseMotion.of(Scenario(**{**s.model_dump(), "sea_state": 5})).sample(t)
    x0 = np.array(s.initial_state or sim.mechanism.working_state, dtype=float)
    held = held_pose(sim.mechanism, x0, before)
    np.testing.assert_allclose(sim.held[0], held, rtol=0, atol=1e-12)
    for k, row in enumerate(np.concatenate(rows)):
        want = pack_target(held_target(held, before if k < K else after, k, DT))
        np.testing.assert_allclose(row, want, rtol=0, atol=1e-9, err_msg=f"step {k}")
    assert np.abs(after.pose[K:] - before.pose[K:]).max() > 0.1  # the sea did change


@pytest.mark.parametrize(
    "case", [("hybrid", "wpi", "hold"), ("upu3up", "pid", "hold"), ("upr4", "pid", "hold")],
    ids=["hybrid", "upu3up", "upr4"],
)  # fmt: skip
def test_update_at_the_end_of_a_block(case: tuple[str, str, str]) -> None:
    """A knob changed at the last step of the engine's block (here: a run extended from 2 s
    to 3 s at its end, with a new planner knob) replans as anywhere else: the 2 s are the
    plain run's, the rest keeps the contract and differs from the plain run's."""
    sim = Simulation({**scenario(*case), "duration": 2.0})
    sim.run()
    at = sim.k
    assert sim.k == sim._block.start + sim._block.steps  # the block is used up
    changes = {"duration": DURATION, "kp" if case[0] != "hybrid" else "beta": 0.3}
    assert sim.update(changes) == set(changes)
    finish(sim)
    assert_steps(sim, [case[2]] * STEPS, [case[1]] * STEPS)
    assert_changed(sim, case, at)

"""The engine (`twin.sim.engine.Simulation`) equals its oracle step by step, to 1e-9.

The oracle (`tests.sim.oracle.OracleRun`) steps one lane with the planner objects as the
former rigs did, on the engine's own held targets: every planner of every mechanism, in both
joint-limit modes, through a plain run, a mid-run change of knobs, planner or joint-limit
mode, an injected planner fault (a NaN target), a stretch of failed base motion (NaN base
poses) and a change of sea. The rows the engine hands its kernels are checked against
`held_target` on their own (`test_targets_are_the_held_targets`, and the held rows of a failed
base motion in `test_base_motion_fault_holds_as_the_oracle`), so the shared targets are no
blind spot.

Runs are 3 s at dt = 0.05 (60 steps). The hybrid system starts towards its joint limits in a
rough sea, so `hold` mode shortens steps and `record` mode passes the limits; the Upr4 starts
near full stroke with a fast PID (its end stops hold), the Upu3Up meets its speed limit.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

import numpy as np
import pytest

from tests.sim.oracle import OracleRun, held_target, pack_target, unpack_target
from twin.mechanisms import HybridBoardingSystem
from twin.planners import PlatformModel, TipTarget, get_planner
from twin.sim.base_motion import BaseMotion, BaseSamples
from twin.sim.engine import Simulation
from twin.sim.kernels.layout import TARGET_V
from twin.sim.scenario import Scenario
from twin.spatial import pose_to_transform, so3_exp

TOL = 1e-9
DT = 0.05
DURATION = 3.0
#: the step at which a run is changed or a fault injected
K = 20
H = HybridBoardingSystem()
#: the platform yaw, q1 and q2 60 % of the way from the working state to their upper limits:
#: in sea state 7 every planner meets a limit within 3 s, and keeps moving in `hold` mode
NEAR_LIMITS = list(
    H.working_state + 0.6 * np.r_[np.zeros(5), 1, 1, 1, 0] * (H.upper - H.working_state)
)

HYBRID = ("pi", "wpi", "mtmp", "dwa", "conv1", "conv2", "qp")
#: (mechanism, planner, joint_limits): every planner of every mechanism in both modes (the
#: small platforms' end stops hold in either and their kernel never reads the mode, so one
#: mode each here; `test_platform_joint_limits_move_nothing` holds `record` to the oracle)
CASES = [("hybrid", p, mode) for p in HYBRID for mode in ("record", "hold")] + [
    (m, p, "hold") for m in ("upu3up", "upr4") for p in ("pid", "ik")
]
IDS = ["-".join(case) for case in CASES]
#: the small platforms' cases
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


def start(case: tuple[str, str, str]) -> tuple[Simulation, OracleRun]:
    sim = Simulation(scenario(*case))
    return sim, OracleRun(sim)


def finish(sim: Simulation, oracle: OracleRun) -> None:
    """Run the engine to its end in one chunk, the oracle after it."""
    sim.run()
    oracle.follow()
    assert sim.k == oracle.k == round(DURATION / DT)


def assert_equal_runs(sim: Simulation, oracle: OracleRun) -> None:
    """States (and actuator lengths) at every step to TOL; the step diagnostics the engine
    records (limit scale; clipped, saturated) from step 1 on; the fault counts per kind."""
    series = sim.series()
    key = "xi" if oracle.hybrid else "state"
    states = np.array(oracle.states)
    assert series[key].shape == states.shape
    for k, (got, want) in enumerate(zip(series[key], states, strict=True)):
        np.testing.assert_allclose(got, want, rtol=0, atol=TOL, err_msg=f"{key} at step {k}")
    if oracle.hybrid:
        np.testing.assert_allclose(series["limit_scale"][1:], oracle.scales, rtol=0, atol=TOL)
    else:
        np.testing.assert_allclose(series["legs"], np.array(oracle.legs), rtol=0, atol=TOL)
        for name in ("clipped", "saturated"):
            want = [d.get(name, 0.0) for d in oracle.diagnostics]
            np.testing.assert_array_equal(series[name][1:], want, err_msg=name)
    assert dict(sim.faults[0].counts) == oracle.fault_counts()


@cache
def baseline(case: tuple[str, str, str]) -> np.ndarray:
    """The engine's states of the case's plain run (what a change must change)."""
    sim = Simulation(scenario(*case))
    sim.run()
    return sim.series()["xi" if case[0] == "hybrid" else "state"]


def assert_changed(sim: Simulation, case: tuple[str, str, str]) -> None:
    """The change made a difference after step K (so the equality above could fail) and none
    before."""
    states = sim.series()["xi" if case[0] == "hybrid" else "state"]
    np.testing.assert_array_equal(states[: K + 1], baseline(case)[: K + 1])
    assert np.abs(states[K + 1 :] - baseline(case)[K + 1 :]).max() > 1e-6


# ----------------------------------------------------------------------------------- tests


def test_target_rows_round_trip(rng: np.random.Generator) -> None:
    """`unpack_target` inverts `pack_target`, row by row where the layout says."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = so3_exp(rng.normal(size=3)), rng.normal(size=3)
    target = TipTarget(T, rng.normal(size=6))
    row = pack_target(target)
    np.testing.assert_array_equal(row, np.r_[T[:3, :3].ravel(), T[:3, 3], target.twist])
    back = unpack_target(row)
    np.testing.assert_array_equal(back.transform, T)
    np.testing.assert_array_equal(back.twist, target.twist)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_run_equals_oracle(case: tuple[str, str, str]) -> None:
    """A 3 s run: every step as the oracle's; the limits are met as the mode says (hybrid:
    `hold` shortens steps, `record` passes the limits; qp: its limits bind, it passes none and
    needs no shortening; Upr4: the end stops hold)."""
    sim, oracle = start(case)
    finish(sim, oracle)
    assert_equal_runs(sim, oracle)
    counts = oracle.fault_counts()
    if case[1] == "qp":
        assert counts["joint_limit"] == 0
        assert not np.any(H.limit_excess(np.array(oracle.states)) > 0)
        assert max(d["qp_active"] for d in oracle.diagnostics) > 0
        np.testing.assert_array_equal(sim.series()["qp_active"][1:],
                                      [d["qp_active"] for d in oracle.diagnostics])  # fmt: skip
        np.testing.assert_array_equal(sim.series()["qp_level"][1:],
                                      [d["qp_level"] for d in oracle.diagnostics])  # fmt: skip
    elif case[0] == "hybrid":
        passed = np.any(H.limit_excess(np.array(oracle.states)) > 1e-9)
        assert (counts["joint_limit"] > 0, passed) == (
            (True, False) if case[2] == "hold" else (False, True)
        )
    elif case[0] == "upr4":
        assert counts["joint_limit"] > 0
    else:
        assert sum(d["saturated"] for d in oracle.diagnostics) > 10


def update_cases() -> list:
    out = []
    for case, name in zip(CASES, IDS, strict=True):
        mechanism, planner, mode = case
        if mechanism == "hybrid":
            changes = [{"beta": 0.3, "k_e": 15.0}, {"planner": SWITCH[planner]},
                       {"joint_limits": "hold" if mode == "record" else "record"}]  # fmt: skip
        else:
            changes = [{"kp": 3.0, "actuator_speed": 0.005}, {"planner": SWITCH[planner]}]
        out += [pytest.param(case, c, id=f"{name}-{'-'.join(c)}") for c in changes]
    return out


@pytest.mark.parametrize(("case", "changes"), update_cases())
def test_update_equals_oracle(case: tuple[str, str, str], changes: dict) -> None:
    """Knobs, planner or joint-limit mode changed after K steps: the engine rebuilds and
    repacks the planner at the current state (the oracle rebuilds its object likewise) or
    switches hold mode; every step still equals the oracle's, and the change changed the run."""
    sim, oracle = start(case)
    sim.advance(K)
    oracle.follow()
    assert sim.update(changes) == set(changes)
    oracle.update(changes)
    finish(sim, oracle)
    assert_equal_runs(sim, oracle)
    reads = set(get_planner(case[1], case[0]).parameters) | {"planner", "joint_limits"}
    if case[1] == "qp":  # it keeps its limits itself: `hold` never has a step to shorten
        reads.discard("joint_limits")
    if set(changes) & reads:  # a knob the planner does not read: a reset, maybe a no-op
        assert_changed(sim, case)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_nan_target_holds_as_the_oracle(
    case: tuple[str, str, str], nan_target: Callable[..., None]
) -> None:
    """A NaN twist in the target of step K: the engine holds the state for that step and
    flags one PLANNER fault, as the oracle does, and the run goes on as the oracle's."""
    nan_target(K)
    sim, oracle = start(case)
    finish(sim, oracle)
    assert not np.all(np.isfinite(oracle.targets[K]))
    key = "xi" if oracle.hybrid else "state"
    states = sim.series()[key]
    np.testing.assert_array_equal(states[K + 1], states[K])  # held, exactly
    assert np.any(states[K + 2 :] != states[K + 1])  # and moving again
    assert sim.faults[0].counts["planner"] == 1
    assert_equal_runs(sim, oracle)


@pytest.mark.parametrize("case", PLATFORMS, ids=["-".join(case) for case in PLATFORMS])
def test_platform_joint_limits_move_nothing(case: tuple[str, str, str]) -> None:
    """A small platform's end stops hold in either joint-limit mode: `pack_platform` records
    the mode and the kernel never reads it, and the rig (`platform_advance`) has no mode. So a
    run in `record` equals the oracle, and so does a `hold` run switched to `record` at K (no
    rebuild: the PID's integral and the actuator lengths carry on); both equal the `hold` run
    sample for sample. The mode shows only in the metrics: `record` counts every clamped
    sample as a violation, `hold` counts them as held steps instead."""
    mechanism, planner, _ = case
    recorded, oracle = start((mechanism, planner, "record"))
    finish(recorded, oracle)
    assert_equal_runs(recorded, oracle)
    switched, oracle = start(case)
    switched.advance(K)
    oracle.follow()
    assert switched.update({"joint_limits": "record"}) == {"joint_limits"}
    oracle.update({"joint_limits": "record"})
    finish(switched, oracle)
    assert_equal_runs(switched, oracle)
    held = Simulation(scenario(*case))
    held.run()
    for sim in (recorded, switched):
        got = sim.series()
        for key, value in held.series().items():
            np.testing.assert_array_equal(got[key], value, err_msg=key)
        assert dict(sim.faults[0].counts) == dict(held.faults[0].counts)
    record, hold = recorded.result().metrics, held.result().metrics
    assert record["limit_violations"]["clamped"] == record["clipped"] > 0
    assert record["violations"] > hold["violations"]
    assert hold["fault_counts"]["joint_limit"] == record["clipped"]


#: the base samples whose pose is NaN in `test_base_motion_fault_holds_as_the_oracle`: 2.1 …
#: 2.5 s, where every case moves (in `hold` mode pi, wpi, mtmp and conv1 stand still on their
#: limits, step scale 0, from about 0.3 s to 2 s or later: a held target there changes nothing)
BASE_FAULT = (42, 50)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_base_motion_fault_holds_as_the_oracle(
    case: tuple[str, str, str], nan_sea: Callable[..., None]
) -> None:
    """The base motion fails (NaN poses from `BaseMotion.uniform_poses` and `poses`) at samples
    42 … 50: the engine hands its kernels `held_target` of the last good pose (sample 41) for
    every step that reads a failed sample (computed here from the unbroken sea: a still
    target), flags those ten steps BASE_MOTION, and the run still equals the oracle's step by
    step (states, limit scale or legs, fault counts: the oracle flags the steps from its own
    sea); the run is the plain run's up to the failure and not after it."""
    first, last = BASE_FAULT
    t = np.arange(round(DURATION / DT) + 1) * DT
    s = Scenario(**scenario(*case))
    poses = BaseMotion.of(s).poses(t)
    plain = baseline(case)  # cached now, before the sea fails: later it would be the broken run
    nan_sea(first * DT, last * DT)
    sim, oracle = start(case)
    finish(sim, oracle)
    assert_equal_runs(sim, oracle)
    assert sim.faults[0].counts["base_motion"] == last - first + 2
    poses[first : last + 1] = poses[first - 1]
    base = BaseSamples(t, poses, pose_to_transform(poses))
    for k, row in enumerate(oracle.targets):
        want = pack_target(held_target(sim.held[0], base, k, DT))
        np.testing.assert_allclose(row, want, rtol=0, atol=1e-9, err_msg=f"step {k}")
    assert not np.any(np.array(oracle.targets)[first - 1 : last, TARGET_V:])
    states = sim.series()["xi" if oracle.hybrid else "state"]
    np.testing.assert_array_equal(states[:first], plain[:first])
    assert np.abs(states[first:] - plain[first:]).max() > 1e-6


def sea_cases() -> list:
    out = []
    for case, name in zip(CASES, IDS, strict=True):
        out.append(pytest.param(case, {"sea_state": 5}, id=f"{name}-sea_state"))
        both = {"sea_state": 5, "planner": SWITCH[case[1]]}
        out.append(pytest.param(case, both, id=f"{name}-sea_state-planner"))
    return out


@pytest.mark.parametrize(("case", "changes"), sea_cases())
def test_sea_state_update_equals_oracle(case: tuple[str, str, str], changes: dict) -> None:
    """The sea changed after K steps (alone, or with the planner): the engine re-synthesises
    it from there and keeps (or rebuilds on the new sea's target) the planner; the oracle reads
    the new sea's targets and does the same: every step equal."""
    sim, oracle = start(case)
    sim.advance(K)
    oracle.follow()
    assert sim.update(changes) == set(changes)
    oracle.update(changes)
    assert sim._block.start == K  # the new sea's block
    finish(sim, oracle)
    assert_equal_runs(sim, oracle)
    assert_changed(sim, case)


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
    """The rows the engine hands the kernels (and the oracle reads) are `held_target` of the
    held pose on the scenario's own base motion, before and after a sea change at K."""
    planner = {"hybrid": "wpi"}.get(mechanism, "pid")
    s = Scenario(**scenario(mechanism, planner, "hold"))
    sim = Simulation(s)
    oracle = OracleRun(sim)
    sim.advance(K)
    oracle.follow()
    sim.update({"sea_state": 5})
    oracle.update({"sea_state": 5})
    finish(sim, oracle)
    t = np.arange(round(DURATION / DT) + 1) * DT
    before = BaseMotion.of(s).sample(t)
    after = BaseMotion.of(Scenario(**{**s.model_dump(), "sea_state": 5})).sample(t)
    x0 = np.array(s.initial_state or sim.mechanism.working_state, dtype=float)
    held = held_pose(sim.mechanism, x0, before)
    np.testing.assert_allclose(sim.held[0], held, rtol=0, atol=1e-12)
    for k, row in enumerate(oracle.targets):
        want = pack_target(held_target(held, before if k < K else after, k, DT))
        np.testing.assert_allclose(row, want, rtol=0, atol=1e-9, err_msg=f"step {k}")
    assert np.abs(after.pose[K:] - before.pose[K:]).max() > 0.1  # the sea did change


@pytest.mark.parametrize(
    "case", [("hybrid", "wpi", "hold"), ("upu3up", "pid", "hold"), ("upr4", "pid", "hold")],
    ids=["hybrid", "upu3up", "upr4"],
)  # fmt: skip
def test_update_at_the_end_of_a_block(case: tuple[str, str, str]) -> None:
    """A knob changed at the last step of the engine's block (here: a run extended from 2 s
    to 3 s at its end, with a new planner knob) replans as anywhere else."""
    sim = Simulation({**scenario(*case), "duration": 2.0})
    oracle = OracleRun(sim)
    sim.run()
    oracle.follow()
    assert sim.k == sim._block.start + sim._block.steps  # the block is used up
    changes = {"duration": DURATION, "kp" if case[0] != "hybrid" else "beta": 0.3}
    sim.update(changes)
    oracle.update(changes)
    finish(sim, oracle)
    assert_equal_runs(sim, oracle)

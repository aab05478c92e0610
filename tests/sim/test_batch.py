"""simulate_many: many scenarios as lanes of the one engine give simulate's results, scenario by
scenario, compiled or interpreted."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from twin.mechanisms import HybridBoardingSystem
from twin.sim import simulate, simulate_many
from twin.sim.base_motion import BaseMotion
from twin.sim.lanes import numba_available
from twin.sim.scenario import Scenario
from twin.vessel import MOUNTS, load_raos, vessel_motion

ENGINES = ["python", pytest.param("numba", marks=pytest.mark.skipif(
    not numba_available(), reason="numba not installed"))]  # fmt: skip

#: one group per planner, two seas and a start off the working state; 4 s = 80 steps
SCENARIOS = [
    {"planner": planner, "sea_state": sea, "seed": seed, "duration": 4.0}
    for planner in ("mtmp", "pi", "wpi", "dwa", "conv1", "conv2")
    for sea, seed in ((3, 0), (5, 1))
] + [
    {"planner": "mtmp", "hs": 3.0, "tp": 8.0, "beta": 0.4, "k_c": 3.0, "duration": 4.0},
    {"planner": "mtmp", "sea_state": 4, "duration": 4.0,
     "initial_state": [0.1, -0.1, 2.6, 0.02, -0.03, 0.05, 0.1, 0.05, 12.0]},
    {"mechanism": "upr4", "duration": 2.0},
    {"mechanism": "upr4", "planner": "ik", "duration": 2.0, "seed": 3},
    {"mechanism": "upu3up", "duration": 2.0, "sea_state": 6},
    {"mechanism": "upu3up", "planner": "ik", "duration": 2.0},
    # undamped with a rank-deficient J_W, and held at the limits
    {"planner": "wpi", "beta": 0.0, "damping": 0.0, "sea_state": 4, "duration": 2.0},
    {"planner": "pi", "sea_state": 5, "duration": 4.0, "joint_limits": "hold"},
    {"planner": "dwa", "sea_state": 6, "duration": 4.0, "joint_limits": "hold"},
]  # fmt: skip


def assert_same(expected, actual) -> None:
    """Series to 1e-9 (relative, or absolute near zero), metrics equal likewise."""
    assert list(actual.series) == list(expected.series)
    for key, value in expected.series.items():
        assert actual.series[key].shape == value.shape, key
        np.testing.assert_allclose(actual.series[key], value, rtol=1e-9, atol=1e-9, err_msg=key)
    assert_same_metrics(actual.metrics, expected.metrics)


@pytest.fixture(scope="module")
def references() -> list:
    """Each scenario alone, compiled (the interpreted engine is held against these too)."""
    return [simulate(s) for s in SCENARIOS]


@pytest.mark.parametrize("engine", ENGINES)
def test_simulate_many_equals_simulate(engine: str, references: list) -> None:
    """Every scenario's series and metrics equal simulate's (seed 000 planners, seed 004's,
    the small platforms), compiled in lanes and interpreted (the engine without numba)."""
    scenarios = SCENARIOS if engine == "numba" else SCENARIOS[::4]  # interpreted is slow
    references = references if engine == "numba" else references[::4]
    results = simulate_many(scenarios, engine=engine)
    assert len(results) == len(scenarios)
    for expected, actual in zip(references, results, strict=True):
        assert actual.scenario == expected.scenario
        assert_same(expected, actual)


@pytest.mark.parametrize("engine", ENGINES)
def test_rough_sea_with_damping_and_rate_limits(engine: str) -> None:
    """Where MTMP's damping (the SVD branch) and the rate limit act, the numbers still agree."""
    scenario = {"planner": "mtmp", "sea_state": 7, "duration": 6.0}
    expected = simulate(scenario, engine="numba" if numba_available() else "python")
    assert np.any(expected.series["damping"] > 0) and np.any(expected.series["velocity_scale"] < 1)
    assert_same(expected, simulate_many([scenario, {**scenario, "seed": 1}], engine=engine)[0])


def test_base_motions_built_together_equal_each_built_alone() -> None:
    """`BaseMotion.many` (one RAO interpolation per vessel and speed) gives each lane the
    terms its own `response_amplitudes` call gives, bit for bit, across vessels, speeds,
    mechanisms, component counts and a regular-wave preset."""
    from twin.sim.base_motion import mount_for

    scenarios = [
        Scenario(sea_state=4, seed=1),
        Scenario(sea_state=6, seed=2, n_components=37, forward_speed=3.0),
        Scenario(mechanism="upr4", hs=1.0, tp=6.0, seed=3, vessel="barge"),
        Scenario(sea_state=5, seed=4, vessel="asv", heading=150.0),
        Scenario(mechanism="upr4", regular_waves="state2"),
        Scenario(sea_state=4, seed=5, forward_speed=3.0),
    ]
    for s, together in zip(scenarios, BaseMotion.many(scenarios), strict=True):
        alone = BaseMotion(s.components(), mount_for(s.mechanism), vessel=s.vessel,
                           speed=s.forward_speed)  # fmt: skip
        assert together.raos is alone.raos and together.mount == alone.mount
        np.testing.assert_array_equal(together.omega_e, alone.omega_e)
        np.testing.assert_array_equal(together.amplitude, alone.amplitude)


def test_uniform_poses_equal_vessel_motion_on_the_mount() -> None:
    """The compiled phasor sum is vessel_motion at t = t0 + k dt put on the mount, from t = 0
    and from a later start (a chunk of a running simulation), lane by lane in one call, with
    lanes of different numbers of components; a lane alone gets the same bits as among
    others; `poses` takes the same path."""
    scenarios = [Scenario(sea_state=5, heading=100.0, forward_speed=2.0, seed=3),
                 Scenario(sea_state=3, n_components=37, seed=4)]  # fmt: skip
    motions = [BaseMotion.of(s) for s in scenarios]
    t = np.arange(1001) * 0.05
    direct = np.stack([
        MOUNTS["hybrid"].pose(vessel_motion(s.components(), load_raos("sov"), t,
                                            speed=s.forward_speed))
        for s in scenarios
    ])  # fmt: skip
    assert np.abs(direct).max() > 0.1
    whole = BaseMotion.uniform_poses(motions, 0.0, 0.05, t.size)
    np.testing.assert_allclose(whole, direct, rtol=0, atol=1e-12)
    alone = BaseMotion.uniform_poses(motions[1:], 0.0, 0.05, t.size)  # the serial build
    np.testing.assert_array_equal(alone[0], whole[1])  # to the bit: no sum is reordered
    interpreted = BaseMotion.uniform_poses(motions, 0.0, 0.05, 101, compiled=False)
    np.testing.assert_allclose(interpreted, direct[:, :101], rtol=0, atol=1e-12)
    later = BaseMotion.uniform_poses(motions, 300 * 0.05, 0.05, 701)
    np.testing.assert_allclose(later, direct[:, 300:], rtol=0, atol=1e-12)
    np.testing.assert_allclose(motions[1].poses(t[:11]), direct[1, :11], rtol=0, atol=1e-12)


def test_order_and_mixed_groups_are_kept() -> None:
    """Results come back in the order given, whatever the grouping by planner and dt."""
    scenarios = [
        {"planner": "pi", "duration": 1.0, "seed": 1},
        {"planner": "mtmp", "duration": 1.0, "dt": 0.1},
        {"planner": "pi", "duration": 2.0, "seed": 2},
    ]
    results = simulate_many(scenarios)
    assert [r.scenario.planner for r in results] == ["pi", "mtmp", "pi"]
    assert [len(r.series["t"]) for r in results] == [21, 11, 41]
    assert results[0].series["xi"][0] == pytest.approx(HybridBoardingSystem().working_state)


@pytest.mark.skipif(not numba_available(), reason="numba not installed")
def test_lanes_split_over_threads_give_the_same_numbers(monkeypatch: pytest.MonkeyPatch) -> None:
    """Lanes run in parts of 3 on two threads, each part's runners serial on its thread, give
    the numbers of the same lanes run as one Simulation per planner, one after the other, with
    runners over their lanes."""
    import numba

    from twin.sim import engine

    scenarios = [{"planner": "mtmp", "sea_state": 4, "seed": s, "duration": 3.0} for s in range(6)]
    scenarios += [{"planner": "dwa", "sea_state": 6, "seed": s, "duration": 3.0} for s in range(6)]
    monkeypatch.setattr(engine, "numba_threads", lambda: 1)  # parts one after the other
    monkeypatch.setattr(engine, "MAX_LANES", 12)
    together = simulate_many(scenarios)  # a part per planner: 6 lanes, runners over lanes
    monkeypatch.setattr(engine, "numba_threads", lambda: 2)  # two threads on any machine
    monkeypatch.setattr(engine, "MAX_LANES", 4)
    names: set[str] = set()
    both = threading.Barrier(2, timeout=60)  # each thread's first part waits for the other's
    original = engine.Simulation.advance

    def advance(self: engine.Simulation, n: int) -> int:
        name = threading.current_thread().name
        if name not in names:
            names.add(name)
            both.wait()  # fails unless two threads run parts at once
        assert numba.get_num_threads() == 1  # the part's runners are serial on its thread
        return original(self, n)

    monkeypatch.setattr(engine.Simulation, "advance", advance)
    split = simulate_many(scenarios)  # parts of 3 lanes, two threads
    assert len(names) == 2 and all(name.startswith("lanes") for name in names)
    for expected, actual in zip(together, split, strict=True):
        assert actual.scenario == expected.scenario
        assert_same(expected, actual)


@pytest.mark.skipif(not numba_available(), reason="numba not installed")
def test_a_failing_part_stops_the_parts_not_yet_started(monkeypatch: pytest.MonkeyPatch) -> None:
    """A part's error reaches the caller, and the parts queued behind it never start (a Ctrl-C
    does not wait for the whole batch)."""
    from twin.sim import engine

    monkeypatch.setattr(engine, "numba_threads", lambda: 2)
    monkeypatch.setattr(engine, "MAX_LANES", 1)
    started: list[int] = []
    original = engine.Simulation.advance

    def advance(self: engine.Simulation, n: int) -> int:
        started.append(self.scenario.seed)
        if self.scenario.seed == 0:
            raise FloatingPointError("injected")
        time.sleep(0.2)  # a part takes a while: the queue is still full when 0 fails
        return original(self, n)

    monkeypatch.setattr(engine.Simulation, "advance", advance)
    with pytest.raises(FloatingPointError, match="injected"):
        simulate_many([{"seed": s, "duration": 1.0} for s in range(12)])
    assert 0 in started and len(set(started)) < 6


@pytest.mark.parametrize(
    ("size", "sizes"),
    [(3, [3]), (16, [16]), (17, [9, 8]), (33, [11, 11, 11]), (256, [16] * 16), (40, [14, 13, 13])],
)
def test_lane_parts(size: int, sizes: list[int]) -> None:
    """Near-equal parts of at most MAX_LANES (16) lanes, every lane once, in order."""
    from twin.sim.engine import MAX_LANES, lane_parts

    assert MAX_LANES == 16
    parts = lane_parts(list(range(size)))
    assert [len(p) for p in parts] == sizes
    assert [i for p in parts for i in p] == list(range(size))


@pytest.mark.parametrize(
    ("size", "threads", "sizes"),
    [
        (256, 2, [16] * 15 + [8, 4, 2, 2]),
        (40, 2, [16, 12, 6, 3, 2, 1]),
        (3, 2, [2, 1]),
        (100, 4, [16, 16, 16, 13, 10, 8, 6, 4, 3, 2, 2, 2, 2]),
    ],
)
def test_guided_lane_parts(size: int, threads: int, sizes: list[int]) -> None:
    """On several threads the parts shrink towards the end (guided self-scheduling): each
    takes the remaining lanes over the threads, within [MIN_LANES, MAX_LANES]; every lane
    once, in order."""
    from twin.sim.engine import lane_parts

    parts = lane_parts(list(range(size)), threads)
    assert [len(p) for p in parts] == sizes
    assert [i for p in parts for i in p] == list(range(size))


@pytest.mark.skipif(not numba_available(), reason="numba not installed")
def test_one_thread_picks_the_serial_runners() -> None:
    """Under `limit_threads(1)` a many-lane runner is the serial one, and the count returns."""
    from twin.compiled import limit_threads, numba_threads, pick_runner

    def factory(parallel: bool) -> str:
        return "parallel" if parallel else "serial"

    before = numba_threads()
    with limit_threads(1):
        assert pick_runner(factory, print, True, 64) == "serial"
    assert numba_threads() == before
    assert pick_runner(factory, print, True, 64) == ("parallel" if before > 1 else "serial")
    assert pick_runner(factory, print, False, 64) is print


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"engine": "fortran"}, "engine"), ({}, "beta")],
)
def test_bad_requests_name_the_field(kwargs: dict, message: str) -> None:
    """A bad simulate_many request raises ValueError naming the field at fault."""
    with pytest.raises(ValueError, match=message):
        simulate_many([{"beta": 2.0}] if not kwargs else [{}], **kwargs)


H = HybridBoardingSystem()
#: the platform yaw, q1 and q2 60 % of the way from the working state to their upper limits
#: (tests/sim/test_engine_steps.py's start): in sea state 7 a run meets a limit within 2 s
NEAR_LIMITS = (
    H.working_state + 0.6 * np.r_[np.zeros(5), 1, 1, 1, 0] * (H.upper - H.working_state)
).tolist()
#: every hybrid planner and both platform laws, ≤ 2 s each (the interpreted engine is slow);
#: those started near the limits pass them (`record`), stop on them (`hold`: the step's
#: bisection) or keep them (qp: its active set), so the metrics they count are not all zero
NO_NUMBA = [
    {"planner": "mtmp", "sea_state": 5, "duration": 1.0, "joint_limits": "hold"},
    {"planner": "dwa", "sea_state": 5, "duration": 1.0},
    {"mechanism": "upr4", "duration": 1.0},
    {"mechanism": "upu3up", "planner": "ik", "duration": 1.0},
    {"planner": "pi", "sea_state": 7, "duration": 2.0, "initial_state": NEAR_LIMITS,
     "joint_limits": "hold"},
    {"planner": "wpi", "sea_state": 7, "duration": 2.0, "initial_state": NEAR_LIMITS},
    {"planner": "conv1", "sea_state": 6, "seed": 2, "duration": 2.0},
    {"planner": "conv2", "sea_state": 5, "seed": 1, "duration": 2.0, "joint_limits": "hold"},
    {"planner": "qp", "sea_state": 7, "duration": 2.0, "initial_state": NEAR_LIMITS},
]  # fmt: skip


def assert_same_metrics(actual: object, expected: object, where: str = "metrics") -> None:
    """Metrics as JSON gives them back: the same keys, lengths and types throughout; floats to
    1e-9 (relative, or absolute near zero), everything else (counts, flags, names) exactly."""
    assert type(actual) is type(expected), f"{where}: {actual!r}, expected {expected!r}"
    if isinstance(expected, dict):
        assert actual.keys() == expected.keys(), where
        for key, value in expected.items():
            assert_same_metrics(actual[key], value, f"{where}/{key}")
    elif isinstance(expected, list):
        assert len(actual) == len(expected), where
        for j, (got, want) in enumerate(zip(actual, expected, strict=True)):
            assert_same_metrics(got, want, f"{where}/{j}")
    elif isinstance(expected, float):
        np.testing.assert_allclose(actual, expected, rtol=1e-9, atol=1e-9, err_msg=where)
    else:
        assert actual == expected, where


def test_where_numba_cannot_import_the_engine_gives_the_same_numbers(tmp_path) -> None:
    """A Python in which `import numba` fails runs the same kernels interpreted: every run
    records the compiled engine's series, each to 1e-9, and its metrics (`assert_same_metrics`,
    both through JSON, as they are served); the runs pass, stop on or keep their limits."""
    out, metrics = tmp_path / "runs.npz", tmp_path / "metrics.json"
    code = (
        "import sys, json, numpy as np; sys.modules['numba'] = None\n"
        "from twin.sim import simulate\n"
        "from twin.sim.lanes import numba_available\n"
        "assert not numba_available()\n"
        f"runs = [simulate(s) for s in json.loads({json.dumps(json.dumps(NO_NUMBA))})]\n"
        "np.savez(sys.argv[1], **{f'{i}/{k}': v for i, r in enumerate(runs)"
        " for k, v in r.series.items()})\n"
        "open(sys.argv[2], 'w').write(json.dumps([r.metrics for r in runs]))\n"
    )
    subprocess.run([sys.executable, "-c", code, str(out), str(metrics)], check=True, timeout=300)
    interpreted = np.load(out)
    interpreted_metrics = json.loads(metrics.read_text())
    engine = "numba" if numba_available() else "python"
    compiled = [simulate(scenario, engine=engine) for scenario in NO_NUMBA]
    for i, run in enumerate(compiled):
        assert sorted(k for k in interpreted.files if k.startswith(f"{i}/")) == sorted(
            f"{i}/{key}" for key in run.series
        )
        for key, value in run.series.items():
            np.testing.assert_allclose(
                interpreted[f"{i}/{key}"], value, rtol=1e-9, atol=1e-9, err_msg=f"{i}/{key}"
            )
        expected = json.loads(json.dumps(run.metrics))
        assert_same_metrics(interpreted_metrics[i], expected, f"{i}/metrics")
    hybrid = [run for run in compiled if run.scenario.mechanism == "hybrid"]
    assert any(run.metrics["violations"] for run in hybrid)
    assert any(run.metrics["fault_counts"]["joint_limit"] for run in hybrid)
    assert any(run.series["qp_active"].max() > 0 for run in hybrid if "qp_active" in run.series)

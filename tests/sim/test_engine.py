"""Simulation engine: stepping equals simulate, series shapes, bad scenarios, export."""

from __future__ import annotations

import csv
import json
import typing

import numpy as np
import pyarrow.parquet as pq
import pytest

from twin.sim import MAX_DURATION, Scenario, Simulation, simulate
from twin.sim.engine import LIVE_BLOCK

SHORT = {"mechanism": "hybrid", "planner": "mtmp", "sea_state": 3, "duration": 5.0}


def test_step_equals_simulate() -> None:
    """The live server's stepping gives the same numbers as a batch run, across the live
    session's base-motion block (`LIVE_BLOCK` steps sampled at a time, where a batch run
    samples all 300 at once)."""
    scenario = {**SHORT, "duration": 15.0}  # 300 steps
    batch = simulate(scenario)
    live = Simulation(scenario, history_limit=400)  # sampled as a live session samples
    assert live.n_steps > LIVE_BLOCK
    records = [live.step() for _ in range(live.n_steps)]
    assert live.done
    for key in ("xi", "legs", "tip_error", "base_pose"):
        np.testing.assert_array_equal(np.stack([r[key] for r in records]), batch.series[key][1:])
    # every key, sample 0 too: the batch run recorded its start with its one chunk, whose
    # arrays became its history; the stepped one appended sample by sample to a ring
    stepped = live.series()
    assert list(stepped) == list(batch.series)  # the same keys in the same order (CSV columns)
    for key, values in batch.series.items():
        np.testing.assert_array_equal(stepped[key], values, err_msg=key)
    assert live.result().metrics == batch.metrics


def test_metrics_later_count_the_faults_of_the_series_taken_with_them(
    nan_target: typing.Callable[..., None],
) -> None:
    """`metrics_later` (what `LiveSession.snapshot` takes under its lock) gives the metrics of
    the series taken with it, fault counts included, however far the run steps before it is
    called; `metrics` of the same series now would count the later faults too."""
    nan_target(*range(30, 40))  # a planner fault on steps 30-39
    sim = Simulation({**SHORT, "duration": 5.0}, history_limit=200)
    sim.advance(20)
    series, later = sim.series(), sim.metrics_later()
    sim.advance(40)  # through the faults
    assert sim.faults[0].counts["planner"] == 10
    metrics = later(series)
    assert metrics["fault_counts"]["planner"] == 0 and metrics["faults"] == 0
    assert sim.metrics(series)["fault_counts"]["planner"] == 10
    assert later(sim.series())["fault_counts"]["planner"] == 0  # the counts were copied


def test_series_has_the_contract_keys_and_shapes() -> None:
    """A 5 s run's series has one sample per step plus one, the contract's shapes, and only finite
    values."""
    result = simulate(SHORT)
    n = 5.0 / 0.05 + 1
    series = result.series
    assert series["t"].shape == (n,) and series["t"][-1] == pytest.approx(5.0)
    assert series["base_pose"].shape == (n, 6)
    assert series["xi"].shape == (n, 9)
    assert series["legs"].shape == (n, 6)
    for value in series.values():
        assert np.all(np.isfinite(value))


def test_metrics_are_finite_and_json_ready() -> None:
    """A run's metrics serialise to strict JSON (no NaN or inf) and round-trip their violation
    count."""
    metrics = simulate(SHORT).metrics
    text = json.dumps(metrics, allow_nan=False)  # raises on NaN or inf
    assert "violations" in metrics and "table7" in metrics
    assert json.loads(text)["violations"] == metrics["violations"]


def test_calm_sea_holds_still() -> None:
    """Hs = 0: the base does not move, so nothing moves and no limit is touched."""
    result = simulate({**SHORT, "hs": 0.0, "tp": 8.0})
    xi = result.series["xi"]
    np.testing.assert_allclose(xi, np.broadcast_to(xi[0], xi.shape), atol=1e-12)
    assert result.metrics["violations"] == 0


def test_base_pose_is_the_mount_on_the_vessel() -> None:
    """In calm water the base sits at the mount's lever arm with yaw −90° (seed 000 §3.1)."""
    pose = simulate({**SHORT, "hs": 0.0, "tp": 8.0}).series["base_pose"][0]
    np.testing.assert_allclose(pose, [0.0, -5.5, 10.0, 0.0, 0.0, -np.pi / 2], atol=1e-12)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("beta", 1.5, "beta"),
        ("k_e", -1.0, "k_e"),
        ("dt", 0.0, "dt"),
        ("duration", MAX_DURATION + 1, "duration"),
        ("planner", "magic", "planner"),
        ("planner", "", "unknown name ''"),
        ("planner", "pid", "does not plan for mechanism 'hybrid'"),
        ("mechanism", "crane", "mechanism"),
        ("sea_state", float("nan"), "sea_state"),
        ("hs", -1.0, "hs"),
        ("initial_state", [0.0] * 5, "initial_state"),
        ("vessel", "titanic", "vessel"),
    ],
)
def test_bad_scenarios_name_the_field(field: str, value, message: str) -> None:
    """Out-of-range, NaN, unknown names: a ValueError that names the field."""
    with pytest.raises(ValueError, match=message):
        Scenario(**{field: value})


def test_too_many_steps_is_refused() -> None:
    """A scenario whose duration and dt need too many steps raises ValueError naming the steps."""
    with pytest.raises(ValueError, match="steps"):
        Scenario(duration=MAX_DURATION, dt=0.005)


def test_exports_round_trip(tmp_path) -> None:
    """CSV, Parquet and JSON carry the same numbers as the series."""
    result = simulate(SHORT)
    with result.to_csv(tmp_path / "run.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(result.series["t"])
    assert float(rows[-1]["legs_5"]) == pytest.approx(result.series["legs"][-1, 5], rel=1e-15)
    table = pq.read_table(result.to_parquet(tmp_path / "run.parquet"))
    np.testing.assert_array_equal(table.column("xi_8").to_numpy(), result.series["xi"][:, 8])
    assert json.loads(table.schema.metadata[b"scenario"])["planner"] == "mtmp"
    data = json.loads(result.to_json(tmp_path / "run.json").read_text())
    np.testing.assert_array_equal(np.array(data["series"]["xi"]), result.series["xi"])
    assert data["metrics"] == json.loads(json.dumps(result.metrics))


@pytest.mark.parametrize(
    "spectrum", [*typing.get_args(Scenario.model_fields["spectrum"].annotation), "pm"]
)
def test_every_allowed_spectrum_runs(spectrum: str) -> None:
    """Each name the scenario accepts (and the `pm` alias) simulates a moving, finite sea."""
    result = simulate({"spectrum": spectrum, "sea_state": 4, "duration": 1.0})
    base = result.series["base_pose"]
    assert np.all(np.isfinite(base)) and np.ptp(base[:, 2]) > 1e-3


@pytest.mark.parametrize(
    "fields",
    [
        # Algorithm 1 on the body yaw rate, half way to the Euler yaw and on it (the default);
        # q1 starts at 24.9°, by the σ band (25°-30°), and the sea carries it in and out
        # (γ 3.3, 200 components: a sea known to do so)
        dict(mechanism="hybrid", planner="mtmp", sea_state=7, yaw_hold=0.0, gamma=3.3,
             n_components=200, initial_state=[0, 0, 2.475, 0, 0, 0, 0.435, 0, 13.052]),
        dict(mechanism="hybrid", planner="mtmp", sea_state=7, yaw_hold=0.5, gamma=3.3,
             n_components=200, initial_state=[0, 0, 2.475, 0, 0, 0, 0.435, 0, 13.052]),
        dict(mechanism="hybrid", planner="mtmp", sea_state=7, yaw_hold=1.0, gamma=3.3,
             n_components=200, initial_state=[0, 0, 2.475, 0, 0, 0, 0.435, 0, 13.052]),
        # effort-driven actuators with mass (PlatformPlanner.actuate), the speed limit binding
        # (γ 3.3 and 200 components, the former defaults: seas known to make it bind)
        dict(mechanism="upr4", planner="pid", sea_state=9, actuator_mass=10.0, gamma=3.3,
             n_components=200),
        dict(mechanism="upr4", planner="pid", regular_waves="state3", actuator_mass=50.0,
             dt=0.005, actuator_speed=0.01),
        dict(mechanism="upu3up", planner="pid", sea_state=6, actuator_mass=20.0, gamma=3.3,
             n_components=200),
        # near full stroke: the masses run into the end stops
        dict(mechanism="upr4", planner="pid", sea_state=9, actuator_mass=5.0, gamma=3.3,
             n_components=200, initial_state=[0.84, 0.0, 0.0]),
    ],
    ids=["yaw-body", "yaw-half", "yaw-euler", "upr4-mass", "upr4-mass-slow", "upu3up-mass",
         "upr4-stroke"],
)  # fmt: skip
def test_engine_keeps_algorithm_1_and_the_actuators(fields: dict) -> None:
    """The kernels' yaw_hold of Algorithm 1 and effort-driven actuators, judged from the run:
    where q1 is in Algorithm 1's flexible range and q̇1 not clipped, the platform's body yaw
    rate is ω_pz = −yaw_hold·tan φ·ω_py (seed 000 Algorithm 1, `SlewPriority`), read from the
    states (`tests.sim.oracle.step_twist`); a small platform's lengths stay in the stroke and
    its state is their fit (`assert_platform_steps`), the speed limit binds, the end stops
    hold; the fault counts are the series'."""
    from tests.sim.oracle import assert_platform_steps, step_twist

    sim = Simulation({"duration": 3.0, "seed": 1, **fields})
    sim.run()
    series = sim.series()
    if sim.lanes.kind == "platform":
        assert_platform_steps(sim.lanes.models[0], series["state"], series["legs"])
        assert series["saturated"].sum() > 0  # the speed limit bound
        if fields.get("initial_state"):
            assert series["legs"].max() == sim.lanes.model.stroke[1][0]  # an end stop
    else:
        xs, scales = series["xi"], series["limit_scale"][1:] * series["velocity_scale"][1:]
        q1 = np.degrees(xs[:, 6])
        p, h = sim.scenario.parameters(), fields["yaw_hold"]
        if h < 1:  # both of Algorithm 1's branches ran (the default's sea keeps q1 < 25°)
            assert q1.min() < 25.0 < q1.max()
        band = (sim.mechanism.lower[6] + np.deg2rad(p.sigma),
                sim.mechanism.upper[6] - np.deg2rad(p.sigma))  # fmt: skip
        checked = 0
        for k in np.flatnonzero(scales > 0):
            u = step_twist(xs[k], xs[k + 1], sim.scenario.dt)
            free = abs(u[6]) / scales[k] < np.deg2rad(p.q1_rate_max) * (1 - 1e-6)
            if band[0] <= xs[k, 6] <= band[1] and free:
                assert u[5] == pytest.approx(-h * np.tan(xs[k, 3]) * u[4], abs=1e-12)
                checked += 1
        assert checked > 30
    assert sim.faults[0].counts["planner"] == sim.faults[0].counts["kinematics"] == 0


def test_warm_refuses_unknown_shares_and_process_counts(capsys: pytest.CaptureFixture) -> None:
    """`warm` names the shares it knows, `warm_in_processes` and `twin warm` the process counts
    they take, before compiling anything."""
    from twin.cli import main
    from twin.sim.engine import WARM_SHARES, warm, warm_in_processes

    last = len(WARM_SHARES) - 1
    with pytest.raises(ValueError, match=rf"shares \[{last + 1}\] unknown; they are 0-{last}"):
        warm(shares=[0, last + 1])
    for processes in (0, last + 2):
        with pytest.raises(ValueError, match=rf"{processes} processes; 1-{last + 1}"):
            warm_in_processes(processes)
    with pytest.raises(SystemExit) as exited:
        main(["warm", "--processes", "0"])
    assert exited.value.code == 2
    assert f"1-{last + 1} (one per share)" in capsys.readouterr().err


@pytest.mark.parametrize("spawn", [False, True])
def test_warm_in_processes_reports_every_lane_set_once(
    spawn: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Progress names each lane set of `WARM_SHARES` once, whether the other shares went to a
    process of their own (share 0 still compiling after `SPAWN_AFTER` s: here at once) or were
    loaded here (share 0 done in time: no process started)."""
    import multiprocessing

    from twin.sim import engine

    labels = [engine.warm_label(lanes) for share in engine.WARM_SHARES for lanes in share]
    if spawn:
        monkeypatch.setattr(engine, "SPAWN_AFTER", 0.0)
    else:
        monkeypatch.setattr(engine, "SPAWN_AFTER", 1e6)

        def no_process(*_: object) -> None:
            raise AssertionError("a process was started")

        monkeypatch.setattr(multiprocessing.context.SpawnContext, "Pool", no_process)
    seen: list[str] = []
    engine.warm_in_processes(2, progress=seen.append)
    assert sorted(seen) == sorted(labels) and len(labels) == engine.WARM_TOTAL
    assert "upr4 pid + upr4 ik" in labels  # a mechanism's default planner is named

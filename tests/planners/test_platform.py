"""Small-platform planners: level target, servo laws, speed limit, registry (platform.py)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import TwinError
from twin.mechanisms import Upr4, Upu3Up
from twin.planners import (
    PLANNERS,
    PlannerParameters,
    PlatformModel,
    PlatformPlanner,
    TipTarget,
    advance_target,
    get_planner,
)
from twin.spatial import invert_transform, pose_to_transform, rpy_to_matrix, so3_exp

MODELS = {"upu3up": PlatformModel(Upu3Up()), "upr4": PlatformModel(Upr4())}


def base_transform(rng: np.random.Generator, tilt_deg: float = 12.0) -> np.ndarray:
    """ᴵT_B with random heave, roll, pitch (±tilt_deg) and yaw (±30°)."""
    angles = np.radians(rng.uniform(-1, 1, 3) * [tilt_deg, tilt_deg, 30.0])
    return pose_to_transform(np.r_[rng.uniform(-1, 1, 3) * [2.0, 2.0, 0.1], angles])


def held_pose(model: PlatformModel, T_IB: np.ndarray) -> np.ndarray:
    """A level inertial pose over the platform's working-state top centre."""
    top = T_IB @ model.transform(model.mechanism.working_state)
    return pose_to_transform(np.r_[top[:3, 3], 0.0, 0.0, 0.3])


def target_at(model: PlatformModel, state: np.ndarray) -> TipTarget:
    """The state's own top pose, at rest."""
    return TipTarget(model.transform(state), np.zeros(6))


@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("seed", range(5))
def test_desired_state_makes_the_top_level(name: str, seed: int) -> None:
    """The desired state's top normal is inertial z up for any base tilt within ±12°."""
    model = MODELS[name]
    T_IB = base_transform(np.random.default_rng(seed))
    state = model.desired_state(invert_transform(T_IB) @ held_pose(model, T_IB))
    normal = T_IB[:3, :3] @ model.transform(state)[:3, 2]  # via the mechanism's own pose
    np.testing.assert_allclose(normal, [0.0, 0.0, 1.0], atol=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_upu3up_desired_heave_holds_the_inertial_height(seed: int) -> None:
    """Upu3Up: O1's inertial height equals the held one (seed 001 eq (13), O1 = (l + z) n)."""
    model = MODELS["upu3up"]
    rng = np.random.default_rng(seed)
    T_IB = base_transform(rng)
    held = held_pose(model, T_IB)
    held[2, 3] += rng.uniform(-0.1, 0.1)  # within the ±150 mm heave range
    state = model.desired_state(invert_transform(T_IB) @ held)
    top = T_IB @ model.transform(state)
    assert top[2, 3] == pytest.approx(held[2, 3], abs=1e-12)


def test_upr4_desired_height_is_held() -> None:
    """Upr4: z stays at z_hold whatever the target position (seed 002 §4)."""
    model = PlatformModel(Upr4(), z_hold=0.55)
    T = pose_to_transform(np.array([0.3, -0.2, 0.9, 0.1, -0.05, 0.4]))
    assert model.desired_state(T)[0] == 0.55


@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("law", ["ik", "pid"])
def test_fulfilled_target_gives_zero_velocity(name: str, law: str) -> None:
    """Lengths already at a resting target's: every actuator rate is zero."""
    model = MODELS[name]
    state = model.mechanism.working_state + np.array([0.0, 0.03, -0.02])
    planner = PlatformPlanner(model, law, 0.1, kp=8.0, ki=1.0, kd=0.1)
    lengths, target = model.leg_lengths(state), target_at(model, state)
    planner.reset(lengths, target)
    out = planner.step(lengths, target, 0.05)
    np.testing.assert_allclose(out.velocity, 0.0, atol=1e-9)


@pytest.mark.parametrize("name", MODELS)
def test_ik_lands_on_the_next_target(name: str) -> None:
    """`ik`: one step of its rate reaches the lengths of the target advanced by its twist."""
    model = MODELS[name]
    state = model.mechanism.working_state
    twist = np.array([0.0, 0.0, 0.01, 0.05, -0.04, 0.0])  # [m/s, rad/s], slow: no saturation
    target = TipTarget(model.transform(state), twist)
    planner = PlatformPlanner(model, "ik", 0.1)
    lengths = model.leg_lengths(state)
    dt = 0.05
    out = planner.step(lengths, target, dt)
    ahead = np.array(target.transform)  # the target advanced by its twist, in numpy
    ahead[:3, :3] = so3_exp(twist[3:] * dt) @ ahead[:3, :3]
    ahead[:3, 3] += twist[:3] * dt
    expected = model.leg_lengths(model.desired_state(ahead))
    np.testing.assert_allclose(lengths + out.velocity * dt, expected, rtol=0, atol=1e-12)
    assert out.diagnostics["saturated"] == 0.0


def test_advance_target_rotates_in_the_base_frame() -> None:
    """R(t + dt) = exp(ω dt) R with ω in B: a z-turn of ω dt = 0.5 rad is Rz(0.5) applied on
    the left; the position moves by ṗ dt."""
    T = pose_to_transform(np.array([0.1, 0.0, 0.5, 0.2, -0.1, 0.3]))
    twist = np.array([0.2, 0.0, -0.4, 0.0, 0.0, 1.0])
    T1 = advance_target(TipTarget(T, twist), 0.5)
    np.testing.assert_allclose(T1[:3, :3], rpy_to_matrix(np.array([0.0, 0.0, 0.5])) @ T[:3, :3])
    np.testing.assert_allclose(T1[:3, 3], T[:3, 3] + [0.1, 0.0, -0.2])


def test_advance_target_is_the_rotation_exponential_batched(rng: np.random.Generator) -> None:
    """A batch (2, 3) of targets advances lane by lane: R(t + dt) = exp([ω dt]×) R by scipy's
    `expm`, p + ṗ dt, the last row (0, 0, 0, 1)."""
    from scipy.linalg import expm

    T = pose_to_transform(rng.uniform(-0.5, 0.5, (2, 3, 6)))
    twist = rng.normal(size=(2, 3, 6))
    T1 = advance_target(TipTarget(T, twist), 0.05)
    assert T1.shape == (2, 3, 4, 4)
    for k in np.ndindex(2, 3):
        w = twist[k][3:] * 0.05
        W = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        np.testing.assert_allclose(T1[k][:3, :3], expm(W) @ T[k][:3, :3], atol=1e-14)
        np.testing.assert_allclose(T1[k][:3, 3], T[k][:3, 3] + twist[k][:3] * 0.05, atol=1e-15)
        np.testing.assert_array_equal(T1[k][3], [0.0, 0.0, 0.0, 1.0])


def test_pid_follows_its_law() -> None:
    """`pid`: v = k e + ki ∫e dt + kd ė with the sampled gain k = (1 − e^(−kp·dt))/dt,
    recomputed by hand over three steps (Upr4)."""
    model = MODELS["upr4"]
    kp, ki, kd, dt = 8.0, 2.0, 0.05, 0.05
    gain = (1.0 - np.exp(-kp * dt)) / dt
    planner = PlatformPlanner(model, "pid", 0.1, kp=kp, ki=ki, kd=kd)
    lengths = model.leg_lengths(model.mechanism.working_state)
    states = [np.array([0.5, 0.01, 0.0]), np.array([0.5, 0.02, -0.01]), np.array([0.5, 0.0, 0.01])]
    planner.reset(lengths, target_at(model, states[0]))
    integral = np.zeros(4)
    previous = model.leg_lengths(states[0]) - lengths
    for state in states:
        error = model.leg_lengths(state) - lengths
        expected = gain * error + ki * integral + kd * (error - previous) / dt
        out = planner.step(lengths, target_at(model, state), dt)
        np.testing.assert_allclose(out.velocity, expected, rtol=1e-12, atol=1e-15)
        integral += error * dt
        previous = error


@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("law", ["ik", "pid"])
@pytest.mark.parametrize("seed", range(3))
def test_every_rate_within_actuator_speed(name: str, law: str, seed: int) -> None:
    """Far targets saturate the actuators, and no rate exceeds 0.1 m/s (seed 002 §5)."""
    model = MODELS[name]
    rng = np.random.default_rng(seed)
    state = model.mechanism.working_state
    heave = 0.1 / model.unit if name == "upu3up" else 0.0  # [native]; the Upr4 holds z
    far = state + rng.uniform(-1, 1, 3) * np.array([heave, 0.2, 0.2])
    planner = PlatformPlanner(model, law, 0.1, kp=200.0, ki=10.0, kd=1.0)
    out = planner.step(model.leg_lengths(state), target_at(model, far), 0.05)
    assert np.max(np.abs(out.velocity)) * model.unit <= 0.1 * (1 + 1e-12)
    assert out.diagnostics["saturated"] == 1.0


def test_saturation_keeps_the_tilt_before_the_heave() -> None:
    """Upu3Up: with the heave demand beyond the speed limit, the tilt rate is kept whole and
    the heave takes what is left (checked through ∂l/∂state, seed 001 eq (24))."""
    model = MODELS["upu3up"]
    state = np.array([0.0, 0.02, -0.01])
    goal = np.array([100.0, 0.021, -0.011])  # 100 mm heave, 0.06° tilt
    lengths = model.leg_lengths(state)
    planner = PlatformPlanner(model, "ik", 0.1)
    dt = 0.05
    out = planner.step(lengths, target_at(model, goal), dt)
    J = model.jacobian(state)
    rates = np.linalg.solve(J, out.velocity)  # [mm/s, rad/s, rad/s]
    wanted = np.linalg.solve(J, (model.leg_lengths(goal) - lengths) / dt)
    np.testing.assert_allclose(rates[1:], wanted[1:], rtol=1e-12)
    assert 0 < rates[0] < wanted[0]
    assert np.max(np.abs(out.velocity)) == pytest.approx(100.0)  # [mm/s]: one actuator at 0.1 m/s


def test_anti_windup_freezes_the_integral_while_saturated() -> None:
    """`pid`: the integral does not grow while the speed limit binds, and does after."""
    model = MODELS["upr4"]
    planner = PlatformPlanner(model, "pid", 0.1, kp=8.0, ki=5.0)
    lengths = model.leg_lengths(model.mechanism.working_state)
    far = target_at(model, np.array([0.5, 0.3, 0.0]))  # 17° roll: kp |e| ≈ 0.13 m/s
    planner.reset(lengths, far)
    for _ in range(5):
        assert planner.step(lengths, far, 0.05).diagnostics["saturated"] == 1.0
    np.testing.assert_array_equal(planner.integral, 0.0)
    near = np.array([0.5, 0.001, 0.0])
    planner.step(lengths, target_at(model, near), 0.05)
    np.testing.assert_allclose(planner.integral, (model.leg_lengths(near) - lengths) * 0.05)


@pytest.mark.parametrize("name", MODELS)
def test_pid_closed_loop_converges(name: str) -> None:
    """`pid` with seed 002's gains drives the platform onto a resting target, up to the
    integral's slow mode (time constant kp/ki = 10⁴ s) that leaves ~ki/kp² of the step."""
    model = MODELS[name]
    p = PlannerParameters()
    planner = PlatformPlanner(model, "pid", p.actuator_speed, p.kp, p.ki, p.kd)
    state = start = model.mechanism.working_state
    goal = state + np.array([0.0, 0.05, -0.04])
    target = target_at(model, goal)
    lengths = model.leg_lengths(state)
    planner.reset(lengths, target)
    for _ in range(100):  # 5 s at dt = 0.05, 40 time constants 1/kp
        lengths = lengths + planner.step(lengths, target, 0.05).velocity * 0.05
        state = model.fit(lengths, state)
    assert np.max(np.abs(state - goal)) <= 1e-4 * np.max(np.abs(goal - start))


def test_desired_state_is_clipped_and_counted() -> None:
    """Upu3Up: a heave beyond ±150 mm is clipped to the limit and flagged."""
    model = MODELS["upu3up"]
    planner = PlatformPlanner(model, "ik", 0.1)
    T = model.transform(np.array([400.0, 0.0, 0.0]))
    out = planner.step(
        model.leg_lengths(model.mechanism.working_state), TipTarget(T, np.zeros(6)), 0.05
    )
    assert out.diagnostics["desired_state"][0] == model.mechanism.heave_limit
    assert out.diagnostics["clipped"] == 1.0


def test_upr4_fit_is_least_squares() -> None:
    """Upr4 `fit`: consistent lengths give back their state (as `Upr4.forward`); disagreeing
    ones give the pose whose residual is orthogonal to ∂l/∂state (least squares)."""
    model = MODELS["upr4"]
    state = np.array([0.55, 0.1, -0.05])
    lengths = model.leg_lengths(state)
    guess = state + 0.01
    np.testing.assert_allclose(
        model.fit(lengths, guess), Upr4().forward(lengths, guess), atol=1e-12
    )
    skewed = lengths + np.array([1e-3, -1e-3, 1e-3, 1e-3])  # [m], fits no state exactly
    fitted = model.fit(skewed, state)
    residual = model.leg_lengths(fitted) - skewed
    gradient = model.jacobian(fitted).T @ residual  # ~1e-3 m residual, stationary to 1e-9
    np.testing.assert_allclose(gradient, 0.0, atol=1e-11)
    assert np.linalg.norm(residual) > 1e-4  # the lengths did disagree


def test_nan_target_gives_nan_velocity() -> None:
    """A non-finite target velocity is reported as a NaN velocity (the rig's fault signal)."""
    model = MODELS["upr4"]
    planner = PlatformPlanner(model, "pid", 0.1, kp=8.0)
    state = model.mechanism.working_state
    twist = np.array([0.0, 0.0, 0.0, np.nan, 0.0, 0.0])
    out = planner.step(model.leg_lengths(state), TipTarget(model.transform(state), twist), 0.05)
    assert np.all(np.isnan(out.velocity))


def test_bad_arguments_raise() -> None:
    """Unknown law, non-positive speed or dt, negative gain, wrong length count: TwinError."""
    model = MODELS["upr4"]
    with pytest.raises(TwinError, match="allowed"):
        PlatformPlanner(model, "mpc", 0.1)
    with pytest.raises(TwinError, match="actuator_speed"):
        PlatformPlanner(model, "ik", 0.0)
    with pytest.raises(TwinError, match="kd"):
        PlatformPlanner(model, "pid", 0.1, kd=-1.0)
    planner = PlatformPlanner(model, "ik", 0.1)
    state = model.mechanism.working_state
    with pytest.raises(TwinError, match="dt"):
        planner.step(model.leg_lengths(state), target_at(model, state), 0.0)
    with pytest.raises(TwinError, match="shape"):
        planner.step(np.ones(3), target_at(model, state), 0.05)
    with pytest.raises(TwinError, match="Upu3Up or Upr4"):
        PlatformModel(object())  # type: ignore[arg-type]


def test_registry_lists_small_platform_planners() -> None:
    """`pid` and `ik` plan for both small platforms and read the knobs they use."""
    for name in ("pid", "ik"):
        assert PLANNERS[name].mechanisms == ("upu3up", "upr4")
    assert set(PLANNERS["pid"].parameters) == {
        "kp", "ki", "kd", "actuator_speed", "actuator_mass"
    }  # fmt: skip
    planner = get_planner("pid", "upr4").build(Upr4(), PlannerParameters(), Upr4().working_state)
    assert (planner.law, planner.kp, planner.actuator_speed) == ("pid", 120.0, 0.1)
    assert not planner.dynamic  # velocity-commanded actuators by default
    heavy = PlannerParameters(actuator_mass=10.0)
    planner = get_planner("pid", "upr4").build(Upr4(), heavy, Upr4().working_state)
    assert planner.dynamic and planner.actuator_mass == 10.0


@pytest.mark.parametrize(
    ("planner", "mechanism"), [("mtmp", "upu3up"), ("pi", "upr4"), ("pid", "hybrid")]
)
def test_registry_refuses_a_planner_for_another_mechanism(planner: str, mechanism: str) -> None:
    """A hybrid planner on a small platform (or the reverse) raises, listing what is allowed."""
    with pytest.raises(TwinError, match="allowed"):
        get_planner(planner, mechanism)


@pytest.mark.parametrize("kp", [8.0, 120.0, 200.0])
@pytest.mark.parametrize("dt", [0.005, 0.05, 0.2])
def test_sampled_proportional_loop_is_the_continuous_one(kp: float, dt: float) -> None:
    """A pure P loop on a resting target leaves e^(−kp·dt) of the error each step, the
    continuous loop ė = −kp e exactly: no overshoot and no instability at any kp·dt (up to 40
    here; the raw gain kp would diverge beyond kp·dt = 2)."""
    model = MODELS["upr4"]
    planner = PlatformPlanner(model, "pid", 2.0, kp=kp)
    goal = np.array([0.5, 0.001, -0.001])
    target = target_at(model, goal)
    lengths = model.leg_lengths(model.mechanism.working_state)
    error = model.leg_lengths(goal) - lengths
    planner.reset(lengths, target)
    for k in range(1, 4):
        lengths = lengths + planner.step(lengths, target, dt).velocity * dt
        np.testing.assert_allclose(
            model.leg_lengths(goal) - lengths, error * np.exp(-kp * dt * k), rtol=1e-9, atol=1e-15
        )


def test_effort_driven_actuators_follow_newton() -> None:
    """`actuator_mass` > 0: one 1 ms step of `actuate` by hand, m (u⁺ − u)/h = K_p (e − h u⁺)
    + K_i ∫e − K_d u⁺ with seed 002's gains, x⁺ = x + h u⁺; the rate returned is where the
    mass went over the period."""
    model = MODELS["upr4"]
    m, dt = 10.0, 0.001
    planner = PlatformPlanner(model, "pid", 0.1, actuator_mass=m)
    lengths = model.leg_lengths(model.mechanism.working_state)
    goal = np.array([0.5, 0.002, 0.0])
    planner.reset(lengths, target_at(model, goal))
    e = model.leg_lengths(goal) - lengths
    integral = e * dt
    u = (5000.0 * e + 0.5 * integral) / (m / dt + 10.0 + dt * 5000.0)
    out = planner.step(lengths, target_at(model, goal), dt)
    np.testing.assert_allclose(out.velocity, u, rtol=1e-9)  # (x⁺ − x)/h: rounding of x⁺
    np.testing.assert_allclose(planner.actuator_velocity, u, rtol=1e-12)
    np.testing.assert_allclose(planner.integral, integral, rtol=1e-12)
    assert out.diagnostics["saturated"] == 0.0


@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("mass", [1e-300, 1.0, 10.0])
def test_effort_driven_actuators_settle_within_the_speed_limit(name: str, mass: float) -> None:
    """From rest towards a tilted target: the masses (any mass, the implicit step is stable)
    never exceed 0.1 m/s, a 4° step saturates them, and they settle on the target (the
    lightly damped spring, ζ = K_d / 2√(K_p m), rings down within 60 s)."""
    model = MODELS[name]
    planner = PlatformPlanner(model, "pid", 0.1, actuator_mass=mass)
    state = model.mechanism.working_state
    goal = state + np.array([0.0, 0.07, -0.05])
    target = target_at(model, goal)
    lengths = model.leg_lengths(state)
    planner.reset(lengths, target)
    saturated = 0.0
    for _ in range(1200):  # 60 s at dt = 0.05
        out = planner.step(lengths, target, 0.05)
        assert np.max(np.abs(out.velocity)) * model.unit <= 0.1 * (1 + 1e-9)
        saturated = max(saturated, out.diagnostics["saturated"])
        lengths = lengths + out.velocity * 0.05
    assert saturated == 1.0
    np.testing.assert_allclose(lengths, model.leg_lengths(goal), rtol=0, atol=1e-4 / model.unit)


def test_effort_driven_actuators_stop_at_the_stroke() -> None:
    """A desired length at the stroke's end: the mass stops there, its velocity zeroed."""
    model = MODELS["upr4"]
    planner = PlatformPlanner(model, "pid", 0.1, actuator_mass=1.0)
    high = model.stroke[1]
    lengths = high - 0.001  # [m] 1 mm short of the end stop
    planner.reset(lengths, target_at(model, model.mechanism.working_state))
    rates, _ = planner.actuate(high + 0.0, lengths, 0.2)
    np.testing.assert_allclose(lengths + rates * 0.2, high, rtol=0, atol=1e-15)
    assert np.all(lengths + rates * 0.2 <= high)
    assert np.all(planner.actuator_velocity == 0.0)

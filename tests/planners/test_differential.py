"""PI / WPI / MTMP as one composed solve: seed 000 eqs (26)-(40), each property on the
planner object and on the engine's lane step (`tests.planners.engine_step`)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import random_hybrid_states
from tests.planners.engine_step import PATHS, step
from twin.mechanisms import HybridBoardingSystem
from twin.planners import PLANNERS, PlannerParameters, TipTarget
from twin.spatial import pose_error

H = HybridBoardingSystem()


def build(name: str, xi0: np.ndarray, **params):
    return PLANNERS[name].build(H, PlannerParameters(**params), xi0)


def target_from(xi: np.ndarray, twist: np.ndarray, offset: np.ndarray | None = None) -> TipTarget:
    T = H.end_effector(xi).copy()
    if offset is not None:
        T[:3, 3] += offset
    return TipTarget(transform=T, twist=twist)


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("name", ["pi", "wpi", "mtmp"])
def test_tip_follows_the_commanded_twist(name: str, path: str, rng: np.random.Generator) -> None:
    """J_task ξ̇ = ẋ_d + k_e e: the primary task is met exactly away from singularities."""
    for xi in random_hybrid_states(rng, 10, shrink=0.3):
        twist = rng.normal(0, 0.05, 6)
        target = target_from(xi, twist, offset=rng.normal(0, 1e-3, 3))
        planner = build(name, xi)
        out = step(path, planner, xi, target)
        if out.diagnostics["velocity_scale"] < 1:
            continue
        demand = twist + 25.0 * pose_error(target.transform, H.end_effector(xi))
        np.testing.assert_allclose(H.task_jacobian(xi) @ out.velocity, demand, atol=1e-8)


@pytest.mark.parametrize("path", PATHS)
def test_fulfilled_task_gives_zero_velocity_for_pi(path: str) -> None:
    xi = H.working_state
    out = step(path, build("pi", xi), xi, target_from(xi, np.zeros(6)))
    np.testing.assert_allclose(out.velocity, 0.0, atol=1e-12)


@pytest.mark.parametrize("path", PATHS)
def test_pi_overlap_compensation_table3(path: str) -> None:
    """Table 3 / conclusion (a): PI moves ω_pz and q̇1 by the same amount (overlap)."""
    xi = H.working_state
    out = step(path, build("pi", xi), xi, target_from(xi, np.r_[0, 0.1, 0, 0, 0, 0.02]))
    assert out.velocity[5] == pytest.approx(out.velocity[6])
    assert abs(out.velocity[6]) > 1e-4


@pytest.mark.parametrize("path", PATHS)
def test_wpi_same_sign_different_values_table4(path: str) -> None:
    """Table 4: with β = 0.7 they keep the same sign but differ in size."""
    xi = H.working_state
    out = step(path, build("wpi", xi), xi, target_from(xi, np.r_[0, 0.1, 0, 0, 0, 0.02]))
    assert np.sign(out.velocity[5]) == np.sign(out.velocity[6])
    assert out.velocity[5] == pytest.approx(out.velocity[6] * 0.7 / 0.3)


@pytest.mark.parametrize("path", PATHS)
def test_reverse_compensation_pitch_and_luff_table3(path: str) -> None:
    """Conclusion (b): PI turns the platform pitch (w_py) and the luff (q̇2) the same way,
    although they move the tip in opposite directions (J columns 4 and 7 oppose in z)."""
    xi = H.working_state
    J = H.task_jacobian(xi)
    assert np.sign(J[2, 4]) == -np.sign(J[2, 7])
    out = step(path, build("pi", xi), xi, target_from(xi, np.r_[0, 0, -0.1, 0.01, 0.03, 0]))
    assert np.sign(out.velocity[4]) == np.sign(out.velocity[7])


@pytest.mark.parametrize("path", PATHS)
def test_mtmp_gives_yaw_to_the_slew_algorithm1(path: str) -> None:
    """Algorithm 1 in the flexible range: ω_pz = 0 and q̇1 takes the whole yaw rate."""
    xi = H.working_state
    out = step(path, build("mtmp", xi), xi, target_from(xi, np.r_[0, 0.05, 0, 0, 0, 0.02]))
    assert out.velocity[5] == pytest.approx(0.0, abs=1e-12)
    assert abs(out.velocity[6]) > 1e-3


@pytest.mark.parametrize("path", PATHS)
def test_secondary_task_lives_in_the_null_space(path: str, rng: np.random.Generator) -> None:
    """The q2 posture task changes joints but not the tip: J_task · (null motion) ≈ 0."""
    for xi0 in random_hybrid_states(rng, 10, shrink=0.3):
        xi = xi0.copy()
        xi[7] += 0.1  # away from the posture set-point q̃2 = xi0[7], so the task pulls
        target = target_from(xi, np.zeros(6))
        with_task = step(path, build("mtmp", xi0, k_a2=5.0), xi, target)
        without = step(path, build("mtmp", xi0, k_a2=0.0), xi, target)
        if min(with_task.diagnostics["velocity_scale"], without.diagnostics["velocity_scale"]) < 1:
            continue
        null_motion = with_task.velocity - without.velocity
        assert np.linalg.norm(null_motion) > 1e-4
        np.testing.assert_allclose(H.task_jacobian(xi) @ null_motion, 0.0, atol=1e-9)


@pytest.mark.parametrize("path", PATHS)
def test_rate_limit_binds_and_keeps_direction(path: str) -> None:
    xi = H.working_state
    fast = np.r_[5.0, 0, 0, 0, 0, 0]  # 5 m/s of tip motion: beyond every joint's rate
    out = step(path, build("pi", xi), xi, target_from(xi, fast))
    assert out.diagnostics["velocity_scale"] < 1
    free = step(path, build("pi", xi), xi, target_from(xi, fast * 1e-3))
    np.testing.assert_allclose(
        out.velocity / np.linalg.norm(out.velocity),
        free.velocity / np.linalg.norm(free.velocity),
        atol=1e-9,
    )

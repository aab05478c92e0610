"""PI / WPI / MTMP as one composed solve: seed 000 eqs (26)-(40). The planner object's `step`
runs the engine's lane step (`twin.planners.differential_step`), so each property here holds
the engine to an independent statement: the task Jacobian and pose error of
`HybridBoardingSystem` (numpy), the papers' tables, and the weighted minimum-norm solution
typed below in numpy's normal equations."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import random_hybrid_states
from twin.mechanisms import HybridBoardingSystem
from twin.planners import (
    PLANNERS,
    BetaSplit,
    DifferentialPlanner,
    JointLimitWeights,
    JointPostureTask,
    PlannerParameters,
    ProductWeights,
    TipPoseTask,
    TipTarget,
)
from twin.spatial import pose_error

H = HybridBoardingSystem()
DT = 0.05  # [s]; the velocity-level planners do not read it


def build(name: str, xi0: np.ndarray, **params):
    return PLANNERS[name].build(H, PlannerParameters(**params), xi0)


def target_from(xi: np.ndarray, twist: np.ndarray, offset: np.ndarray | None = None) -> TipTarget:
    T = H.end_effector(xi).copy()
    if offset is not None:
        T[:3, 3] += offset
    return TipTarget(transform=T, twist=twist)


@pytest.mark.parametrize("name", ["pi", "wpi", "mtmp"])
def test_tip_follows_the_commanded_twist(name: str, rng: np.random.Generator) -> None:
    """J_task ξ̇ = ẋ_d + k e with k_e sampled over the step, k = (1 − e^(−k_e dt))/dt: the
    primary task is met exactly away from singularities."""
    for xi in random_hybrid_states(rng, 10, shrink=0.3):
        twist = rng.normal(0, 0.05, 6)
        target = target_from(xi, twist, offset=rng.normal(0, 1e-3, 3))
        planner = build(name, xi)
        out = planner.step(xi, target, DT)
        if out.diagnostics["velocity_scale"] < 1:
            continue
        gain = -np.expm1(-25.0 * DT) / DT
        demand = twist + gain * pose_error(target.transform, H.end_effector(xi))
        np.testing.assert_allclose(H.task_jacobian(xi) @ out.velocity, demand, atol=1e-8)


def test_fulfilled_task_gives_zero_velocity_for_pi() -> None:
    """With the tip already on a still target, pi commands zero joint velocity."""
    xi = H.working_state
    out = build("pi", xi).step(xi, target_from(xi, np.zeros(6)), DT)
    np.testing.assert_allclose(out.velocity, 0.0, atol=1e-12)


def test_pi_overlap_compensation_table3() -> None:
    """Table 3 / conclusion (a): PI moves ω_pz and q̇1 by the same amount (overlap)."""
    xi = H.working_state
    out = build("pi", xi).step(xi, target_from(xi, np.r_[0, 0.1, 0, 0, 0, 0.02]), DT)
    assert out.velocity[5] == pytest.approx(out.velocity[6])
    assert abs(out.velocity[6]) > 1e-4


def test_wpi_same_sign_different_values_table4() -> None:
    """Table 4: with β = 0.7 they keep the same sign but differ in size."""
    xi = H.working_state
    out = build("wpi", xi).step(xi, target_from(xi, np.r_[0, 0.1, 0, 0, 0, 0.02]), DT)
    assert np.sign(out.velocity[5]) == np.sign(out.velocity[6])
    assert out.velocity[5] == pytest.approx(out.velocity[6] * 0.7 / 0.3)


def test_reverse_compensation_pitch_and_luff_table3() -> None:
    """Conclusion (b): PI turns the platform pitch (w_py) and the luff (q̇2) the same way,
    although they move the tip in opposite directions (J columns 4 and 7 oppose in z)."""
    xi = H.working_state
    J = H.task_jacobian(xi)
    assert np.sign(J[2, 4]) == -np.sign(J[2, 7])
    out = build("pi", xi).step(xi, target_from(xi, np.r_[0, 0, -0.1, 0.01, 0.03, 0]), DT)
    assert np.sign(out.velocity[4]) == np.sign(out.velocity[7])


def test_mtmp_gives_yaw_to_the_slew_algorithm1() -> None:
    """Algorithm 1 in the flexible range: ω_pz = 0 and q̇1 takes the whole yaw rate."""
    xi = H.working_state
    out = build("mtmp", xi).step(xi, target_from(xi, np.r_[0, 0.05, 0, 0, 0, 0.02]), DT)
    assert out.velocity[5] == pytest.approx(0.0, abs=1e-12)
    assert abs(out.velocity[6]) > 1e-3


def test_secondary_task_lives_in_the_null_space(rng: np.random.Generator) -> None:
    """The q2 posture task changes joints but not the tip: J_task · (null motion) ≈ 0."""
    for xi0 in random_hybrid_states(rng, 10, shrink=0.3):
        xi = xi0.copy()
        xi[7] += 0.1  # away from the posture set-point q̃2 = xi0[7], so the task pulls
        target = target_from(xi, np.zeros(6))
        with_task = build("mtmp", xi0, k_a2=5.0).step(xi, target, DT)
        without = build("mtmp", xi0, k_a2=0.0).step(xi, target, DT)
        if min(with_task.diagnostics["velocity_scale"], without.diagnostics["velocity_scale"]) < 1:
            continue
        null_motion = with_task.velocity - without.velocity
        assert np.linalg.norm(null_motion) > 1e-4
        np.testing.assert_allclose(H.task_jacobian(xi) @ null_motion, 0.0, atol=1e-9)


def test_rate_limit_binds_and_keeps_direction() -> None:
    """A demand beyond the rate limits is scaled down (scale < 1) without changing the velocity's
    direction."""
    xi = H.working_state
    fast = np.r_[5.0, 0, 0, 0, 0, 0]  # 5 m/s of tip motion: beyond every joint's rate
    out = build("pi", xi).step(xi, target_from(xi, fast), DT)
    assert out.diagnostics["velocity_scale"] < 1
    free = build("pi", xi).step(xi, target_from(xi, fast * 1e-3), DT)
    np.testing.assert_allclose(
        out.velocity / np.linalg.norm(out.velocity),
        free.velocity / np.linalg.norm(free.velocity),
        atol=1e-9,
    )


@pytest.mark.parametrize("posture", [False, True])
def test_velocity_is_the_weighted_minimum_norm_solution(
    posture: bool, rng: np.random.Generator
) -> None:
    """Away from singularities (λ = 0) and limits, eq (34) typed in numpy's normal equations:
    ξ̇ = W Jᵀ (J W Jᵀ)⁻¹ b + λ_s (I − W Jᵀ (J W Jᵀ)⁻¹ J) e_7 k_a (q̃2 − q2), W = diag(W⁻¹) the
    planner's weights (β split × joint-limit weights), b = ẋ_d + k e with k_e = 20 1/s sampled
    over the step (k = (1 − e^(−k_e dt))/dt), J and e numpy's."""
    for xi in random_hybrid_states(rng, 8, shrink=0.4):
        split = BetaSplit(rng.uniform(0.2, 0.9), rng.uniform(0.5, 2.0))
        weights = ProductWeights(
            (split, JointLimitWeights(H.lower, H.upper, np.r_[np.ones(8), 9.0]))
        )
        q2_set, k_a, lam = xi[7] - 0.1, 2.0, 0.8
        secondary = (JointPostureTask(index=7, setpoint=q2_set, gain=k_a),) if posture else ()
        planner = DifferentialPlanner(
            TipPoseTask(H, gain=20.0), weights, secondary=secondary, secondary_weight=lam
        )
        target = target_from(xi, rng.normal(0, 0.05, 6), offset=rng.normal(0, 1e-3, 3))
        out = planner.step(xi, target, DT)
        assert out.diagnostics["damping"] == 0.0 and out.diagnostics["velocity_scale"] == 1.0
        J, W = H.task_jacobian(xi), np.diag(weights(xi))
        b = target.twist - np.expm1(-20.0 * DT) / DT * pose_error(target.transform,
                                                                   H.end_effector(xi))
        pinv = W @ J.T @ np.linalg.inv(J @ W @ J.T)
        expected = pinv @ b
        if posture:
            wanted = np.zeros(9)
            wanted[7] = k_a * (q2_set - xi[7])
            expected += lam * (np.eye(9) - pinv @ J) @ wanted
            null = np.linalg.norm(lam * (np.eye(9) - pinv @ J) @ wanted)
            share = null / np.linalg.norm(expected)
            assert out.diagnostics["null_space_share"] == pytest.approx(share, rel=1e-9)
        np.testing.assert_allclose(out.velocity, expected, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(out.diagnostics["weights"], np.diag(W), rtol=0, atol=0)
        np.testing.assert_allclose(
            out.diagnostics["task_error"],
            pose_error(target.transform, H.end_effector(xi)),
            atol=1e-12,
        )

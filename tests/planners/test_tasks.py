"""`TipPoseTask` on the lanes (`tip_task_lane`) against the mechanism's own numpy composition of
seed 000 eqs (24), (34): `HybridBoardingSystem.task_jacobian` (itself held to finite differences
and Pinocchio in tests/mechanisms) and `pose_error` of `end_effector`."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import random_hybrid_states
from twin.errors import TwinError
from twin.mechanisms import HybridBoardingSystem
from twin.planners import TipTarget
from twin.planners.tasks import TipPoseTask
from twin.spatial import pose_error

H = HybridBoardingSystem()
TASK = TipPoseTask(H, gain=7.0)


def targets(rng: np.random.Generator, xi: np.ndarray) -> TipTarget:
    """Tips near those of xi, with random twists."""
    near = xi + rng.normal(scale=0.02, size=xi.shape)
    return TipTarget(H.end_effector(near), rng.normal(size=(*xi.shape[:-1], 6)))


def test_error_demand_and_jacobian_equal_the_mechanisms(rng: np.random.Generator) -> None:
    """The tip task's error, demand (twist + 7 e) and Jacobian equal the mechanism's pose error and
    task Jacobian to 1e-12."""
    xi = random_hybrid_states(rng, 40)
    target = targets(rng, xi)
    e = pose_error(target.transform, H.end_effector(xi))
    np.testing.assert_allclose(TASK.error(xi, target), e, rtol=0, atol=1e-12)
    demand, error = TASK.demand(xi, target)
    np.testing.assert_allclose(error, e, rtol=0, atol=1e-12)
    np.testing.assert_allclose(demand, target.twist + 7.0 * e, rtol=0, atol=1e-12)
    np.testing.assert_allclose(TASK.jacobian(xi), H.task_jacobian(xi), rtol=0, atol=1e-12)


def test_one_lane_and_a_shared_target(rng: np.random.Generator) -> None:
    """xi (9,) gives (6,) and (6, 9); a batch of states against one target broadcasts."""
    xi = random_hybrid_states(rng, 5)
    one = TipTarget(H.end_effector(xi[0] + 0.01), np.zeros(6))
    assert TASK.error(xi[0], one).shape == (6,) and TASK.jacobian(xi[0]).shape == (6, 9)
    shared = TASK.error(xi, one)
    for k in range(5):
        np.testing.assert_array_equal(shared[k], TASK.error(xi[k], one))


def test_bad_states_raise_twin_errors() -> None:
    """A non-finite or wrongly shaped state raises TwinError naming the argument and what is
    allowed."""
    xi = H.working_state.copy()
    xi[7] = np.nan
    target = TipTarget(H.end_effector(H.working_state), np.zeros(6))
    with pytest.raises(TwinError, match="q must be finite"):
        TASK.error(xi, target)
    with pytest.raises(TwinError, match="xi must be finite"):
        TASK.jacobian(xi)
    with pytest.raises(TwinError, match=r"shape \(\.\.\., 9\)"):
        TASK.jacobian(np.zeros(8))


def test_the_demand_over_a_step_applies_the_sampled_gain(rng: np.random.Generator) -> None:
    """With a control period dt the demand is ẋ_d + (1 − e^(−k_e dt))/dt · e, the gain the
    planners' steps apply; without one, ẋ_d + k_e e."""
    xi = random_hybrid_states(rng, 10)
    target = targets(rng, xi)
    for dt in (0.01, 0.2):
        demand, error = TASK.demand(xi, target, dt)
        sampled = (1.0 - np.exp(-TASK.gain * dt)) / dt
        np.testing.assert_allclose(demand, target.twist + sampled * error, rtol=0, atol=1e-12)
        assert sampled < TASK.gain

"""Seed 004's position-level planners: conv1, conv2, DWA, and the reachable range; the
planners' properties on the object and on the engine's lane step (`tests.planners.engine_step`)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.planners.engine_step import PATHS, step
from twin.mechanisms import HybridBoardingSystem
from twin.planners import PLANNERS, PlannerParameters, TipTarget, reachable_range
from twin.spatial import pose_to_transform

H = HybridBoardingSystem()


def brute_range(pose: np.ndarray, axis: int) -> float:
    """Feasible interval through 0 by a 0.1 mm scan: the paper's 'space search'."""
    s = np.arange(-3.0, 3.0 + 1e-12, 1e-4)
    poses = np.tile(pose, (s.size, 1))
    poses[:, axis] += s
    ok = H.stewart.within_limits(H.stewart.leg_lengths(poses))
    centre = np.argmin(np.abs(s))
    hi = centre + np.argmin(ok[centre:]) - 1 if not ok[centre:].all() else s.size - 1
    lo = centre - np.argmin(ok[centre::-1]) + 1 if not ok[centre::-1].all() else 0
    return s[hi] - s[lo]


@pytest.mark.parametrize(
    "pose", [[0, 0, 2.475, 0, 0, 0], [0.1, -0.2, 2.6, 0.05, -0.08, 0.1], [0, 0, 1.7, 0, 0, 0]]
)
def test_reachable_range_equals_a_brute_force_search(pose: list[float]) -> None:
    pose = np.array(pose, dtype=float)
    closed = reachable_range(H, pose)
    for axis in range(3):
        assert closed[axis] == pytest.approx(brute_range(pose, axis), abs=3e-4)


def test_reachable_range_of_a_batch_is_each_poses() -> None:
    """Poses (2, 3, 6) give ranges (2, 3, 3), each its pose's own (`reachable_range_lane` per
    lane; the brute-force search above holds the numbers)."""
    poses = H.working_state[:6] + np.linspace(-0.1, 0.1, 6)[:, None] * [1, 1, 1, 0.1, 0.1, 0.1]
    batch = reachable_range(H, poses.reshape(2, 3, 6))
    assert batch.shape == (2, 3, 3)
    for pose, got in zip(poses, batch.reshape(6, 3), strict=True):
        np.testing.assert_array_equal(got, reachable_range(H, pose))


def test_reachable_range_is_zero_outside() -> None:
    np.testing.assert_array_equal(reachable_range(H, np.array([0, 0, 5.0, 0, 0, 0])), 0.0)


def compensation_target(C_pose: np.ndarray) -> TipTarget:
    """The tip target when the base has moved by C⁻¹: ᴮT_E,d = C ᴮT_E(0)."""
    return TipTarget(pose_to_transform(C_pose) @ H.end_effector(H.working_state), np.zeros(6))


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("method", ["conv1", "conv2", "dwa"])
def test_tip_position_is_held(method: str, path: str) -> None:
    """Every method puts the tip on the target position (seed 004 §3: exact compensation)."""
    xi = H.working_state
    planner = PLANNERS[method].build(H, PlannerParameters(), xi)
    target = compensation_target(np.array([0.2, -0.1, 0.3, 0.03, -0.02, 0.04]))
    planner.reset(xi, compensation_target(np.zeros(6)))
    out = step(path, planner, xi, target)
    new = H.integrate(xi, out.velocity, 0.05)
    np.testing.assert_allclose(H.end_effector(new)[:3, 3], target.transform[:3, 3], atol=1e-9)


@pytest.mark.parametrize("path", PATHS)
def test_conv1_moves_only_the_platform_and_conv2_keeps_its_position(path: str) -> None:
    xi = H.working_state
    target = compensation_target(np.array([0.2, -0.1, 0.3, 0.03, -0.02, 0.04]))
    new = {}
    for method in ("conv1", "conv2"):
        planner = PLANNERS[method].build(H, PlannerParameters(), xi)
        planner.reset(xi, compensation_target(np.zeros(6)))
        new[method] = H.integrate(xi, step(path, planner, xi, target).velocity, 0.05)
    np.testing.assert_allclose(new["conv1"][6:], xi[6:], atol=1e-12)
    np.testing.assert_allclose(H.end_effector(new["conv1"]), target.transform, atol=1e-9)
    np.testing.assert_allclose(new["conv2"][:3], xi[:3], atol=1e-12)


@pytest.mark.parametrize("path", PATHS)
def test_dwa_gives_yaw_to_the_slew_and_shares_position(path: str) -> None:
    """Seed 004 §3.2 b: θ1 takes ψ; a: the platform takes [λ_p w]³ of each position axis."""
    xi = H.working_state
    planner = PLANNERS["dwa"].build(H, PlannerParameters(), xi)
    planner.reset(xi, compensation_target(np.zeros(6)))
    share = planner.shares(xi[:6])
    np.testing.assert_allclose(share, 1.0, atol=1e-12)  # at the mid pose λ_p = w = 1
    out = step(path, planner, xi, compensation_target(np.array([0, 0, 0, 0, 0, 0.05])))
    new = H.integrate(xi, out.velocity, 0.05)
    assert new[5] == pytest.approx(0.0, abs=1e-12)  # the platform does not yaw
    assert new[6] == pytest.approx(0.05, abs=2e-3)  # the slew does

"""Seed 004's position-level planners: conv1, conv2, DWA, and the reachable range. The planner
object's `step` runs the engine's lane step (`twin.planners.allocation_step`), so each property
holds the engine to an independent statement: `HybridBoardingSystem`'s numpy kinematics, a
brute-force space search, and seed 004's split typed below in numpy."""

from __future__ import annotations

import numpy as np
import pytest

from tests.sim.oracle import held_target
from twin.mechanisms import HybridBoardingSystem
from twin.planners import PLANNERS, PlannerParameters, TipTarget, reachable_range
from twin.sim.base_motion import BaseMotion
from twin.sim.scenario import Scenario
from twin.spatial import invert_transform, matrix_to_rpy, pose_to_transform, so3_exp

H = HybridBoardingSystem()
DT = 0.05  # [s]


def brute_range(pose: np.ndarray, axis: int) -> float:
    """Feasible interval through 0 by a 0.1 mm scan: the paper's 'space search'."""
    s = np.arange(-3.0, 3.0 + 1e-12, 1e-4)
    poses = np.tile(pose, (s.size, 1))
    poses[:, axis] += s
    legs = H.stewart.leg_lengths(poses)  # the stroke itself: the range is geometric, no tolerance
    ok = np.all((legs >= H.stewart.leg_min) & (legs <= H.stewart.leg_max), axis=-1)
    centre = np.argmin(np.abs(s))
    hi = centre + np.argmin(ok[centre:]) - 1 if not ok[centre:].all() else s.size - 1
    lo = centre - np.argmin(ok[centre::-1]) + 1 if not ok[centre::-1].all() else 0
    return s[hi] - s[lo]


@pytest.mark.parametrize(
    "pose", [[0, 0, 2.475, 0, 0, 0], [0.1, -0.2, 2.6, 0.05, -0.08, 0.1], [0, 0, 1.7, 0, 0, 0]]
)
def test_reachable_range_equals_a_brute_force_search(pose: list[float]) -> None:
    """The closed-form reachable range of the platform equals a brute-force search on every axis
    within 0.3 mm."""
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
    """A pose outside the workspace has a reachable range of zero on every axis."""
    np.testing.assert_array_equal(reachable_range(H, np.array([0, 0, 5.0, 0, 0, 0])), 0.0)


def compensation_target(C_pose: np.ndarray) -> TipTarget:
    """The tip target when the base has moved by C⁻¹: ᴮT_E,d = C ᴮT_E(0)."""
    return TipTarget(pose_to_transform(C_pose) @ H.end_effector(H.working_state), np.zeros(6))


@pytest.mark.parametrize("method", ["conv1", "conv2", "dwa"])
def test_tip_position_is_held(method: str) -> None:
    """Every method puts the tip on the target position (seed 004 §3: exact compensation)."""
    xi = H.working_state
    planner = PLANNERS[method].build(H, PlannerParameters(), xi)
    target = compensation_target(np.array([0.2, -0.1, 0.3, 0.03, -0.02, 0.04]))
    planner.reset(xi, compensation_target(np.zeros(6)))
    out = planner.step(xi, target, DT)
    new = H.integrate(xi, out.velocity, DT)
    np.testing.assert_allclose(H.end_effector(new)[:3, 3], target.transform[:3, 3], atol=1e-9)


def test_conv1_moves_only_the_platform_and_conv2_keeps_its_position() -> None:
    """conv1 reaches the target with the platform alone (gangway joints unchanged); conv2 leaves the
    platform's position unchanged."""
    xi = H.working_state
    target = compensation_target(np.array([0.2, -0.1, 0.3, 0.03, -0.02, 0.04]))
    new = {}
    for method in ("conv1", "conv2"):
        planner = PLANNERS[method].build(H, PlannerParameters(), xi)
        planner.reset(xi, compensation_target(np.zeros(6)))
        new[method] = H.integrate(xi, planner.step(xi, target, DT).velocity, DT)
    np.testing.assert_allclose(new["conv1"][6:], xi[6:], atol=1e-12)
    np.testing.assert_allclose(H.end_effector(new["conv1"]), target.transform, atol=1e-9)
    np.testing.assert_allclose(new["conv2"][:3], xi[:3], atol=1e-12)


def test_dwa_gives_yaw_to_the_slew_and_shares_position() -> None:
    """Seed 004 §3.2 b: θ1 takes ψ; a: the platform takes [λ_p w]³ of each position axis."""
    xi = H.working_state
    planner = PLANNERS["dwa"].build(H, PlannerParameters(), xi)
    planner.reset(xi, compensation_target(np.zeros(6)))
    share = planner.shares(xi[:6])
    np.testing.assert_allclose(share, 1.0, atol=1e-12)  # at the mid pose λ_p = w = 1
    out = planner.step(xi, compensation_target(np.array([0, 0, 0, 0, 0, 0.05])), DT)
    new = H.integrate(xi, out.velocity, DT)
    assert new[5] == pytest.approx(0.0, abs=1e-12)  # the platform does not yaw
    assert new[6] == pytest.approx(0.05, abs=2e-3)  # the slew does


def dwa_shares(pose: np.ndarray) -> np.ndarray:
    """[λ_p w_i]³ clipped to [0, 1] (seed 004 §3.2): the manipulability and the reachable
    range (held to a brute-force search above) over the working state's."""
    mid = H.working_state[:6]
    lam = H.stewart.manipulability(pose) / H.stewart.manipulability(mid)
    return np.clip(lam * reachable_range(H, pose) / reachable_range(H, mid), 0.0, 1.0) ** 3


#: starts: the working state, off-centre, a low platform near the leg minimum (small reach,
#: clipped shares) and one whose legs are outside their stroke (reach and shares zero)
STARTS = {
    "working": H.working_state,
    "off_centre": np.array([0.1, -0.1, 2.6, 0.02, -0.03, 0.05, 0.1, 0.05, 12.0]),
    "low": np.array([0.0, 0.0, 1.6, 0.0, 0.0, 0.0, 0.0, 0.0, 13.0]),
    "legs_outside": np.array([0.6, 0.4, 3.0, 0.1, -0.1, 0.2, -0.2, 0.1, 14.0]),
}


@pytest.mark.parametrize("start", list(STARTS))
@pytest.mark.parametrize("method", ["conv1", "conv2", "dwa"])
def test_steps_on_a_sea_split_as_seed_004_says(method: str, start: str) -> None:
    """40 steps of a held tip on sea state 6 from each start, each checked against
    seed 004's split typed here in numpy: the target predicted one dt ahead,
    T_a = [exp(ω dt) R_d, p_d + v dt]; T_full = T_a ᴮT_E(0)⁻¹ ᴮT_P(0); the tip reaches p_a;
    conv1 puts the platform at T_full and keeps the gangway, conv2 keeps the platform's
    position, dwa keeps its yaw and moves each position axis by the share [λ_p w_i]³ of the
    state the previous step reached (`dwa_shares`), which it reports as `position_share`."""
    xi = STARTS[start].copy()
    base = BaseMotion.of(Scenario(planner=method, sea_state=6, seed=3))
    samples = base.sample(np.arange(41) * DT)
    held = samples.transform[0] @ H.end_effector(xi)
    planner = PLANNERS[method].build(H, PlannerParameters(), xi)
    planner.reset(xi, held_target(held, samples, 0, DT))
    T_P0, T_E0_inv = pose_to_transform(xi[:6]), invert_transform(H.end_effector(xi))
    p0, yaw0 = T_P0[:3, 3], xi[5]
    share = dwa_shares(xi[:6])
    if start == "legs_outside":
        np.testing.assert_array_equal(share, 0.0)  # no reach, no share
    for k in range(40):
        target = held_target(held, samples, k, DT)
        out = planner.step(xi, target, DT)
        new = H.integrate(xi, out.velocity, DT)
        T_full = np.eye(4)
        T_full[:3, :3] = so3_exp(target.twist[3:] * DT) @ target.transform[:3, :3]
        T_full[:3, 3] = target.transform[:3, 3] + target.twist[:3] * DT
        ahead_p = T_full[:3, 3].copy()
        T_full = T_full @ T_E0_inv @ T_P0
        np.testing.assert_allclose(H.end_effector(new)[:3, 3], ahead_p, atol=1e-9)
        if method == "conv1":
            np.testing.assert_allclose(pose_to_transform(new[:6]), T_full, atol=1e-9)
            np.testing.assert_allclose(new[6:], xi[6:], atol=1e-12)
        elif method == "conv2":
            np.testing.assert_allclose(pose_to_transform(new[:6])[:3, :3], T_full[:3, :3],
                                       atol=1e-9)  # fmt: skip
            np.testing.assert_allclose(new[:3], p0, atol=1e-9)
        else:
            np.testing.assert_allclose(out.diagnostics["position_share"], share, atol=1e-12)
            roll, pitch, _ = matrix_to_rpy(T_full[:3, :3])
            np.testing.assert_allclose(new[3:6], [roll, pitch, yaw0], atol=1e-9)
            np.testing.assert_allclose(new[:3], p0 + share * (T_full[:3, 3] - p0), atol=1e-9)
            share = dwa_shares(new[:6])
        xi = new

"""The benchmark's Pinocchio peer is the same machine: tip pose and J_task agree to 1e-9.

Pinocchio (`pin`) is a test dependency: a peer that fails to import fails here, never skips."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks import pinocchio_peer as pin_peer
from tests.conftest import random_hybrid_states
from twin.mechanisms import HybridBoardingSystem

H = HybridBoardingSystem()


@pytest.mark.parametrize("seed", range(3))
def test_peer_jacobian_equals_task_jacobian(seed: int) -> None:
    """Pinocchio's tip Jacobian (LOCAL_WORLD_ALIGNED, Euler-rate columns) times the map from our
    body-twist columns equals J_task (seed 000 eq (24)) on random in-limit states."""
    peer = pin_peer.PinocchioPeer()
    for xi in random_hybrid_states(np.random.default_rng(seed), 20):
        J = peer.jacobian(pin_peer.xi_to_q(xi)) @ pin_peer.body_to_pin_rates(xi)
        np.testing.assert_allclose(J, H.task_jacobian(xi), rtol=0, atol=1e-9)


def test_peer_tip_pose_equals_end_effector() -> None:
    """Pinocchio's tip placement equals `end_effector` (seed 000 eq (14)) to 1e-9."""
    peer = pin_peer.PinocchioPeer()
    for xi in random_hybrid_states(np.random.default_rng(7), 20):
        T = peer.tip_pose(pin_peer.xi_to_q(xi)).homogeneous
        np.testing.assert_allclose(T, H.end_effector(xi), rtol=0, atol=1e-9)


def test_peer_loop_holds_a_fixed_target() -> None:
    """The peer's closed loop converges onto a target a few centimetres off (a sanity check)."""
    peer = pin_peer.PinocchioPeer()
    q0 = pin_peer.xi_to_q(H.working_state)
    target = H.end_effector(H.working_state)
    target[:3, 3] += [0.03, -0.02, 0.05]
    q = peer.run(q0, np.repeat(target[None], 100, 0), np.zeros((100, 6)), 0.05)[-1]
    np.testing.assert_allclose(peer.tip_pose(q).homogeneous, target, atol=1e-6)

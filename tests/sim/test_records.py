"""What a run records, computed by the compiled records runner from the samples' target rows,
equals the mechanism objects' own methods (legs, tip pose error, manipulability, tilt),
compiled or interpreted."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import random_hybrid_states
from twin.mechanisms import HybridBoardingSystem
from twin.planners import HYBRID_RATE_LIMITS
from twin.sim.kernels.hybrid import hybrid_constants
from twin.sim.kernels.records import compiled_records, run_hybrid_records
from twin.sim.records import hybrid_records, landing_frame
from twin.sim.target import held_targets, tilt
from twin.spatial import invert_transform, pose_error, pose_to_transform

H = HybridBoardingSystem()


@pytest.mark.parametrize("runner", ["compiled", "python"])
def test_hybrid_records_equal_the_mechanism(rng: np.random.Generator, runner: str) -> None:
    """The hybrid records equal the mechanism's legs, tip error, manipulability and tilt, and from a
    later first sample the same bits."""
    n_lanes, n = 2, 40
    xi = random_hybrid_states(rng, n_lanes * n, shrink=0.8).reshape(n_lanes, n, 9)
    poses = rng.normal(scale=[0.5, 0.5, 0.5, 0.1, 0.1, 0.3], size=(n_lanes, n, 6))
    T_IB0 = pose_to_transform(poses[:, 0])
    held = T_IB0 @ H.end_effector(xi[:, 0])
    landing, g0 = landing_frame(T_IB0, xi[:, 0], H)
    run = compiled_records(False) if runner == "compiled" else run_hybrid_records
    targets = held_targets(held, poses, 0.05, end=True)  # a sample's ᴮT_d, as the engine's
    out = hybrid_records(targets, xi, held, landing, g0, hybrid_constants(H, HYBRID_RATE_LIMITS),
                         run)  # fmt: skip
    T_IB = pose_to_transform(poses)
    np.testing.assert_allclose(out["legs"], H.leg_lengths(xi), atol=1e-12)
    expected = pose_error(invert_transform(T_IB) @ held[:, None], H.end_effector(xi))
    np.testing.assert_allclose(out["tip_error"], expected, atol=1e-12)
    np.testing.assert_allclose(out["manipulability"], H.manipulability(xi), rtol=1e-10)
    np.testing.assert_allclose(out["alpha_bottom"], tilt(T_IB[..., :3, :3]), atol=1e-14)
    # at t = 0 the tip is where it is held and the gangway points where it started
    np.testing.assert_allclose(out["tip_error"][:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(out["alpha_top"][:, 0], 0.0, atol=1e-7)
    np.testing.assert_allclose(out["phi_e"][:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(out["theta_e"][:, 0], 0.0, atol=1e-12)
    assert np.abs(out["phi_e"][:, 1:]).max() > 1e-3  # and moves with the states
    # from a later first sample: the same records of the samples after it, bit for bit
    later = hybrid_records(targets, xi, held, landing, g0,
                           hybrid_constants(H, HYBRID_RATE_LIMITS), run, first=7)  # fmt: skip
    assert later["legs"].shape == (n_lanes, n - 7, 6)
    for key, values in later.items():
        np.testing.assert_array_equal(values, out[key][:, 7:], err_msg=key)


def test_targets_with_the_end_row(rng: np.random.Generator) -> None:
    """`held_targets(..., end=True)`: the chunk's rows as without it, then the end's desired
    pose ᴵT_B⁻¹ ᴵT* (what is recorded there) with a NaN twist (the next pose is not known)."""
    poses = rng.normal(scale=[0.5, 0.5, 0.5, 0.1, 0.1, 0.3], size=(2, 9, 6))
    held = pose_to_transform(rng.normal(scale=0.3, size=(2, 6)))
    rows = held_targets(held, poses, 0.05)
    with_end = held_targets(held, poses, 0.05, end=True)
    assert rows.shape == (2, 8, 18) and with_end.shape == (2, 9, 18)
    np.testing.assert_array_equal(with_end[:, :8], rows)
    desired = invert_transform(pose_to_transform(poses[:, -1])) @ held
    np.testing.assert_allclose(with_end[:, 8, :9].reshape(2, 3, 3), desired[:, :3, :3], atol=1e-14)
    np.testing.assert_allclose(with_end[:, 8, 9:12], desired[:, :3, 3], atol=1e-14)
    assert np.isnan(with_end[:, 8, 12:]).all()


@pytest.mark.parametrize("runner", ["serial", "parallel", "python"])
def test_records_refuse_targets_without_the_end_row(rng: np.random.Generator, runner: str) -> None:
    """A chunk's targets without the end row (one short of the states) are refused, not read
    past, by every runner (two lanes, so the parallel one runs its parallel loop)."""
    xi = random_hybrid_states(rng, 5, shrink=0.8)[None].repeat(2, axis=0)
    poses = rng.normal(scale=0.1, size=(2, 5, 6))
    held = pose_to_transform(poses[:, 0]) @ H.end_effector(xi[:, 0])
    landing, g0 = landing_frame(pose_to_transform(poses[:, 0]), xi[:, 0], H)
    run = {"serial": compiled_records(False), "parallel": compiled_records(True),
           "python": run_hybrid_records}[runner]  # fmt: skip
    short = held_targets(held, poses, 0.05)  # 4 rows for 5 samples
    with pytest.raises(ValueError, match="row per sample"):
        hybrid_records(short, xi, held, landing, g0, hybrid_constants(H, HYBRID_RATE_LIMITS), run)

"""The compiled sea (twin/sim/kernels/sea.py): the vessel motion at uniform samples put on the
mount, against `vessel_motion` and `base_pose`, across spans (exact phasors every
SPAN·BLOCK samples) and blocks, for odd and even numbers of components; the same bits for a
lane however it runs (alone or among others, serial or parallel, compiled here or loaded from
numba's cache); its error against an extended-precision sum no larger than the direct sum's.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from twin.errors import TwinError
from twin.sim.base_motion import BaseMotion
from twin.sim.kernels import sea
from twin.sim.lanes import numba_available
from twin.sim.scenario import Scenario
from twin.vessel import MOUNTS, load_raos
from twin.vessel.motion import base_pose, vessel_motion

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba not installed")

#: a head-on sea with forward speed (even K), a small odd K, a spread sea on the ASV's mount
SCENARIOS = [
    Scenario(sea_state=5, heading=170.0, forward_speed=2.0, seed=3),
    Scenario(sea_state=3, n_components=37, seed=4),
    Scenario(mechanism="upr4", hs=1.0, tp=6.0, spreading=4.0, n_components=61, seed=5),
]
DT = 0.05  # [s]


def kernel_arrays(motions: list[BaseMotion]) -> tuple[np.ndarray, ...]:
    """The runner's inputs as `BaseMotion.uniform_poses` builds them (lanes padded)."""
    K = max(m.omega_e.size for m in motions)
    omega_e, response = np.zeros((len(motions), K)), np.zeros((len(motions), 6, K), complex)
    for lane, m in enumerate(motions):
        omega_e[lane, : m.omega_e.size] = m.omega_e
        response[lane, :, : m.omega_e.size] = m.amplitude.T
    lever_arm = np.array([m.mount.lever_arm for m in motions], dtype=float)
    yaw = np.array([m.mount.yaw for m in motions], dtype=float)
    return (omega_e, np.ascontiguousarray(response.real), np.ascontiguousarray(response.imag),
            lever_arm, yaw)  # fmt: skip


def direct(scenario: Scenario, t: np.ndarray) -> np.ndarray:
    """`vessel_motion` on the scenario's mount, by the dense complex sum (N, 6) [m, rad]."""
    mount = MOUNTS[scenario.mechanism]
    motion = vessel_motion(scenario.components(), load_raos(mount.vessel), t,
                           speed=scenario.forward_speed)  # fmt: skip
    return mount.pose(motion)


@pytest.fixture(scope="module")
def motions() -> list[BaseMotion]:
    return [BaseMotion.of(s) for s in SCENARIOS]


def test_mount_lane_is_base_pose() -> None:
    """One sample put on the mount equals `base_pose`, for any mount yaw and lever arm."""
    rng = np.random.default_rng(0)
    R, out = np.empty((3, 3)), np.empty(6)
    for _ in range(50):
        motion = rng.normal(size=6) * [1, 1, 1, 0.2, 0.2, 0.3]
        lever_arm, yaw = rng.normal(size=3) * 10, rng.uniform(-np.pi, np.pi)
        sea.mount_lane(motion, lever_arm, np.cos(yaw), np.sin(yaw), R, out)
        np.testing.assert_allclose(out, base_pose(motion[None], lever_arm, yaw)[0],
                                   rtol=0, atol=1e-13)  # fmt: skip


@pytest.mark.parametrize("t0", [0.0, 1234.5])
def test_many_spans_equal_the_direct_sum(motions: list[BaseMotion], t0: float) -> None:
    """Over several spans, from a span's start or mid-block (as a chunk of a long run), every
    lane matches vessel_motion on its mount; a length that is no multiple of a block too."""
    n = 2 * sea.SPAN * sea.BLOCK + sea.BLOCK // 2 + 3
    t = t0 + np.arange(n) * DT
    poses = BaseMotion.uniform_poses(motions, t0, DT, n)
    for lane, scenario in enumerate(SCENARIOS):
        expected = direct(scenario, t)
        assert np.abs(expected).max() > 0.05
        np.testing.assert_allclose(poses[lane], expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "python"])
def test_a_run_sampled_in_pieces_gets_the_bits_of_one_call(
    motions: list[BaseMotion], compiled: bool
) -> None:
    """Pieces that start anywhere (mid-block, on a block, mid-span; a live session's 256
    samples at a time, or after a sea change at any step) give one call's bits: blocks and
    spans count from sample 0, not from a call's first sample."""
    motions = motions if compiled else motions[1:2]  # interpreted: the lane of 37 components
    n = 2 * sea.SPAN * sea.BLOCK + 40
    whole = BaseMotion.uniform_poses(motions, 1.5, DT, n, compiled)
    cuts = [0, 37, sea.BLOCK, 256, 300, sea.SPAN * sea.BLOCK - 1, sea.SPAN * sea.BLOCK + 1, n]
    pieces = [BaseMotion.uniform_poses(motions, 1.5, DT, b - a, compiled, first=a)
              for a, b in itertools.pairwise(cuts)]  # fmt: skip
    assert np.concatenate(pieces, axis=1).tobytes() == whole.tobytes()
    # the same samples from a t0 moved by `first` steps are other numbers (they would need the
    # span's phasor at another time), which is why the engine keeps t0 = 0 and moves `first`
    moved = BaseMotion.uniform_poses(motions, 1.5 + 300 * DT, DT, n - 300, compiled)
    np.testing.assert_allclose(moved, whole[:, 300:], rtol=0, atol=1e-12)
    assert moved.tobytes() != whole[:, 300:].tobytes()
    with pytest.raises(TwinError, match="first"):
        BaseMotion.uniform_poses(motions, 1.5, DT, 3, compiled, first=-1)


def test_interpreted_equals_compiled(motions: list[BaseMotion]) -> None:
    """The plain function (the engine without numba) gives the compiled numbers, across a
    span boundary."""
    n = sea.SPAN * sea.BLOCK + 5
    compiled = BaseMotion.uniform_poses(motions[1:], 3.0, DT, n)
    interpreted = BaseMotion.uniform_poses(motions[1:], 3.0, DT, n, compiled=False)
    np.testing.assert_allclose(interpreted, compiled, rtol=0, atol=1e-13)


@needs_numba
def test_a_lane_gets_the_same_bits_however_it_runs(motions: list[BaseMotion]) -> None:
    """A lane's poses do not depend on its company (others, padding of its components, its
    place), on serial or parallel code, nor on whether the code was compiled in this process or
    loaded from numba's cache: no sum is reordered by the machine code."""
    import numba

    n = sea.SPAN * sea.BLOCK + sea.BLOCK + 7
    many = motions * 3  # enough lanes for both threads
    arrays = kernel_arrays(many)
    reference = np.empty((len(many), n, 6))
    sea.compiled_base_poses(True)(*arrays, 2.0, DT, 0, reference)  # cached on disk
    for lane, motion in enumerate(motions):
        alone = np.empty((1, n, 6))
        sea.compiled_base_poses(False)(*kernel_arrays([motion]), 2.0, DT, 0, alone)
        assert alone.tobytes() == reference[lane].tobytes()
    reordered = [many[i] for i in (4, 2, 0, 1, 3, 5, 7, 8, 6)]
    out = np.empty((len(many), n, 6))
    sea.compiled_base_poses(True)(*kernel_arrays(reordered), 2.0, DT, 0, out)
    assert out[2].tobytes() == reference[0].tobytes()
    for parallel in (False, True):  # compiled afresh here, never from the cache
        fresh = numba.njit(parallel=parallel, error_model="numpy")(sea.run_base_poses)
        fresh(*arrays, 2.0, DT, 0, out)
        assert out.tobytes() == reference.tobytes()


@pytest.mark.skipif(np.finfo(np.longdouble).eps >= np.finfo(float).eps, reason="no long double")
def test_error_is_that_of_the_direct_sum(motions: list[BaseMotion]) -> None:
    """Against the motion summed in extended precision (x87 long double) at the same times,
    the compiled sum errs no more than the dense double sum of vessel_motion (both start from
    the rounded angle ω t), and by a few 1e-14 m over the first minutes."""
    motion = motions[0]
    n = 3 * sea.SPAN * sea.BLOCK
    for t0 in (0.0, 600.0):
        t = t0 + np.arange(n) * DT
        arrays = list(kernel_arrays([motion]))
        arrays[3], arrays[4] = np.zeros((1, 3)), np.zeros(1)  # the vessel's origin: x, y, z
        out = np.empty((1, n, 6))
        sea.compiled_base_poses(False)(*arrays, t0, DT, 0, out)
        long_t = np.longdouble(t0) + np.arange(n, dtype=np.longdouble) * np.longdouble(DT)
        angle = np.outer(long_t, motion.omega_e.astype(np.longdouble))
        H = motion.amplitude[:, :3]
        exact = (np.cos(angle) @ H.real.astype(np.longdouble)
                 + np.sin(angle) @ H.imag.astype(np.longdouble)).astype(float)  # fmt: skip
        dense = (np.exp(-1j * np.outer(t, motion.omega_e)) @ H).real
        error, dense_error = np.abs(out[0, :, :3] - exact).max(), np.abs(dense - exact).max()
        assert error <= max(2 * dense_error, 5e-14), (t0, error, dense_error)
        if t0 == 0.0:
            assert error < 1e-13

"""Property-based fuzzing of the vessel layer: RAO motion and mechanism base poses (issue 8).

Random seas in the Scenario ranges, any heading, forward speeds 0-10 m/s, each shipped vessel
and mount: the motion is finite and bounded by the RAO tables, base poses are rigid and keep
their lever arm; bad input raises a ValueError that names the argument.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tests.figures import fuzz
from twin.sea import WaveComponents, wave_components
from twin.sim.base_motion import BaseMotion
from twin.vessel import (
    MOUNTS,
    available_raos,
    base_pose,
    equilibrium_to_world,
    load_raos,
    vessel_motion,
)

VESSELS = ("sov", "asv", "barge")
RAOS = {name: load_raos(name) for name in VESSELS}


def finite(low: float, high: float) -> st.SearchStrategy[float]:
    return st.floats(low, high, allow_nan=False, allow_infinity=False)


@st.composite
def seas(draw: st.DrawFn) -> WaveComponents:
    """A sea in the Scenario ranges (Hs 0-20 m, Tp 1-30 s, γ 1-10, s 1-100 or None)."""
    return wave_components(
        draw(finite(0.0, 20.0)),
        draw(finite(1.0, 30.0)),
        draw(st.sampled_from(["jonswap", "pierson_moskowitz"])),
        heading=float(np.deg2rad(draw(finite(-360.0, 360.0)))),
        spreading=draw(st.none() | finite(1.0, 100.0)),
        seed=draw(st.integers(0, 2**32 - 1)),
        n_components=draw(st.integers(8, 48)),
        gamma=draw(finite(1.0, 10.0)),
    )


TIMES = arrays(np.float64, st.integers(1, 24), elements=finite(0.0, 1e4))  # [s]
HEADING = finite(-2 * np.pi, 2 * np.pi)  # [rad]
SPEED = finite(0.0, 10.0)  # [m/s], Scenario.forward_speed
NONFINITE = st.sampled_from([np.nan, np.inf, -np.inf])


def assert_rigid(T: np.ndarray) -> None:
    """Finite homogeneous transforms (..., 4, 4) with a proper rotation block."""
    assert np.all(np.isfinite(T))
    R = T[..., :3, :3]
    np.testing.assert_allclose(
        R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12
    )
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    np.testing.assert_array_equal(T[..., 3, :], np.broadcast_to([0.0, 0.0, 0.0, 1.0], T.shape[:-1]))


@fuzz(300)
@given(vessel=st.sampled_from(VESSELS), sea=seas(), t=TIMES, heading=HEADING, speed=SPEED)
def test_vessel_motion_is_finite_and_bounded_by_the_raos(vessel, sea, t, heading, speed) -> None:
    """|x_j(t)| ≤ Σ_i a_i max|H_j|: bilinear RAO interpolation is a convex combination of
    table nodes, conjugation keeps |H|, and every phasor has modulus 1."""
    raos = RAOS[vessel]
    motion = vessel_motion(sea, raos, t, heading, speed)
    assert motion.shape == (t.size, 6) and np.all(np.isfinite(motion))
    bound = np.sum(sea.amplitude) * np.max(np.abs(raos.values), axis=(0, 1))  # (6,)
    assert np.all(np.abs(motion) <= bound * (1 + 1e-9) + 1e-12)
    np.testing.assert_array_equal(vessel_motion(sea, raos, t, heading, speed), motion)


@fuzz(200)
@given(
    mount=st.sampled_from(sorted(MOUNTS)),
    vessel=st.sampled_from(VESSELS),
    sea=seas(),
    t=TIMES,
    speed=SPEED,
    heading=HEADING,
)
def test_base_poses_are_rigid_and_keep_the_lever_arm(mount, vessel, sea, t, speed, heading):
    """BaseMotion gives finite poses and rigid ᴵT_B; the base sits |r| from the centre of
    motion at every instant (p_base = p + R(t) r); equilibrium → world keeps heights."""
    m = MOUNTS[mount]
    samples = BaseMotion(sea, m, vessel=vessel, speed=speed).sample(t)
    assert samples.pose.shape == (t.size, 6) and np.all(np.isfinite(samples.pose))
    assert_rigid(samples.transform)
    motion = vessel_motion(sea, RAOS[vessel], t, 0.0, speed)
    offset = np.linalg.norm(samples.pose[:, :3] - motion[:, :3], axis=-1)
    np.testing.assert_allclose(offset, np.linalg.norm(m.lever_arm), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(base_pose(motion, m.lever_arm, m.yaw), samples.pose, atol=1e-12)
    world = equilibrium_to_world(samples.pose, t, heading, speed)
    assert np.all(np.isfinite(world))
    np.testing.assert_allclose(world[:, 2], samples.pose[:, 2], atol=1e-9)


_SEA = WaveComponents(np.array([0.8]), np.array([1.0]), np.array([0.0]), np.array([np.pi]))
_SOV = RAOS["sov"]


def _components(**bad: Any) -> WaveComponents:
    fields = {
        "omega": [0.8, 1.0],
        "amplitude": [1.0, 0.5],
        "phase": [0.0, 1.0],
        "direction": [np.pi, 0.0],
    }
    fields.update({k: [fields[k][0], v] for k, v in bad.items()})
    return WaveComponents(*(np.array(fields[k]) for k in fields))


# (name the message starts with, call with the bad value, bad values)
BAD_VESSEL: list[tuple[str, Callable[[Any], Any], st.SearchStrategy]] = [
    ("t", lambda v: vessel_motion(_SEA, _SOV, [0.0, v]), NONFINITE),
    ("heading", lambda v: vessel_motion(_SEA, _SOV, [0.0], heading=v), NONFINITE),
    ("speed", lambda v: vessel_motion(_SEA, _SOV, [0.0], speed=v), NONFINITE),
    ("motion", lambda v: base_pose([[0.0, 0.0, v, 0.0, 0.0, 0.0]], [0.0, 0.0, 1.0]), NONFINITE),
    ("lever_arm", lambda v: base_pose(np.zeros((1, 6)), [v, 0.0, 1.0]), NONFINITE),
    ("mount_yaw", lambda v: base_pose(np.zeros((1, 6)), [0.0, 0.0, 1.0], v), NONFINITE),
    ("pose", lambda v: equilibrium_to_world([[v, 0, 0, 0, 0, 0]], [0.0]), NONFINITE),
    ("speed", lambda v: BaseMotion(_SEA, MOUNTS["hybrid"], speed=v).poses(np.zeros(1)), NONFINITE),
    ("WaveComponents.omega", lambda v: _components(omega=v), NONFINITE | finite(-1e3, 0.0)),
    ("WaveComponents.amplitude", lambda v: _components(amplitude=v), NONFINITE),
    ("WaveComponents.phase", lambda v: _components(phase=v), NONFINITE),
    ("WaveComponents.direction", lambda v: _components(direction=v), NONFINITE),
    (
        "unknown vessel",
        load_raos,
        st.text("abcdefghijklmnopqrstuvwxyz_", min_size=1).filter(
            lambda name: name not in available_raos()
        ),
    ),
]


@fuzz(200)
@given(data=st.data())
def test_bad_vessel_input_raises_a_value_error_naming_it(data: st.DataObject) -> None:
    """NaN or inf input, a non-positive frequency or an unknown vessel: a ValueError whose
    message starts with what was wrong."""
    name, call, bad = data.draw(st.sampled_from(BAD_VESSEL), label="argument")
    value = data.draw(bad, label=name)
    with pytest.raises(ValueError, match=rf"^{re.escape(name)}\b"):
        call(value)

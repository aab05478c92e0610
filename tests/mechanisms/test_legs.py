"""twin.mechanisms.legs: the leg vectors, the arms and the leg twist rows (seed 000 eqs (4)-(8)),
checked against independent references: numpy's vectors and determinants and central finite
differences of the leg lengths, on a layout that is not the Stewart platform's."""

from __future__ import annotations

import numpy as np

from tests.conftest import random_hybrid_states
from tests.mechanisms.support import length_rates_by_differences
from twin.mechanisms import StewartPlatform
from twin.mechanisms.legs import (
    LEGS,
    TWIST,
    LegLayout,
    legs,
    manipulability_lane,
    twist_jacobian,
)
from twin.spatial import pose_to_transform

STEWART = StewartPlatform()


def random_layout(rng: np.random.Generator, n: int) -> LegLayout:
    """n legs between random hinges: base near z = 0, platform hinges about its origin [m]."""
    base = rng.uniform(-2.0, 2.0, (n, 3)) * [1.0, 1.0, 0.1]
    platform = rng.uniform(-1.0, 1.0, (n, 3)) * [1.0, 1.0, 0.2]
    return LegLayout(base, platform, np.full(n, 0.5), np.full(n, 5.0))


def random_transforms(rng: np.random.Generator, count: int) -> np.ndarray:
    """count platform transforms ᴮT_P (count, 4, 4), 2-3 m above the base, tilted ≤ 0.4 rad."""
    pose = np.zeros((count, 6))
    pose[:, :3] = rng.uniform([-0.3, -0.3, 2.0], [0.3, 0.3, 3.0], (count, 3))
    pose[:, 3:] = rng.uniform(-0.4, 0.4, (count, 3))
    return pose_to_transform(pose)


def test_legs_are_the_closed_vector_equation(rng: np.random.Generator) -> None:
    """l_i = ᴮR_P ᴾP_i + ᴮO_P − ᴮB_i, |l_i| and the arm ᴮR_P ᴾP_i, written here with numpy."""
    layout = random_layout(rng, 5)
    T = random_transforms(rng, 30)
    state = legs(layout, T)
    arms = np.einsum("kab,ib->kia", T[:, :3, :3], layout.platform_hinges)
    vectors = arms + T[:, None, :3, 3] - layout.base_hinges
    np.testing.assert_allclose(state.arms, arms, rtol=0, atol=1e-14)
    np.testing.assert_allclose(state.vectors, vectors, rtol=0, atol=1e-14)
    np.testing.assert_allclose(state.lengths, np.linalg.norm(vectors, axis=-1), rtol=1e-15)
    np.testing.assert_allclose(state.units, vectors / np.linalg.norm(vectors, axis=-1)[..., None],
                               rtol=0, atol=1e-15)  # fmt: skip


def test_twist_rows_are_central_differences_of_the_lengths(rng: np.random.Generator) -> None:
    """l̇ = J [v_O; ω] (v_O the origin's velocity, ω the angular velocity, both in B): each
    column of `twist_jacobian` is the central difference of the leg lengths along that twist,
    for a five-leg layout (the rows are not tied to six legs or to the Stewart geometry)."""
    layout = random_layout(rng, 5)
    for T in random_transforms(rng, 10):
        J = twist_jacobian(legs(layout, T))
        assert J.shape == (5, 6)
        np.testing.assert_allclose(length_rates_by_differences(layout, T), J, atol=1e-8)


def test_manipulability_lane_is_the_determinant_of_the_twist_rows(
    rng: np.random.Generator,
) -> None:
    """`manipulability_lane` (Gaussian elimination over the rows it builds) equals numpy's
    sqrt(det(J Jᵀ)) of `twist_jacobian`, and its rows are the same rows."""
    poses = random_hybrid_states(rng, 20)[:, :6]
    platform = STEWART.layout.platform_hinges.reshape(-1)
    for pose in poses:
        T = pose_to_transform(pose)
        state = legs(STEWART.layout, T)
        J = twist_jacobian(state)
        scratch = np.zeros((6, 6))
        m = manipulability_lane(T[:3, :3], state.vectors, state.lengths, platform, scratch)
        want = np.sqrt(np.linalg.det(J @ J.T))
        assert abs(m - want) <= 1e-12 * want
        assert abs(STEWART.manipulability(pose) - want) <= 1e-12 * want


def test_compiled_and_plain_batches_agree(rng: np.random.Generator) -> None:
    """The compiled batch loops give the plain-Python loops' numbers (the interpreted
    fallback runs the same lane functions), with the batch's leading axes kept."""
    layout = random_layout(rng, 4)
    T = random_transforms(rng, 12).reshape(3, 4, 4, 4)
    hinges = [layout.base_hinges.reshape(-1), layout.platform_hinges.reshape(-1)]
    cores = [(4, 3), (4,), (4, 3)]
    compiled = LEGS([T], hinges, cores)
    plain = LEGS([T], hinges, cores, plain=True)
    for c, p in zip(compiled, plain, strict=True):
        assert c.shape[:2] == (3, 4)
        np.testing.assert_allclose(c, p, rtol=1e-15, atol=1e-15)
    vectors, lengths, arms = compiled
    rows = TWIST([arms, vectors, lengths], [], [(4, 6)])[0]
    plain_rows = TWIST([arms, vectors, lengths], [], [(4, 6)], plain=True)[0]
    np.testing.assert_allclose(rows, plain_rows, rtol=1e-15, atol=1e-15)
    assert rows.shape == (3, 4, 4, 6)

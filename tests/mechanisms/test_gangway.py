"""Gangway: seed 000 Table 2 / eqs (9)-(11), seed 004 eqs (5), (7)-(8)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import UnreachableError
from twin.mechanisms import Gangway
from twin.spatial import so3_log

GANGWAY = Gangway()


def random_q(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.uniform(GANGWAY.lower, GANGWAY.upper, size=(n, 3))


def eq10(q: np.ndarray) -> np.ndarray:
    """Seed 000 eq (10) entries, typed from the paper, with θ2 = q2 + 90° (SPEC erratum 3)."""
    a1, d1 = 0.230, 3.106
    s1, c1 = np.sin(q[0]), np.cos(q[0])
    s2, c2 = np.sin(q[1] + np.pi / 2), np.cos(q[1] + np.pi / 2)
    d3 = q[2]
    return np.array(
        [
            [c1 * c2, s1, c1 * s2, a1 * c1 + d3 * c1 * s2],
            [c2 * s1, -c1, s1 * s2, a1 * s1 + d3 * s1 * s2],
            [s2, 0, -c2, d1 - d3 * c2],
            [0, 0, 0, 1],
        ]
    )


def test_dh_product_and_forward_equal_eq10(rng: np.random.Generator) -> None:
    """The eq (9) DH product (`links`) and `forward` (the closed-form `gangway_tip_lane`, one
    lane at a time and over a batch) equal the paper's closed form eq (10)."""
    qs = random_q(rng, 50)
    batch = GANGWAY.forward(qs)
    assert batch.shape == (50, 4, 4)
    for q, T in zip(qs, batch, strict=True):
        np.testing.assert_allclose(GANGWAY.links(q)[2], eq10(q), atol=1e-12)
        np.testing.assert_allclose(GANGWAY.forward(q), eq10(q), atol=1e-12)
        np.testing.assert_allclose(T, eq10(q), atol=1e-12)


def test_working_state_tip() -> None:
    """q = (0, 0, 13.052 m): tip at (a1 + d3, 0, d1) in P, gangway horizontal."""
    T = GANGWAY.forward([0, 0, 13.052])
    np.testing.assert_allclose(T[:3, 3], [13.282, 0, 3.106], atol=1e-12)
    np.testing.assert_allclose(T[:3, 2], [1, 0, 0], atol=1e-12)  # z_E along the gangway


def test_jacobian_equals_finite_difference(rng: np.random.Generator) -> None:
    """J_s (eq (11)) maps q̇ to the tip's linear and angular velocity in frame P."""
    h = 1e-6
    for q in random_q(rng, 30):
        J = GANGWAY.jacobian(q)
        for k in range(3):
            dq = np.eye(3)[k] * h
            Tp, Tm = GANGWAY.forward(q + dq), GANGWAY.forward(q - dq)
            np.testing.assert_allclose((Tp[:3, 3] - Tm[:3, 3]) / (2 * h), J[:3, k], atol=1e-6)
            w = so3_log(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * h)
            np.testing.assert_allclose(w, J[3:, k], atol=1e-6)


def test_inverse_recovers_joints(rng: np.random.Generator) -> None:
    """Seed 004 eqs (7)-(8) invert the position part of eq (10) over the Table 6 box."""
    q = random_q(rng, 1000)
    np.testing.assert_allclose(GANGWAY.inverse(GANGWAY.forward(q)[:, :3, 3]), q, atol=1e-10)


def test_inverse_at_the_paper_singular_pose() -> None:
    """At θ1 = 0, θ2 = 90° both of seed 004's d3 formulas divide by zero; ours does not."""
    np.testing.assert_allclose(GANGWAY.inverse([13.282, 0.0, 3.106]), [0, 0, 13.052], atol=1e-12)


def test_inverse_rejects_unreachable_positions() -> None:
    """A tip past the telescope's stroke or the slew range raises UnreachableError saying what is
    allowed."""
    with pytest.raises(UnreachableError, match="allowed"):
        GANGWAY.inverse([30.0, 0.0, 3.106])  # needs d3 > 16.552 m
    with pytest.raises(UnreachableError, match="allowed"):
        GANGWAY.inverse([5.0, 8.0, 3.106])  # needs q1 > 30°


def test_cylinder_law_of_cosines() -> None:
    """Seed 004 eq (5) with ϕ1 = 0: ϕ2 = 90° at q2 = 0, so l_c = sqrt(la² + lb²)."""
    assert GANGWAY.cylinder_length(0.0) == pytest.approx(np.hypot(0.93, 1.678))


def test_cylinder_covers_the_luff_range_monotonically() -> None:
    """Over q2 ∈ [-30°, 30°] the cylinder length is monotonic (no dead point) and invertible."""
    q2 = np.linspace(-GANGWAY.q2_limit, GANGWAY.q2_limit, 201)
    lc = GANGWAY.cylinder_length(q2)
    assert np.all(np.diff(lc) < 0)
    assert lc.min() > abs(1.678 - 0.93) and lc.max() < 1.678 + 0.93
    np.testing.assert_allclose(GANGWAY.luff_from_cylinder(lc), q2, atol=1e-12)


def test_impossible_cylinder_length() -> None:
    """A luffing-cylinder length no luff angle gives raises UnreachableError naming it
    impossible."""
    with pytest.raises(UnreachableError, match="impossible"):
        GANGWAY.luff_from_cylinder(3.0)


def test_bad_joint_shape() -> None:
    """Joints of the wrong shape raise ValueError naming the shape (..., 3) expected."""
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 3\)"):
        GANGWAY.forward([0.0, 0.0])

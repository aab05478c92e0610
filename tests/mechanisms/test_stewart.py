"""StewartPlatform: seed 000 Table 1 geometry, eqs (1)-(8), SPEC check values."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import random_hybrid_states
from tests.mechanisms.support import length_rates_by_differences
from twin.errors import ConvergenceError, TwinError, UnreachableError
from twin.mechanisms import StewartPlatform
from twin.spatial import pose_to_transform

STEWART = StewartPlatform()


@pytest.mark.parametrize(
    ("z", "expected"),
    [(1.525, 2.5799), (2.475, 3.2335)],  # SPEC check values
)
def test_level_leg_lengths_match_spec(z: float, expected: float) -> None:
    """All six legs equal the SPEC check value for a level, centred platform."""
    lengths = STEWART.leg_lengths([0, 0, z, 0, 0, 0])
    np.testing.assert_allclose(lengths, expected, atol=5e-5)


def test_table5_leg_lengths() -> None:
    """Seed 000 Table 5 prints 2.58 m (initial) and 3.234 m (working) to its precision."""
    np.testing.assert_allclose(STEWART.leg_lengths([0, 0, 1.525, 0, 0, 0]), 2.58, atol=5e-3)
    np.testing.assert_allclose(STEWART.leg_lengths([0, 0, 2.475, 0, 0, 0]), 3.234, atol=5e-4)


def test_manipulability_matches_spec() -> None:
    """sqrt(det(J_P J_Pᵀ)) at z = 2.625 m, level, is ≈ 44.90 (SPEC; seed 004 reports 44.51)."""
    assert STEWART.manipulability([0, 0, 2.625, 0, 0, 0]) == pytest.approx(44.90, abs=5e-3)


def test_hinges_follow_eqs_1_2() -> None:
    """Hinge pairs are d apart on circles of radius r (Table 1), with seed 000's angles."""
    for hinges, r, d in (
        (STEWART.layout.base_hinges, 2.65, 0.35),
        (STEWART.layout.platform_hinges, 1.95, 0.35),
    ):
        np.testing.assert_allclose(np.linalg.norm(hinges, axis=1), r)
        pairs = hinges.reshape(3, 2, 3) if hinges is STEWART.layout.platform_hinges else None
        if pairs is not None:
            np.testing.assert_allclose(np.linalg.norm(pairs[:, 0] - pairs[:, 1], axis=1), d)
    # base pairs are legs (6,1), (2,3), (4,5) in seed 000's numbering (SPEC erratum 1)
    b = STEWART.layout.base_hinges
    for i, j in ((5, 0), (1, 2), (3, 4)):
        assert np.linalg.norm(b[i] - b[j]) == pytest.approx(0.35)


def test_jacobian_equals_finite_difference(rng: np.random.Generator) -> None:
    """l̇ = J_P [v; ω] with v, ω in B (seed 000 eq (8)), by central differences."""
    poses = random_hybrid_states(rng, 20)[:, :6]
    for pose in poses:
        differences = length_rates_by_differences(STEWART.layout, pose_to_transform(pose))
        np.testing.assert_allclose(differences, STEWART.jacobian(pose), atol=1e-7)


def test_forward_inverts_inverse_on_random_poses(rng: np.random.Generator) -> None:
    """FK(IK(pose)) = pose to 1e-9 on 1000 random in-limit poses, from the default guess."""
    poses = random_hybrid_states(rng, 1000, shrink=0.9)[:, :6]
    recovered = STEWART.forward(STEWART.leg_lengths(poses))
    np.testing.assert_allclose(recovered, poses, atol=1e-9)


def test_forward_converges_in_a_handful_of_steps_from_nearby(rng: np.random.Generator) -> None:
    """From a guess 1 cm / 1° away, five Newton steps reach 1e-10 m."""
    poses = random_hybrid_states(rng, 200)[:, :6]
    guess = poses + rng.normal(0, [0.01] * 3 + [0.017] * 3, poses.shape)
    out = STEWART.forward(STEWART.leg_lengths(poses), guess, tol=1e-10, max_iter=5)
    np.testing.assert_allclose(STEWART.leg_lengths(out), STEWART.leg_lengths(poses), atol=1e-10)


def test_forward_raises_when_it_cannot_converge() -> None:
    """A far-off guess and two iterations give ConvergenceError, not a wrong answer."""
    lengths = STEWART.leg_lengths([0.3, -0.2, 3.0, 0.2, -0.1, 0.3])
    with pytest.raises(ConvergenceError, match="did not converge"):
        STEWART.forward(lengths, guess=[0, 0, 2.0, 0, 0, 0], max_iter=2)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: STEWART.leg_lengths([0, 0, 2.0]), r"shape \(\.\.\., 6\)"),
        (lambda: STEWART.leg_lengths([0, 0, np.nan, 0, 0, 0]), "finite"),
        (lambda: STEWART.forward([3.0] * 5 + [5.0]), r"allowed \[2.58, 4.18\]"),
        (lambda: STEWART.leg_lengths([0, 0, 5.0, 0, 0, 0], check=True), "allowed"),
        (lambda: STEWART.forward("abc"), "numeric"),
    ],
)
def test_bad_input_raises_value_error(call, match: str) -> None:
    """Wrong shape, NaN, lengths or poses beyond the stroke: a ValueError that says so."""
    with pytest.raises(ValueError, match=match):
        call()


def test_unreachable_is_a_twin_error() -> None:
    """UnreachableError is a TwinError, which is a ValueError (callers catch one class)."""
    assert issubclass(UnreachableError, TwinError) and issubclass(TwinError, ValueError)

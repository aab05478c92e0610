"""Seed 001's level-4 sea and the inputs of its Table 4 (twin.sea.presets)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from twin.errors import TwinError
from twin.mechanisms import Upu3Up
from twin.sea import evaluate_elevation, evaluate_slope, evaluate_surface, pierson_moskowitz_wind
from twin.sea.presets import (
    SEED001_DURATION,
    SEED001_TRAJECTORIES,
    seed001_inputs,
    seed001_sea,
    seed001_signals,
    seed001_trajectory,
)

U, G_PAPER, DOMEGA = 12.0, 9.8, 0.01  # [m/s], [m/s²], [rad/s] seed 001 §IV.C, eq (28)
T = np.arange(0.0, SEED001_DURATION + 0.025, 0.05)  # [s]


def test_grid_is_the_papers() -> None:
    """191 components at ω_i = 0.50, 0.51, … 2.40 rad/s, no jitter (seed 001 §IV.C)."""
    sea = seed001_sea()
    np.testing.assert_allclose(sea.omega, 0.5 + DOMEGA * np.arange(191), atol=1e-12)
    np.testing.assert_allclose(sea.direction, 0.0)


def test_record_repeats_after_628_s_not_within_500_s() -> None:
    """Equal Δω makes the record periodic with 2π/Δω = 628.3 s, longer than the 500 s run."""
    period = 2 * np.pi / DOMEGA
    assert period > SEED001_DURATION
    sea = seed001_sea(3)
    np.testing.assert_allclose(
        evaluate_elevation(sea, T + period), evaluate_elevation(sea, T), atol=1e-9
    )


def test_amplitudes_follow_eq_29() -> None:
    """A_i = sqrt(2 Δω S(ω_i)) with the wind form of eq (28), U = 12 m/s, g = 9.8."""
    sea = seed001_sea()
    s = 0.0081 * G_PAPER**2 / sea.omega**5 * np.exp(-0.74 * (G_PAPER / (U * sea.omega)) ** 4)
    np.testing.assert_allclose(sea.amplitude, np.sqrt(2 * DOMEGA * s), rtol=1e-12)


def test_significant_wave_height_is_the_wind_seas() -> None:
    """4·sqrt(m0) of the components ≈ 0.21 U²/g, less the 1.4 % of m0 outside the band."""
    sea = seed001_sea()
    hs = 4 * np.sqrt(np.sum(sea.amplitude**2) / 2)
    band_m0, _ = quad(lambda w: pierson_moskowitz_wind(w, U, g=G_PAPER), 0.495, 2.405)
    assert hs == pytest.approx(4 * np.sqrt(band_m0), rel=1e-4)  # midpoint rule, O(Δω²)
    assert hs == pytest.approx(0.21 * U**2 / G_PAPER, rel=0.02)
    assert hs == pytest.approx(3.053, abs=1e-3)


def test_same_seed_same_sea() -> None:
    """The seed fixes the phases; another seed gives another record."""
    np.testing.assert_array_equal(seed001_sea(7).phase, seed001_sea(7).phase)
    np.testing.assert_array_equal(seed001_inputs(T, 7)[0], seed001_inputs(T, 7)[0])
    assert not np.allclose(seed001_inputs(T, 7)[0], seed001_inputs(T, 8)[0])


def test_trajectories_are_table_4() -> None:
    """P5 (α, β), P6 (β, z), P7 (α, z), P8 (α, β, z), as printed in seed 001 Table 4."""
    printed = {"P5": {"α", "β"}, "P6": {"β", "z"}, "P7": {"α", "z"}, "P8": {"α", "β", "z"}}
    driven = {
        name: {s for s, on in zip("zαβ", row, strict=True) if on}
        for name, row in SEED001_TRAJECTORIES.items()
    }
    assert driven == printed


@pytest.mark.parametrize("trajectory", sorted(SEED001_TRAJECTORIES))
def test_inputs_match_an_independent_evaluation(trajectory: str) -> None:
    """z = 0.05 A(t) [m → mm], α, β = a(t) or 0, against eqs (29)-(30) summed here directly.

    A(t) = Σ A_i cos(ε_i − ω_i t) and a(t) = ∂η/∂x = −Σ (ω_i²/g) A_i sin(ε_i − ω_i t) at the
    origin, with the paper's g = 9.8; the preset's slope uses g = 9.80665 (0.07 % apart).
    """
    t = T[::7]
    sea = seed001_sea(2)
    theta = sea.phase - np.outer(t, sea.omega)
    heave = 1e3 * 0.05 * np.cos(theta) @ sea.amplitude  # [mm]
    slope = -np.sin(theta) @ (sea.omega**2 / G_PAPER * sea.amplitude)  # [m/m] = [rad]
    z, alpha, beta = seed001_inputs(t, 2, trajectory)
    row = SEED001_TRAJECTORIES[trajectory]
    np.testing.assert_allclose(z, heave if row.z else 0.0, atol=1e-9)
    for got, on in ((alpha, row.alpha), (beta, row.beta)):
        np.testing.assert_allclose(got, slope if on else 0.0, atol=1e-3 * np.abs(slope).max())


def test_outputs_are_independent_arrays() -> None:
    """α and β share a(t) but are separate arrays, so editing one leaves the other."""
    _, alpha, beta = seed001_inputs(T[:10])
    alpha[:] = 0.0
    assert np.any(beta != 0.0)


@pytest.mark.parametrize("seed", range(5))
def test_stays_inside_the_3upu_up_state_limits(seed: int) -> None:
    """P8 over 500 s stays within Upu3Up.state_limits (docs/mechanisms/upu3up.md)."""
    low, high = Upu3Up().state_limits
    state = np.stack(seed001_inputs(T, seed), axis=-1)
    assert np.all((state >= low) & (state <= high))


def test_unknown_trajectory_is_refused() -> None:
    """An unknown trajectory name raises, naming the allowed ones."""
    with pytest.raises(TwinError, match=r"\['P5', 'P6', 'P7', 'P8'\]"):
        seed001_inputs(T, trajectory="P1")


def test_one_sea_serves_every_trajectory_bit_for_bit() -> None:
    """`evaluate_surface` is `evaluate_elevation` and `evaluate_slope` in one pass, to the bit;
    the trajectories built from one seed's signals are `seed001_inputs`' own; an unknown name
    is refused by either path."""
    sea = seed001_sea(4)
    heave, slope = evaluate_surface(sea, T[:500])
    np.testing.assert_array_equal(heave, evaluate_elevation(sea, T[:500]))
    np.testing.assert_array_equal(slope, evaluate_slope(sea, T[:500]))
    signals = seed001_signals(T, 4)
    for name in SEED001_TRAJECTORIES:
        for got, want in zip(seed001_trajectory(signals, name), seed001_inputs(T, 4, name),
                             strict=True):  # fmt: skip
            np.testing.assert_array_equal(got, want)
    with pytest.raises(TwinError, match="P5"):
        seed001_trajectory(signals, "P1")

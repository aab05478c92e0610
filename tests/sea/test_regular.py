"""Regular-wave presets: seed 002 Table 2's three wave states."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import TwinError
from twin.sea import G
from twin.sea.regular import REGULAR_PRESETS, regular_components
from twin.sea.synthesis import evaluate_elevation

# seed 002 Table 2: amplitude [m], period [s], direction [x, y] of each wave
TABLE_2 = {
    "state1": ([0.2], [3.0], [[1, 1]]),
    "state2": ([0.2, 0.3], [5.0, 3.0], [[1, 0], [0, 1]]),
    "state3": ([0.2, 0.3, 0.4], [7.0, 5.0, 3.0], [[1, 0], [0, 1], [1, 1]]),
}


@pytest.mark.parametrize("state", TABLE_2)
def test_presets_match_table_2(state: str) -> None:
    """The regular-wave presets have Table 2's number of waves, amplitudes, periods and
    directions."""
    amplitude, period, direction = TABLE_2[state]
    preset = REGULAR_PRESETS[state]
    assert preset.omega.size == len(amplitude)  # "Number of Waves"
    np.testing.assert_allclose(preset.amplitude, amplitude)
    np.testing.assert_allclose(2 * np.pi / preset.omega, period)
    unit = np.asarray(direction) / np.linalg.norm(direction, axis=1, keepdims=True)
    np.testing.assert_allclose(
        np.c_[np.cos(preset.direction), np.sin(preset.direction)], unit, atol=1e-15
    )


def test_presets_are_read_only() -> None:
    """The regular-wave preset mapping cannot be assigned to."""
    with pytest.raises(TypeError):
        REGULAR_PRESETS["state4"] = REGULAR_PRESETS["state1"]  # type: ignore[index]


def test_state1_is_one_cosine_through_the_origin() -> None:
    """Zero phase: η(0, 0, t) = 0.2 cos(2π t / 3)."""
    t = np.linspace(0.0, 9.0, 91)
    np.testing.assert_allclose(
        evaluate_elevation(REGULAR_PRESETS["state1"], t),
        0.2 * np.cos(2 * np.pi * t / 3.0),
        atol=1e-15,
    )


def test_wave_repeats_one_deep_water_wavelength_downwave() -> None:
    """λ = gT²/2π along the travel direction [1, 1]: η(x + λ d̂, t) = η(x, t)."""
    wave = REGULAR_PRESETS["state1"]
    wavelength = G * 3.0**2 / (2 * np.pi)
    t = np.linspace(0.0, 3.0, 13)
    shift = wavelength / np.sqrt(2)
    np.testing.assert_allclose(
        evaluate_elevation(wave, t, 1.0 + shift, 2.0 + shift),
        evaluate_elevation(wave, t, 1.0, 2.0),
        atol=1e-12,
    )
    crest_moves = evaluate_elevation(
        wave, 0.75, shift / 4, shift / 4
    )  # quarter period later, quarter λ on
    assert crest_moves == pytest.approx(0.2)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (([0.2], [3.0], [[0, 0]]), "non-zero"),
        (([0.2], [3.0], [[1, 0, 0]]), "non-zero"),
        (([0.2, 0.3], [3.0, 4.0, 5.0], [[1, 0]]), "lengths differ"),
        (([0.2], [0.0], [[1, 0]]), r"period .*\(0, inf\] s"),
        (([-0.2], [3.0], [[1, 0]]), r"amplitude .*\[0, inf\] m"),
        (([0.2], [np.nan], [[1, 0]]), r"period must be finite"),
    ],
)
def test_bad_regular_waves_raise(args: tuple, message: str) -> None:
    """Bad regular-wave arguments raise TwinError with a message naming the problem."""
    with pytest.raises(TwinError, match=message):
        regular_components(*args)

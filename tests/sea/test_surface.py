"""Ocean surface on a grid: heights and Gerstner points for the 3D scene."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import TwinError
from twin.sea import WaveComponents
from twin.sea.surface import gerstner_points, surface_heights
from twin.sea.synthesis import evaluate_elevation, wave_components

SEA = wave_components(2.0, 8.0, heading=0.4, spreading=8.0, seed=3)
X = np.linspace(-60.0, 60.0, 41)
Y = np.linspace(-30.0, 50.0, 27)


def test_grid_heights_equal_pointwise_elevation() -> None:
    """heights[..., p, q] = η(x[p], y[q], t) ("ij" indexing), for a batch of times."""
    t = np.array([[0.0, 1.5, 7.25]])
    grid_x, grid_y = np.meshgrid(X, Y, indexing="ij")
    heights = surface_heights(SEA, X, Y, t)
    assert heights.shape == (1, 3, 41, 27)
    for j, tj in enumerate(t[0]):
        np.testing.assert_allclose(
            heights[0, j], evaluate_elevation(SEA, tj, grid_x, grid_y), atol=1e-12
        )


def test_gerstner_without_steepness_is_the_height_field() -> None:
    """Gerstner points with zero steepness stay on the grid and have the surface heights as z."""
    points = gerstner_points(SEA, X, Y, 2.0, steepness=0.0)
    grid_x, grid_y = np.meshgrid(X, Y, indexing="ij")
    np.testing.assert_array_equal(points[..., 0], grid_x)
    np.testing.assert_array_equal(points[..., 1], grid_y)
    np.testing.assert_allclose(points[..., 2], surface_heights(SEA, X, Y, 2.0), atol=1e-12)


def test_gerstner_particles_move_on_circles_of_radius_a() -> None:
    """Q = 1, one deep-water component: each surface particle orbits a circle of radius a,
    clockwise seen with the wave travelling to the right (forward at the crest)."""
    a, mu = 0.5, 0.3
    wave = WaveComponents([0.9], [a], [0.0], [mu])
    t = np.linspace(0.0, 2 * np.pi / 0.9, 64)
    points = gerstner_points(wave, [4.0], [-2.0], t)[:, 0, 0]  # (64, 3)
    along = (points[:, 0] - 4.0) * np.cos(mu) + (points[:, 1] + 2.0) * np.sin(mu)
    across = -(points[:, 0] - 4.0) * np.sin(mu) + (points[:, 1] + 2.0) * np.cos(mu)
    np.testing.assert_allclose(np.hypot(along, points[:, 2]), a, rtol=1e-12)
    np.testing.assert_allclose(across, 0.0, atol=1e-12)
    crest = np.argmax(points[:, 2])
    assert along[(crest + 1) % 64] > along[crest - 1]  # moving down-wave at the crest


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: surface_heights(SEA, np.zeros((2, 2)), Y, 0.0), "x must be a 1-D array"),
        (lambda: surface_heights(SEA, X, [0.0, np.nan], 0.0), "y must be finite"),
        (lambda: surface_heights(SEA, X, Y, np.inf), "t must be finite"),
        (lambda: gerstner_points(SEA, X, Y, 0.0, steepness=1.5), r"steepness .*\[0, 1\]"),
    ],
)
def test_bad_grid_raises(call, message: str) -> None:
    """A bad grid or time raises TwinError with a message naming the problem."""
    with pytest.raises(TwinError, match=message):
        call()

"""Hull parameter sets and their wetted-surface panels (twin/vessel/hulls.py)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import TwinError
from twin.vessel import HULLS, displaced_volume, get_hull, load_raos, wetted_surface
from twin.vessel.hulls import panel_geometry


def test_box_displaces_its_block() -> None:
    """A box hull displaces exactly L·B·T."""
    hull = HULLS["barge"]
    volume = displaced_volume(*wetted_surface(hull, 2.0))
    assert volume == pytest.approx(hull.length * hull.beam * hull.draft, rel=1e-12)


def test_twin_floats_displace_two_circular_segments() -> None:
    """Two r = 0.213 m floats at T = 0.10 m: the polygonal arc is within 2 % of the circle."""
    hull = HULLS["asv"]
    r, T = hull.beam / 2, hull.draft
    segment = r**2 * np.arccos((r - T) / r) - (r - T) * np.sqrt(2 * r * T - T**2)
    volume = displaced_volume(*wetted_surface(hull, 0.12))
    assert volume == pytest.approx(2 * hull.length * segment, rel=0.02)
    assert volume < 2 * hull.length * segment  # chords lie inside the arc


def test_wigley_block_coefficient() -> None:
    """The modified Wigley form I has Cb ≈ 0.561 (Journée 1992)."""
    hull = HULLS["sov"]
    volume = displaced_volume(*wetted_surface(hull, 0.5))
    assert volume / (hull.length * hull.beam * hull.draft) == pytest.approx(0.561, abs=0.005)


@pytest.mark.parametrize("name", sorted(HULLS))
def test_normals_point_into_the_water(name: str) -> None:
    """Wetted surface plus waterplane is closed: Σ n dA over the hull = −A_wp ẑ."""
    hull = HULLS[name]
    vertices, faces = wetted_surface(hull, hull.length / 40)
    area_vector, _ = panel_geometry(vertices, faces)
    waterline = vertices[np.isclose(vertices[:, 2], 0.0)]
    if hull.shape == "twin_cylinder":
        r, T = hull.beam / 2, hull.draft
        waterplane = 2 * hull.length * 2 * np.sqrt(r**2 - (r - T) ** 2)
    elif hull.shape == "box":
        waterplane = hull.length * hull.beam
    else:  # Wigley waterline (1 - ξ²)(1 + 0.2 ξ²): A_wp = L B (2/3 + 0.2 · 2/15)
        waterplane = hull.length * hull.beam * (2 / 3 + 0.2 * 2 / 15)
    assert waterline.size > 0
    total = area_vector.sum(axis=0)
    np.testing.assert_allclose(total[:2], 0.0, atol=1e-9 * waterplane)
    assert -total[2] == pytest.approx(waterplane, rel=0.01)


def test_unknown_hull_lists_the_known_ones() -> None:
    """A typo raises TwinError naming the valid hulls."""
    with pytest.raises(TwinError, match=r"unknown hull 'sovv'.*asv.*barge.*sov"):
        get_hull("sovv")


def test_bad_panel_size_is_refused() -> None:
    """panel_size ≤ 0 raises TwinError."""
    with pytest.raises(TwinError, match="panel_size"):
        wetted_surface(HULLS["sov"], 0.0)


@pytest.mark.parametrize("name", sorted(HULLS))
def test_shipped_table_matches_hull_parameters(name: str) -> None:
    """assets/vessels/NAME.nc was computed from today's parameters (re-run the script if not)."""
    hull, attrs = HULLS[name], load_raos(name).attrs
    assert [attrs["length_m"], attrs["beam_m"], attrs["draft_m"], attrs["hull_spacing_m"]] == [
        hull.length,
        hull.beam,
        hull.draft,
        hull.hull_spacing,
    ]
    assert attrs["center_of_gravity_m"][2] == hull.z_g
    np.testing.assert_array_equal(attrs["radii_of_gyration_m"], hull.radii_of_gyration)
    assert attrs["roll_damping_ratio"] == hull.roll_damping_ratio

"""RAO tables: layout, validation, interpolation and physics of the shipped tables."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from twin.errors import TwinError
from twin.vessel import (
    DOFS,
    RaoTable,
    available_raos,
    interpolate_raos,
    load_raos,
    raos_to_dataset,
    write_raos,
)
from twin.vessel.frames import POSE_SIGNS

SHIPPED = ("asv", "barge", "sov")
SWAY, HEAVE, ROLL, YAW = (DOFS.index(d) for d in ("sway", "heave", "roll", "yaw"))


def small_table() -> RaoTable:
    """A random table with three frequencies and four directions."""
    rng = np.random.default_rng(1)
    values = rng.normal(size=(3, 4, 6)) + 1j * rng.normal(size=(3, 4, 6))
    return RaoTable("small", [0.5, 1.0, 2.0], np.radians([0, 90, 180, 270]), values)


def test_shipped_tables_are_listed_and_load() -> None:
    """Every hull has a committed table with the six DOFs on a full circle of directions."""
    assert set(SHIPPED) <= set(available_raos())
    for name in SHIPPED:
        raos = load_raos(name)
        assert raos.values.shape == (raos.omega.size, 24, 6)
        np.testing.assert_allclose(np.diff(raos.wave_direction), np.radians(15))


def test_interpolation_is_exact_at_the_nodes() -> None:
    """At tabulated (ω, β) the interpolant returns the table."""
    raos = small_table()
    W, B = np.meshgrid(raos.omega, raos.wave_direction, indexing="ij")
    np.testing.assert_allclose(interpolate_raos(raos, W, B), raos.values, atol=1e-14)


def test_interpolation_is_periodic_in_direction() -> None:
    """β and β + 2π agree, and the value is continuous across 2π → 0."""
    raos = small_table()
    beta = np.linspace(-7.0, 7.0, 57)
    np.testing.assert_allclose(
        interpolate_raos(raos, 1.3, beta), interpolate_raos(raos, 1.3, beta + 2 * np.pi), atol=1e-12
    )
    np.testing.assert_allclose(
        interpolate_raos(raos, 1.0, 2 * np.pi - 1e-9), raos.values[1, 0], atol=1e-8
    )


def test_interpolation_is_linear_in_real_and_imaginary_parts() -> None:
    """Mid-way between two frequencies the RAO is the mean of the two complex values."""
    raos = small_table()
    mid = interpolate_raos(raos, 0.75, np.pi / 2)
    np.testing.assert_allclose(mid, (raos.values[0, 1] + raos.values[1, 1]) / 2)


def test_outside_the_frequency_range() -> None:
    """Below ω_min the first row is used; above ω_max the RAO is zero."""
    raos = small_table()
    np.testing.assert_allclose(interpolate_raos(raos, 0.01, 0.0), raos.values[0, 0])
    np.testing.assert_array_equal(interpolate_raos(raos, 2.01, 0.0), 0.0)


@pytest.mark.parametrize("name", SHIPPED)
def test_heave_follows_long_waves(name: str) -> None:
    """Heave RAO → 1 as ω → 0 from every direction: the hull rides long waves."""
    raos = load_raos(name)
    np.testing.assert_allclose(np.abs(raos.values[0, :, HEAVE]), 1.0, atol=0.01)


@pytest.mark.parametrize("name", ["sov", "barge"])
def test_heave_vanishes_for_short_waves(name: str) -> None:
    """Waves shorter than the beam (λ = 2πg/ω² < B) heave the hull < 5 % of their amplitude."""
    raos = load_raos(name)
    assert 2 * np.pi * 9.81 / raos.omega[-1] ** 2 < raos.attrs["beam_m"]
    assert np.abs(raos.values[-1, :, HEAVE]).max() < 0.05


@pytest.mark.parametrize("name", SHIPPED)
def test_head_and_following_seas_excite_no_lateral_motion(name: str) -> None:
    """Port-starboard symmetry: sway, roll and yaw vanish for β = 0 and π."""
    raos = load_raos(name)
    for beta in (0.0, np.pi):
        j = int(np.argmin(np.abs(raos.wave_direction - beta)))
        lateral = np.abs(raos.values[:, j][:, [SWAY, ROLL, YAW]])
        scale = np.abs(raos.values[..., [SWAY, ROLL, YAW]]).max(axis=(0, 1))
        assert np.all(lateral <= 1e-6 * scale)


@pytest.mark.parametrize("name", ["sov", "barge"])
def test_roll_peaks_at_its_natural_frequency(name: str) -> None:
    """Beam-sea roll peaks within 5 % of ω_n = sqrt(C44 / (M44 + A44)) from the hydrostatics."""
    raos = load_raos(name)
    j = int(np.argmin(np.abs(raos.wave_direction - np.pi / 2)))
    peak = raos.omega[np.argmax(np.abs(raos.values[:, j, ROLL]))]
    assert peak == pytest.approx(raos.attrs["roll_natural_frequency_rad_s"], rel=0.05)


@pytest.mark.parametrize("name", SHIPPED)
def test_tables_are_dense_enough_for_linear_interpolation(name: str) -> None:
    """Below 3 rad/s, neighbouring frequencies differ < 30° in phase where |H| > 10 % of max."""
    raos = load_raos(name)
    v = raos.values[raos.omega <= 3.0]
    amplitude = np.abs(v)
    significant = np.minimum(amplitude[1:], amplitude[:-1]) > 0.1 * amplitude.max(axis=(0, 1))
    step = np.abs(np.angle(v[1:] * np.conj(v[:-1])))
    assert np.degrees(step[significant]).max() < 30.0


def test_write_then_load_round_trips(tmp_path: Path) -> None:
    """A table written in the file layout reads back equal."""
    raos = small_table()
    write_raos(raos, tmp_path / "mine.nc")
    back = load_raos(tmp_path / "mine.nc")
    assert back.name == "mine"
    np.testing.assert_array_equal(back.values, raos.values)
    np.testing.assert_array_equal(back.wave_direction, raos.wave_direction)


def test_z_down_file_in_degrees_is_converted(tmp_path: Path) -> None:
    """A file in x bow, y starboard, z down with β in degrees loads as the z-up table."""
    raos = small_table()
    ds = raos_to_dataset(raos)
    ds = ds.assign_coords(wave_direction=np.degrees(np.mod(-raos.wave_direction, 2 * np.pi)))
    ds["wave_direction"].attrs["units"] = "deg"
    ds["rao_real"] = ds["rao_real"] * POSE_SIGNS
    ds["rao_imag"] = ds["rao_imag"] * POSE_SIGNS
    ds = ds.sortby("wave_direction").sel(dof=list(DOFS[::-1]))  # any order is accepted
    ds.attrs["frame"] = "z_down"
    ds.to_netcdf(tmp_path / "zdown.nc", engine="scipy")
    back = load_raos(tmp_path / "zdown.nc")
    np.testing.assert_allclose(back.wave_direction, raos.wave_direction, atol=1e-12)
    np.testing.assert_allclose(back.values, raos.values)


def _write(ds: xr.Dataset, path: Path) -> Path:
    ds.to_netcdf(path, engine="scipy")
    return path


def test_unknown_vessel_name_lists_the_shipped_ones() -> None:
    """A name that is no shipped table raises TwinError listing the tables."""
    with pytest.raises(TwinError, match=r"unknown vessel 'ferry'.*\['asv', 'barge', 'sov'\]"):
        load_raos("ferry")


def test_missing_file_is_reported(tmp_path: Path) -> None:
    """A path that does not exist raises TwinError naming it."""
    with pytest.raises(TwinError, match=r"not found.*nope\.nc"):
        load_raos(tmp_path / "nope.nc")


def test_file_that_is_not_netcdf_is_refused(tmp_path: Path) -> None:
    """Garbage bytes raise TwinError, not a backend exception."""
    (tmp_path / "junk.nc").write_bytes(b"definitely not netcdf")
    with pytest.raises(TwinError, match="cannot read RAO file"):
        load_raos(tmp_path / "junk.nc")


def test_missing_variable_is_named(tmp_path: Path) -> None:
    """A file without rao_imag is refused, naming the variable."""
    path = _write(raos_to_dataset(small_table()).drop_vars("rao_imag"), tmp_path / "a.nc")
    with pytest.raises(TwinError, match=r"missing variable\(s\) \['rao_imag'\]"):
        load_raos(path)


def test_missing_dof_is_named(tmp_path: Path) -> None:
    """A file without yaw is refused, naming the DOF."""
    path = _write(raos_to_dataset(small_table()).isel(dof=slice(0, 5)), tmp_path / "b.nc")
    with pytest.raises(TwinError, match=r"missing DOF\(s\) \['yaw'\]"):
        load_raos(path)


def test_non_monotonic_frequency_axis_is_refused(tmp_path: Path) -> None:
    """Frequencies out of order are refused."""
    ds = raos_to_dataset(small_table())
    path = _write(ds.isel(omega=[0, 2, 1]), tmp_path / "c.nc")
    with pytest.raises(TwinError, match="omega must be > 0 rad/s and strictly increasing"):
        load_raos(path)


def test_nan_is_refused(tmp_path: Path) -> None:
    """A NaN in the RAO is refused, with a count."""
    ds = raos_to_dataset(small_table())
    ds["rao_real"][1, 2, 3] = np.nan
    with pytest.raises(TwinError, match="RAO has 1 NaN/inf entries"):
        load_raos(_write(ds, tmp_path / "d.nc"))


def test_in_memory_table_is_validated() -> None:
    """A values array of the wrong shape raises TwinError with the expected shape."""
    with pytest.raises(TwinError, match=r"values must have shape .* \(2, 1, 6\)"):
        RaoTable("bad", [0.5, 1.0], [0.0], np.zeros((2, 1, 5)))

r"""Response amplitude operator (RAO) tables: read, validate, interpolate, write.

A table holds the complex RAO :math:`H_j(\omega, \beta)` of the six rigid-body motions
(surge, sway, heave, roll, pitch, yaw) of the centre of motion, per unit wave amplitude, in
the z-up vessel frame (x bow, y port, z up). β is the direction the waves travel *towards*,
measured from the bow counter-clockwise seen from above: 0 following seas, π/2 waves running
to port (beam seas from starboard), π head seas. The phase follows Capytaine: a wave whose
elevation at the centre of motion is :math:`\Re(\hat\zeta e^{-i\omega t})` moves the vessel by
:math:`x_j(t) = \Re(H_j \hat\zeta e^{-i\omega t})`, so arg H is a phase lag.

On disk (NetCDF, one file per vessel, docs/vessel.md "RAO file layout"): dimensions
`omega` [rad/s], `wave_direction` [rad] and `dof` (the six names), and two float variables
`rao_real` and `rao_imag` of dims (omega, wave_direction, dof). NetCDF has no complex type;
the two real variables keep the file readable by any NetCDF tool.

Interpolation is linear in the real and imaginary parts (bilinear in ω and β, β periodic):
it is linear in the data, exact at the nodes and well defined where |H| crosses zero, which
amplitude/phase interpolation is not (the phase jumps there and must be unwrapped in two
directions). Its cost is an amplitude dip between nodes whose phases differ by Δφ (factor
cos(Δφ/2) at mid-interval), so the tables are tabulated densely enough that neighbouring
nodes differ by less than 30° wherever the response matters (tests/vessel/test_rao.py).
Below the first frequency the first row is used (long waves: the vessel follows the wave);
above the last one the RAO is zero (the hull filters out waves much shorter than itself).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from twin.assets import asset_path
from twin.errors import TwinError
from twin.vessel.frames import POSE_SIGNS, direction_from_z_down

DOFS = ("surge", "sway", "heave", "roll", "pitch", "yaw")
UNITS = "m/m for surge, sway, heave; rad/m for roll, pitch, yaw"
VESSELS_DIR = ("vessels",)  # under assets/


@dataclass(frozen=True)
class RaoTable:
    """A validated RAO table; build one with `load_raos` or from arrays.

    Attributes:
        name: vessel name.
        omega: (n_ω,) [rad/s] wave frequencies, > 0, strictly increasing, n_ω ≥ 2.
        wave_direction: (n_β,) [rad] directions in [0, 2π), strictly increasing.
        values: (n_ω, n_β, 6) complex RAO [m/m, rad/m], DOFs in `DOFS` order.
        attrs: metadata (hull, solver, damping), carried to and from the file.
    """

    name: str
    omega: np.ndarray
    wave_direction: np.ndarray
    values: np.ndarray
    attrs: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        omega = np.asarray(self.omega, dtype=float)
        direction = np.asarray(self.wave_direction, dtype=float)
        values = np.asarray(self.values, dtype=complex)
        where = f"RAO table {self.name!r}"
        if omega.ndim != 1 or omega.size < 2:
            raise TwinError(f"{where}: omega must be 1-D with ≥ 2 frequencies, got {omega.shape}")
        if direction.ndim != 1 or direction.size < 1:
            raise TwinError(f"{where}: wave_direction must be 1-D and non-empty")
        if values.shape != (omega.size, direction.size, len(DOFS)):
            raise TwinError(
                f"{where}: values must have shape (omega, wave_direction, dof) = "
                f"{(omega.size, direction.size, len(DOFS))}, got {values.shape}"
            )
        for label, array in (("omega", omega), ("wave_direction", direction), ("RAO", values)):
            bad = ~np.isfinite(array)
            if np.any(bad):
                raise TwinError(f"{where}: {label} has {np.count_nonzero(bad)} NaN/inf entries")
        if omega[0] <= 0 or np.any(np.diff(omega) <= 0):
            raise TwinError(f"{where}: omega must be > 0 rad/s and strictly increasing")
        if direction[0] < 0 or direction[-1] >= 2 * np.pi or np.any(np.diff(direction) <= 0):
            raise TwinError(
                f"{where}: wave_direction must be strictly increasing within [0, 2π) rad "
                "(drop a 360° column: it repeats 0°)"
            )
        object.__setattr__(self, "omega", omega)
        object.__setattr__(self, "wave_direction", direction)
        object.__setattr__(self, "values", values)

    def __repr__(self) -> str:
        return (
            f"RaoTable({self.name!r}, omega {self.omega[0]:g}..{self.omega[-1]:g} rad/s "
            f"({self.omega.size}), {self.wave_direction.size} wave directions)"
        )


def available_raos() -> list[str]:
    """Names of the RAO tables shipped in assets/vessels/."""
    return sorted(p.stem for p in asset_path(*VESSELS_DIR).glob("*.nc"))


def _resolve(path_or_name: str | os.PathLike) -> tuple[Path, str]:
    path = Path(path_or_name)
    if path.is_file():
        return path, path.stem
    if isinstance(path_or_name, str) and path.suffix == "" and len(path.parts) == 1:
        known = available_raos()
        if path_or_name not in known:
            raise TwinError(f"unknown vessel {path_or_name!r}, shipped RAO tables: {known}")
        return asset_path(*VESSELS_DIR, f"{path_or_name}.nc"), path_or_name
    raise TwinError(f"RAO file not found: {path}")


def raos_from_dataset(ds: xr.Dataset, name: str) -> RaoTable:
    """Check the layout of `ds` (module docstring) and build the table.

    Accepts DOF names in any order and case, `wave_direction` in rad or deg (its `units`
    attribute), and a z-down file (global attribute `frame = "z_down"`: x bow, y starboard,
    z down), converted here through `twin.vessel.frames`.

    Raises:
        TwinError: a missing variable, dimension or DOF, a NaN, or a non-monotonic axis.
    """
    where = f"RAO file {name!r}"
    missing = [v for v in ("rao_real", "rao_imag") if v not in ds.data_vars]
    if missing:
        raise TwinError(f"{where}: missing variable(s) {missing}; expected rao_real, rao_imag")
    dims = ("omega", "wave_direction", "dof")
    for var in ("rao_real", "rao_imag"):
        if set(ds[var].dims) != set(dims):
            raise TwinError(f"{where}: {var} must have dims {dims}, got {ds[var].dims}")
    dof_names = [str(d).lower() for d in ds["dof"].values]
    absent = [d for d in DOFS if d not in dof_names]
    if absent:
        raise TwinError(f"{where}: missing DOF(s) {absent}; the file must hold all of {DOFS}")
    ds = ds.assign_coords(dof=dof_names).sel(dof=list(DOFS))
    values = (ds["rao_real"] + 1j * ds["rao_imag"]).transpose(*dims).values

    direction = ds["wave_direction"].values.astype(float)
    units = str(ds["wave_direction"].attrs.get("units", "rad")).lower()
    if units in ("deg", "degree", "degrees"):
        direction = np.radians(direction)
    elif units not in ("rad", "radian", "radians"):
        raise TwinError(f"{where}: wave_direction units must be rad or deg, got {units!r}")

    frame = str(ds.attrs.get("frame", "z_up"))
    if frame == "z_down":
        direction = direction_from_z_down(direction)
        values = values * POSE_SIGNS
    elif frame != "z_up":
        raise TwinError(f"{where}: attribute frame must be 'z_up' or 'z_down', got {frame!r}")
    order = np.argsort(direction)  # a z-down file reverses the direction axis
    return RaoTable(
        name=name,
        omega=ds["omega"].values,
        wave_direction=direction[order],
        values=values[:, order],
        attrs={k: v for k, v in ds.attrs.items() if k != "frame"},
    )


def load_raos(path_or_name: str | os.PathLike) -> RaoTable:
    """Read an RAO table: a shipped vessel name (`available_raos()`) or a NetCDF file path.

    Raises:
        TwinError: unknown name, missing or unreadable file, or a malformed layout.
    """
    path, name = _resolve(path_or_name)
    try:
        ds = xr.load_dataset(path, engine="scipy")  # NETCDF3, as raos_to_dataset writes
    except (OSError, ValueError, TypeError) as exc:  # scipy's reader: TypeError on non-NetCDF
        raise TwinError(f"cannot read RAO file {path}: {exc}") from exc
    return raos_from_dataset(ds, name)


def raos_to_dataset(raos: RaoTable) -> xr.Dataset:
    """The on-disk layout of `raos` (module docstring), z-up frame, β in rad."""
    dims = ("omega", "wave_direction", "dof")
    ds = xr.Dataset(
        {
            "rao_real": (dims, raos.values.real, {"units": UNITS}),
            "rao_imag": (dims, raos.values.imag, {"units": UNITS}),
        },
        coords={
            "omega": ("omega", raos.omega, {"units": "rad/s"}),
            "wave_direction": (
                "wave_direction",
                raos.wave_direction,
                {"units": "rad", "long_name": "direction waves travel to, from bow to port"},
            ),
            "dof": ("dof", list(DOFS)),
        },
        attrs=dict(raos.attrs),
    )
    ds.attrs["frame"] = "z_up"
    return ds


def write_raos(raos: RaoTable, path: str | os.PathLike) -> None:
    """Write `raos` as NetCDF-3 (scipy engine: no HDF5 library needed), real/imag layout."""
    raos_to_dataset(raos).to_netcdf(path, engine="scipy", format="NETCDF3_64BIT")


def interpolate_raos(raos: RaoTable, omega: ArrayLike, wave_direction: ArrayLike) -> np.ndarray:
    """Complex RAO at frequencies `omega` [rad/s] and directions `wave_direction` [rad].

    Bilinear in the real and imaginary parts; β periodic; ω clamped to the first row below the
    table and zero above it (module docstring).

    Args:
        raos: the table.
        omega: (...) [rad/s] frequencies ≥ 0.
        wave_direction: (...) [rad] any angle, broadcast against `omega`.

    Returns:
        (..., 6) complex [m/m, rad/m], DOFs in `DOFS` order.
    """
    omega, beta = np.broadcast_arrays(
        np.asarray(omega, dtype=float), np.mod(np.asarray(wave_direction, dtype=float), 2 * np.pi)
    )
    w_axis = raos.omega
    i = np.clip(np.searchsorted(w_axis, omega, side="right") - 1, 0, w_axis.size - 2)
    wi = np.clip((omega - w_axis[i]) / (w_axis[i + 1] - w_axis[i]), 0.0, 1.0)[..., None]

    # Periodic axis: one wrapped column each side puts every β ∈ [0, 2π) inside it.
    b = raos.wave_direction
    b_axis = np.r_[b[-1] - 2 * np.pi, b, b[0] + 2 * np.pi]
    table = np.concatenate([raos.values[:, -1:], raos.values, raos.values[:, :1]], axis=1)
    j = np.clip(np.searchsorted(b_axis, beta, side="right") - 1, 0, b_axis.size - 2)
    wj = ((beta - b_axis[j]) / (b_axis[j + 1] - b_axis[j]))[..., None]

    value = (1 - wi) * ((1 - wj) * table[i, j] + wj * table[i, j + 1]) + wi * (
        (1 - wj) * table[i + 1, j] + wj * table[i + 1, j + 1]
    )
    return np.where((omega <= w_axis[-1])[..., None], value, 0.0)

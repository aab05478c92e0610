"""Compute the RAO tables of the shipped hulls with Capytaine.

Meshes each hull of `twin.vessel.HULLS` from its parameters, solves the radiation and
diffraction problems (linear potential flow, deep water) over a frequency × wave-direction
grid, adds a linear viscous roll damping, solves the equation of motion and writes
`assets/vessels/NAME.nc` in the layout `twin.vessel.load_raos` reads (docs/vessel.md).

**Features**
- Panels from `twin.vessel.wetted_surface`, solved on a quarter mesh with the hulls' two
  reflection symmetries, plus a waterplane lid where irregular frequencies fall in the band.
- Diffraction solved for β = 0..180°, mirrored to 195..345° (hulls symmetric port-starboard).
- Hydrostatics from Capytaine; inertia from each hull's stated mass distribution.
- `--plot PATH`: our box-barge heave and pitch RAOs against netsse's closed forms
  (Jensen, Mansour & Olsen 2004); needs matplotlib and netsse, not Capytaine.

The solve itself is `twin.vessel.bem` (also used by tests/vessel/test_capytaine_fresh.py).
Needs the `hydro` extra (capytaine, threadpoolctl) and the package importable, e.g.
`pip install -e .[hydro]`:

    python scripts/compute_raos.py                       # all hulls → assets/vessels/
    python scripts/compute_raos.py --hull asv --out /tmp
    python scripts/compute_raos.py --hull --plot docs/vessel_rao_netsse.png   # plot only
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from twin.assets import asset_path
from twin.vessel import DOFS, HULLS, RaoTable, load_raos, write_raos
from twin.vessel.bem import GRIDS, solve_hull


def summary(table: RaoTable) -> str:
    """One line on the solve: panels, grid, time, mass, GM_T and roll natural frequency."""
    a = table.attrs
    w_n = a["roll_natural_frequency_rad_s"]
    return (
        f"{table.name}: {a['panels_hull']} hull + {a['panels_lid']} lid panels, "
        f"{table.omega.size} ω × {table.wave_direction.size} β solved in "
        f"{a['solve_seconds']:.1f} s ({a['solve_cpu_seconds']:.1f} s CPU); "
        f"m = {a['mass_kg'] / 1e3:.3f} t, GM_T = {a['gm_t_m']:.2f} m, "
        f"roll ω_n = {w_n:.3f} rad/s (T = {2 * np.pi / w_n:.2f} s)"
    )


def plot_netsse_check(path: Path) -> None:
    """Box-barge heave and pitch |RAO| in head seas: ours (Capytaine) against netsse."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from netsse.model.ship import heaveCF, pitchCF

    raos = load_raos("barge")
    hull = HULLS["barge"]
    head = int(np.argmin(np.abs(raos.wave_direction - np.pi)))
    args = (raos.omega, np.array([180.0]), 0.0, hull.length, hull.beam, hull.draft)
    peers = {"heave": heaveCF(*args)[:, 0], "pitch": pitchCF(*args)[:, 0]}
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for ax, dof, unit in zip(axes, ("heave", "pitch"), ("m/m", "rad/m"), strict=True):
        ours = np.abs(raos.values[:, head, DOFS.index(dof)])
        ax.plot(raos.omega, ours, label="Capytaine (this repo)")
        ax.plot(raos.omega, peers[dof], "--", label="netsse closed form (Jensen et al. 2004)")
        ax.set(xlabel="ω [rad/s]", ylabel=f"|{dof} RAO| [{unit}]", title=f"box barge, {dof}")
        ax.grid(True)
        ax.legend()
    fig.suptitle(f"{hull.length} × {hull.beam} × {hull.draft} m box barge, head seas, U = 0")
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hull", nargs="*", default=sorted(GRIDS), choices=sorted(GRIDS))
    parser.add_argument("--out", type=Path, default=asset_path("vessels"))
    parser.add_argument("--plot", type=Path, help="also write the netsse comparison PNG here")
    options = parser.parse_args()
    options.out.mkdir(parents=True, exist_ok=True)
    for name in options.hull:
        table = solve_hull(HULLS[name], GRIDS[name], progress=True)
        print(summary(table))
        write_raos(table, options.out / f"{name}.nc")
    if options.plot:
        plot_netsse_check(options.plot)


if __name__ == "__main__":
    main()

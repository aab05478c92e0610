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

Needs the `hydro` extra (capytaine, threadpoolctl) and the package importable, e.g.
`pip install -e .[hydro]`:

    python scripts/compute_raos.py                       # all hulls → assets/vessels/
    python scripts/compute_raos.py --hull asv --out /tmp
    python scripts/compute_raos.py --hull --plot docs/vessel_rao_netsse.png   # plot only
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from twin.assets import asset_path
from twin.sea.components import G
from twin.spatial import skew
from twin.vessel import DOFS, HULLS, Hull, RaoTable, load_raos, wetted_surface, write_raos
from twin.vessel.hulls import panel_geometry

RHO = 1025.0  # [kg/m³] sea water
CAPYTAINE_DOFS = ["Surge", "Sway", "Heave", "Roll", "Pitch", "Yaw"]  # DOFS order
DIRECTIONS = np.radians(np.arange(0.0, 360.0, 15.0))  # [rad] 24 directions, full circle
SOLVED = DIRECTIONS[DIRECTIONS <= np.pi]  # the port-starboard mirror gives the other 11
MIRROR = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])  # xOz reflection: sway, roll, yaw flip


@dataclass(frozen=True)
class Grid:
    """Discretisation of one solve: panel size and frequencies."""

    panel_size: float  # [m] panel radius ≤ 1/8 of the shortest wavelength 2πg/ω_max²
    omega: np.ndarray  # [rad/s] RAO phases of neighbouring frequencies differ < 30°


def frequencies(low: float, high: float, step: float, fine: tuple[float, float]) -> np.ndarray:
    """[rad/s] `step` apart on [low, high], `step`/2 on the roll-resonance band `fine`."""
    coarse = np.arange(low, high + step / 2, step)
    return np.unique(np.round(np.r_[coarse, np.arange(*fine, step / 2)], 4))


GRIDS = {
    # λ(2.2 rad/s) = 12.7 m (2 m triangles); |heave| < 0.2 % beyond. 2 m panels move the heave
    # added mass < 1 % against 1.5 m.
    "sov": Grid(2.0, frequencies(0.10, 2.20, 0.025, (0.50, 0.80))),
    # λ(2.35 rad/s) = 11.2 m (2 m quads).
    "barge": Grid(2.0, frequencies(0.10, 2.35, 0.025, (0.40, 0.65))),
    # λ(6 rad/s) = 1.71 m for 4.9 m floats, |RAO| < 0.15 beyond; seed 002 waves: 0.9-2.1 rad/s.
    # The roll resonance (≈ 8 rad/s) lies above the band: no refinement.
    "asv": Grid(0.12, np.round(np.arange(0.2, 6.0001, 0.1), 4)),
}


def symmetric_body(hull: Hull, grid: Grid):
    """Capytaine body: quarter mesh mirrored across xOz and yOz, 6 DOFs about the origin, and a
    waterplane lid if Capytaine's estimate of the first irregular frequency is in the band."""
    import capytaine as cpt

    vertices, faces = wetted_surface(hull, grid.panel_size)
    _, centroid = panel_geometry(vertices, faces)
    quarter = faces[(centroid[:, 0] > 0) & (centroid[:, 1] > 0)]
    mesh = cpt.ReflectionSymmetricMesh(
        cpt.ReflectionSymmetricMesh(cpt.Mesh(vertices, quarter.tolist()), plane="yOz"),
        plane="xOz",
        name=hull.name,
    )
    body = cpt.FloatingBody(
        mesh=mesh,
        dofs=cpt.rigid_body_dofs(rotation_center=(0.0, 0.0, 0.0)),
        center_of_mass=(0.0, 0.0, hull.z_g),
        name=hull.name,
    )
    if body.first_irregular_frequency_estimate(g=G) > grid.omega[-1]:
        return body
    return cpt.FloatingBody(
        mesh=mesh,
        lid_mesh=mesh.generate_lid(faces_max_radius=grid.panel_size),  # coarse: < 0.6 % on H
        dofs=body.dofs,
        center_of_mass=body.center_of_mass,
        name=hull.name,
    )


def rigid_body_mass(mass: float, center_of_gravity: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """6×6 mass matrix about the origin for DOFs (translation of the origin, rotation).

    Velocity of G = v + ω × r_G, so M = [[m I, -m S(r_G)], [m S(r_G), I_G - m S(r_G)²]],
    I_G = m diag(k²) (parallel-axis theorem in the lower right block).
    """
    S = skew(center_of_gravity)
    return np.block(
        [[mass * np.eye(3), -mass * S], [mass * S, mass * np.diag(radii**2) - mass * S @ S]]
    )


def roll_natural_frequency(omega: np.ndarray, a44: np.ndarray, m44: float, c44: float) -> float:
    """ω_n = sqrt(C44 / (M44 + A44(ω_n))) by fixed-point iteration, A44 clamped to the grid."""
    w = np.sqrt(c44 / m44)
    for _ in range(50):
        w = np.sqrt(c44 / (m44 + np.interp(w, omega, a44)))
    return float(w)


def solve_hull(hull: Hull, grid: Grid) -> RaoTable:
    """Mesh, solve and assemble the RAO table of one hull; prints progress and timings."""
    import capytaine as cpt
    from threadpoolctl import threadpool_limits

    start, start_cpu = time.perf_counter(), time.process_time()
    body = symmetric_body(hull, grid)
    solver = cpt.BEMSolver()
    results = []
    # One thread: the quarter meshes are small, and on a shared machine BLAS/OpenMP threads
    # spin-wait (2-5x slower than one thread under load).
    with threadpool_limits(limits=1):
        for omega in tqdm(grid.omega, desc=f"{hull.name}: ω", unit="freq"):
            problems = [
                cpt.RadiationProblem(body=body, omega=omega, radiating_dof=d, rho=RHO, g=G)
                for d in CAPYTAINE_DOFS
            ] + [
                cpt.DiffractionProblem(body=body, omega=omega, wave_direction=b, rho=RHO, g=G)
                for b in SOLVED
            ]
            results += solver.solve_all(problems, progress_bar=False, keep_details=False)
    ds = cpt.assemble_dataset(results)
    solve_seconds = time.perf_counter() - start
    solve_cpu_seconds = time.process_time() - start_cpu  # this process, all threads

    dofs = {"influenced_dof": CAPYTAINE_DOFS, "radiating_dof": CAPYTAINE_DOFS}
    order = ("omega", "influenced_dof", "radiating_dof")
    A = ds["added_mass"].sel(**dofs).transpose(*order).values  # (n_ω, 6, 6) [kg, kg m, kg m²]
    B = ds["radiation_damping"].sel(**dofs).transpose(*order).values  # (n_ω, 6, 6)
    F = (  # (n_ω, 13, 6) [N/m, N m/m], Froude-Krylov + diffraction, β = 0..π
        ds["excitation_force"]
        .sel(influenced_dof=CAPYTAINE_DOFS)
        .transpose("omega", "wave_direction", "influenced_dof")
        .values
    )
    F = np.concatenate([F, MIRROR * F[:, -2:0:-1]], axis=1)  # F(2π - β) = MIRROR F(β)
    C = body.compute_hydrostatic_stiffness(rho=RHO, g=G).sel(**dofs).values  # (6, 6)

    mass = body.disp_mass(rho=RHO)  # free floating: mass = displaced mass
    center_of_gravity = np.array([body.center_of_buoyancy[0], 0.0, hull.z_g])
    M = rigid_body_mass(mass, center_of_gravity, np.array(hull.radii_of_gyration))

    # Potential flow has only wave-radiation roll damping, far below the real one (friction,
    # eddies, bilge keels: Ikeda's components, ITTC 7.5-02-07-04.5); add ζ of critical.
    w_n = roll_natural_frequency(grid.omega, A[:, 3, 3], M[3, 3], C[3, 3])
    inertia_44 = M[3, 3] + np.interp(w_n, grid.omega, A[:, 3, 3])  # [kg m²] at ω_n
    b44 = 2 * hull.roll_damping_ratio * np.sqrt(C[3, 3] * inertia_44)  # [N m s/rad]
    B_visc = np.zeros((6, 6))
    B_visc[3, 3] = b44

    w = grid.omega[:, None, None]
    K = -(w**2) * (M + A) - 1j * w * (B + B_visc) + C  # e^{-iωt}: Capytaine's convention
    rao = np.linalg.solve(K[:, None], F[..., None])[..., 0]  # (n_ω, n_β, 6)

    lid = 0 if body.lid_mesh is None else body.lid_mesh.nb_faces
    print(
        f"{hull.name}: {body.mesh.nb_faces} hull + {lid} lid panels, "
        f"{grid.omega.size} ω × {DIRECTIONS.size} β solved in {solve_seconds:.1f} s "
        f"({solve_cpu_seconds:.1f} s CPU); "
        f"m = {mass / 1e3:.3f} t, GM_T = {body.transversal_metacentric_height:.2f} m, "
        f"roll ω_n = {w_n:.3f} rad/s (T = {2 * np.pi / w_n:.2f} s)"
    )
    attrs = {
        "title": f"RAO table: {hull.description}",
        "created_by": "scripts/compute_raos.py",
        "solver": f"capytaine {cpt.__version__}, deep water"
        + (", waterplane lid against irregular frequencies" if lid else ""),
        "phase_convention": "x(t) = Re(H * zeta * exp(-i omega t)); arg H is a phase lag",
        "reference_point": "centre of motion: midship, centreline, still waterline",
        "hull_shape": hull.shape,
        "hull_source": hull.source,
        "length_m": hull.length,
        "beam_m": hull.beam,
        "draft_m": hull.draft,
        "hull_spacing_m": hull.hull_spacing,
        "mass_kg": mass,
        "center_of_gravity_m": center_of_gravity,
        "radii_of_gyration_m": np.array(hull.radii_of_gyration),
        "gm_t_m": body.transversal_metacentric_height,
        "gm_l_m": body.longitudinal_metacentric_height,
        "roll_natural_frequency_rad_s": w_n,
        "roll_damping_ratio": hull.roll_damping_ratio,
        "roll_viscous_damping_N_m_s": b44,
        "rho_kg_m3": RHO,
        "g_m_s2": G,
        "panel_size_m": grid.panel_size,
        "panels_hull": body.mesh.nb_faces,
        "panels_lid": lid,
        "solve_seconds": solve_seconds,
        "solve_cpu_seconds": solve_cpu_seconds,
    }
    return RaoTable(hull.name, grid.omega, DIRECTIONS, rao, attrs)


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
        write_raos(solve_hull(HULLS[name], GRIDS[name]), options.out / f"{name}.nc")
    if options.plot:
        plot_netsse_check(options.plot)


if __name__ == "__main__":
    main()

"""RAO tables from a boundary-element solve with Capytaine (the optional `hydro` extra).

Meshes a hull of `HULLS` from its parameters, solves radiation and diffraction (linear
potential flow, deep water), adds a linear viscous roll damping and solves the equation of
motion (docs/vessel.md, "Computing the RAOs"). `scripts/compute_raos.py` runs it over the
shipped grids; the tests re-solve a few frequencies against the shipped tables. Capytaine and
threadpoolctl are imported only inside the functions that solve, so the twin runs without them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from tqdm import tqdm

from twin.sea.components import G
from twin.spatial import skew
from twin.vessel.hulls import Hull, panel_geometry, wetted_surface
from twin.vessel.rao import RaoTable

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


@dataclass(frozen=True)
class Hydrodynamics:
    """Linear hydrodynamics of one hull about the centre of motion, Capytaine's e^{−iωt}.

    Attributes:
        body: the Capytaine `FloatingBody` solved.
        omega: (n,) [rad/s] frequencies.
        wave_direction: (m,) [rad] directions of the excitation, from the bow, towards.
        added_mass: (n, 6, 6) A [kg, kg m, kg m²].
        radiation_damping: (n, 6, 6) B [N s/m, N s, N m s].
        excitation: (n, m, 6) Froude–Krylov + diffraction force per unit amplitude [N/m, N].
        stiffness: (6, 6) hydrostatic stiffness C, with −m g z_G in roll and pitch.
        mass_matrix: (6, 6) M from the hull's mass distribution.
        mass: [kg] displaced mass ρ∇ (free floating).
        center_of_gravity: (3,) [m].
        seconds: [s] wall time of the solve; cpu_seconds: this process's CPU time.
    """

    body: Any
    omega: np.ndarray
    wave_direction: np.ndarray
    added_mass: np.ndarray
    radiation_damping: np.ndarray
    excitation: np.ndarray
    stiffness: np.ndarray
    mass_matrix: np.ndarray
    mass: float
    center_of_gravity: np.ndarray
    seconds: float
    cpu_seconds: float


def symmetric_body(hull: Hull, grid: Grid) -> Any:
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


def roll_damping(ratio: float, c44: float, inertia_44: float) -> float:
    """Viscous roll damping B44 = 2ζ sqrt(C44 (M44 + A44(ω_n))) [N m s/rad].

    Potential flow has only wave-radiation roll damping, far below the real one (friction,
    eddies, bilge keels: Ikeda's components, ITTC 7.5-02-07-04.5); `ratio` ζ is the fraction
    of critical added (docs/vessel.md, "Roll damping"); `inertia_44` [kg m²] is M44 + A44.
    """
    return 2.0 * ratio * np.sqrt(c44 * inertia_44)


def solve_hydrodynamics(
    hull: Hull,
    grid: Grid,
    *,
    omega: ArrayLike | None = None,
    wave_direction: ArrayLike = SOLVED,
    progress: bool = False,
) -> Hydrodynamics:
    """Radiation and diffraction of `hull`, meshed as `grid` says, at the given frequencies.

    Args:
        hull: the hull.
        grid: panel size, and the band that decides the waterplane lid.
        omega: [rad/s] frequencies to solve; default `grid.omega`.
        wave_direction: [rad] directions of the diffraction problems, any in [0, 2π).
        progress: show a progress bar over the frequencies.

    Returns:
        Added mass, damping, excitation, hydrostatics and the rigid-body mass matrix, with
        `omega` and `wave_direction` sorted (Capytaine's dataset sorts its coordinates).
    """
    import capytaine as cpt
    from threadpoolctl import threadpool_limits

    omega = np.unique(grid.omega if omega is None else np.asarray(omega, dtype=float))
    wave_direction = np.unique(np.asarray(wave_direction, dtype=float))
    start, start_cpu = time.perf_counter(), time.process_time()
    body = symmetric_body(hull, grid)
    solver = cpt.BEMSolver()
    results = []
    # One thread: the quarter meshes are small, and on a shared machine BLAS/OpenMP threads
    # spin-wait (2-5x slower than one thread under load).
    with threadpool_limits(limits=1):
        for w in tqdm(omega, desc=f"{hull.name}: ω", unit="freq", disable=not progress):
            problems = [
                cpt.RadiationProblem(body=body, omega=w, radiating_dof=d, rho=RHO, g=G)
                for d in CAPYTAINE_DOFS
            ] + [
                cpt.DiffractionProblem(body=body, omega=w, wave_direction=b, rho=RHO, g=G)
                for b in wave_direction
            ]
            results += solver.solve_all(problems, progress_bar=False, keep_details=False)
    ds = cpt.assemble_dataset(results)
    seconds = time.perf_counter() - start
    cpu_seconds = time.process_time() - start_cpu  # this process, all threads

    dofs = {"influenced_dof": CAPYTAINE_DOFS, "radiating_dof": CAPYTAINE_DOFS}
    order = ("omega", "influenced_dof", "radiating_dof")
    excitation = (
        ds["excitation_force"]
        .sel(influenced_dof=CAPYTAINE_DOFS)
        .transpose("omega", "wave_direction", "influenced_dof")
        .values
    )
    mass = body.disp_mass(rho=RHO)  # free floating: mass = displaced mass
    center_of_gravity = np.array([body.center_of_buoyancy[0], 0.0, hull.z_g])
    return Hydrodynamics(
        body=body,
        omega=omega,
        wave_direction=wave_direction,
        added_mass=ds["added_mass"].sel(**dofs).transpose(*order).values,
        radiation_damping=ds["radiation_damping"].sel(**dofs).transpose(*order).values,
        excitation=excitation,
        stiffness=body.compute_hydrostatic_stiffness(rho=RHO, g=G).sel(**dofs).values,
        mass_matrix=rigid_body_mass(mass, center_of_gravity, np.array(hull.radii_of_gyration)),
        mass=mass,
        center_of_gravity=center_of_gravity,
        seconds=seconds,
        cpu_seconds=cpu_seconds,
    )


def motion_raos(hydro: Hydrodynamics, roll_viscous_damping: float) -> np.ndarray:
    """RAOs (n_ω, n_β, 6) [m/m, rad/m] of the equation of motion, Capytaine's e^{−iωt}.

    [−ω²(M + A) − iω(B + B_visc) + C] X = F, with B_visc = `roll_viscous_damping` [N m s/rad]
    on roll only.
    """
    b_visc = np.zeros((6, 6))
    b_visc[3, 3] = roll_viscous_damping
    w = hydro.omega[:, None, None]
    K = (
        -(w**2) * (hydro.mass_matrix + hydro.added_mass)
        - 1j * w * (hydro.radiation_damping + b_visc)
        + hydro.stiffness
    )
    return np.linalg.solve(K[:, None], hydro.excitation[..., None])[..., 0]


def solve_hull(hull: Hull, grid: Grid, *, progress: bool = False) -> RaoTable:
    """Mesh, solve and assemble the RAO table of one hull over `grid` and `DIRECTIONS`.

    Diffraction is solved for `SOLVED` (0..180°); 195..345° follow from the port-starboard
    mirror F(2π − β) = MIRROR F(β). The roll damping takes ζ = `hull.roll_damping_ratio` at
    the roll natural frequency found on the grid. The solve's figures are in the table's
    attributes.
    """
    import capytaine as cpt

    hydro = solve_hydrodynamics(hull, grid, progress=progress)
    F = hydro.excitation
    F = np.concatenate([F, MIRROR * F[:, -2:0:-1]], axis=1)  # F(2π - β) = MIRROR F(β)
    hydro = replace(hydro, wave_direction=DIRECTIONS, excitation=F)
    M, C, A = hydro.mass_matrix, hydro.stiffness, hydro.added_mass
    w_n = roll_natural_frequency(grid.omega, A[:, 3, 3], M[3, 3], C[3, 3])
    inertia_44 = M[3, 3] + np.interp(w_n, grid.omega, A[:, 3, 3])  # [kg m²] at ω_n
    b44 = roll_damping(hull.roll_damping_ratio, C[3, 3], inertia_44)
    rao = motion_raos(hydro, b44)

    body = hydro.body
    lid = 0 if body.lid_mesh is None else body.lid_mesh.nb_faces
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
        "mass_kg": hydro.mass,
        "center_of_gravity_m": hydro.center_of_gravity,
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
        "solve_seconds": hydro.seconds,
        "solve_cpu_seconds": hydro.cpu_seconds,
    }
    return RaoTable(hull.name, grid.omega, DIRECTIONS, rao, attrs)

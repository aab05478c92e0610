"""Hull parameter sets and their wetted-surface panels.

Every length is in the z-up vessel frame (x bow, y port, z up) with the origin at midship, on
the centreline, in the still waterline: the *centre of motion* that the RAO tables refer to.
The hulls are free-floating, so the mass is the displaced mass ρ∇ of the wetted surface
(computed by `scripts/compute_raos.py`); `z_g` and the radii of gyration state how that mass is
distributed. Sources and choices are in docs/vessel.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from twin.errors import TwinError

Shape = Literal["box", "wigley", "twin_cylinder"]


@dataclass(frozen=True)
class Hull:
    """Main dimensions and mass distribution of one floating hull.

    Attributes:
        name: key in `HULLS` and stem of `assets/vessels/NAME.nc`.
        description: what the hull stands for.
        shape: "box" (rectangular barge), "wigley" (Journée's modified Wigley form, Cb 0.56),
            or "twin_cylinder" (two horizontal circular floats, catamaran).
        length: [m] waterline length of the hull (of each float for "twin_cylinder").
        beam: [m] waterline beam of the hull; for "twin_cylinder" the float diameter 2r.
        draft: [m] still-water draft, < beam / 2 for "twin_cylinder".
        hull_spacing: [m] centre-to-centre distance of the floats, 0 for a monohull.
        z_g: [m] centre of gravity above the still waterline (z up).
        radii_of_gyration: [m] (k_xx, k_yy, k_zz) about the centre of gravity.
        roll_damping_ratio: [-] viscous roll damping added to potential flow, as a fraction of
            critical (docs/vessel.md, "Roll damping").
        source: where the dimensions come from.
    """

    name: str
    description: str
    shape: Shape
    length: float
    beam: float
    draft: float
    hull_spacing: float
    z_g: float
    radii_of_gyration: tuple[float, float, float]
    roll_damping_ratio: float
    source: str


HULLS: dict[str, Hull] = {
    "sov": Hull(
        name="sov",
        description="walk-to-work service operation vessel carrying the hybrid boarding system",
        shape="wigley",
        # Esvagt Schelde (Havyard SOV for offshore wind O&M): LOA 70.5 m, beam 16.6 m,
        # draught 5.6 m (Baird Maritime, "Vessel review | Esvagt Schelde").
        length=70.5,
        beam=16.6,
        draft=5.6,
        hull_spacing=0.0,
        # KG = 4.78 m above the keel: GM_T ≈ 2.0 m, mid-range for offshore support vessels.
        z_g=-0.82,
        # k_xx = 0.40 B, k_yy = k_zz = 0.25 L: typical ship values (Journée & Massie,
        # Offshore Hydromechanics, 2001), k_xx at the upper end for a tall superstructure.
        radii_of_gyration=(6.64, 17.6, 17.6),
        roll_damping_ratio=0.08,
        source="Esvagt Schelde main dimensions (Baird Maritime vessel review); "
        "modified Wigley form (Journée 1992, TU Delft report 909)",
    ),
    "asv": Hull(
        name="asv",
        description="twin-float ASV carrying the 4-UPR UAV landing platform (seed 002)",
        shape="twin_cylinder",
        # Seed 002 gives only the mechanism (base square b = 1.25 m, 2 x 2 m top) and simulates
        # the ASV with the VRX Gazebo plug-ins [35]; their WAM-V floats are cylinders
        # 4.9 m long, r = 0.213 m, 2 x 1.03 m apart (osrf/vrx wamv_gazebo_dynamics_plugin.xacro).
        length=4.9,
        beam=0.426,
        # 0.10 m floats 256 kg: VRX's 180 kg WAM-V plus ≈ 75 kg of 4-UPR mechanism and UAV.
        draft=0.10,
        hull_spacing=2.06,
        z_g=0.35,
        # From the VRX WAM-V inertia (120, 393, 446) kg m² at 180 kg, kept for the total mass.
        radii_of_gyration=(0.82, 1.48, 1.57),
        roll_damping_ratio=0.10,
        source="seed 002 mechanism; floats from VRX WAM-V (osrf/vrx wamv_base.urdf.xacro)",
    ),
    "barge": Hull(
        name="barge",
        description="box barge with the SOV's main dimensions, the netsse cross-check hull",
        shape="box",
        length=70.5,
        beam=16.6,
        draft=5.6,
        hull_spacing=0.0,
        z_g=0.0,
        # Uniform mass along the length, k_yy = k_zz = L/sqrt(12), as Jensen et al. (2004)
        # assume for their closed-form pitch of a homogeneous box.
        radii_of_gyration=(5.81, 20.35, 20.35),
        # Sharp bilges shed vortices: eddy damping, Ikeda's largest term for barges.
        roll_damping_ratio=0.10,
        source="Jensen, Mansour & Olsen (2004), Ocean Eng. 31(1) 61-85, box-shaped hull",
    ),
}


def get_hull(name: str) -> Hull:
    """The hull called `name`; raises `TwinError` listing the known hulls."""
    try:
        return HULLS[name]
    except KeyError:
        raise TwinError(f"unknown hull {name!r}, known hulls: {sorted(HULLS)}") from None


def wigley_half_breadth(xi: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """η = 2y/B of the modified Wigley hull I at ξ = 2x/L, ζ = z/T ∈ [-1, 0].

    η = (1 - ζ²)(1 - ξ²)(1 + 0.2 ξ²) + ζ²(1 - ζ⁸)(1 - ξ²)⁴ (Journée 1992, model I, Cb = 0.56).
    """
    return (1 - zeta**2) * (1 - xi**2) * (1 + 0.2 * xi**2) + zeta**2 * (1 - zeta**8) * (
        1 - xi**2
    ) ** 4


def _arclength_resample(y: np.ndarray, z: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """n + 1 points equally spaced in arc length along the polyline (y, z)."""
    s = np.r_[0.0, np.cumsum(np.hypot(np.diff(y), np.diff(z)))]
    if s[-1] == 0.0:  # the Wigley stem: a section of zero girth
        s = np.linspace(0.0, 1.0, y.size)
    u = np.linspace(0.0, s[-1], n + 1)
    return np.interp(u, s, y), np.interp(u, s, z)


def _sections(hull: Hull, x: np.ndarray, panel_size: float) -> tuple[np.ndarray, np.ndarray]:
    """Port-half sections y, z of shape (len(x), n + 1), keel first, one hull or float."""
    T, half_b = hull.draft, hull.beam / 2
    if hull.shape == "box":
        n_bottom, n_side = int(np.ceil(half_b / panel_size)), int(np.ceil(T / panel_size))
        y = np.r_[np.linspace(0.0, half_b, n_bottom + 1), np.full(n_side, half_b)]
        z = np.r_[np.full(n_bottom + 1, -T), np.linspace(-T, 0.0, n_side + 1)[1:]]
        return np.broadcast_to(y, (x.size, y.size)), np.broadcast_to(z, (x.size, z.size))
    if hull.shape == "wigley":
        zeta = -np.cos(np.linspace(0.0, np.pi / 2, 200))  # dense near the flat bottom
        xi = 2 * x[:, None] / hull.length
        y_dense = half_b * wigley_half_breadth(xi, zeta[None, :])
        girth = np.sum(np.hypot(np.diff(y_dense[x.size // 2]), np.diff(T * zeta)))
        n = int(np.ceil(girth / panel_size))
        pairs = [_arclength_resample(row, T * zeta, n) for row in y_dense]
        return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
    # twin_cylinder: the whole immersed arc of one float, inner waterline → keel → outer.
    r = half_b
    half_angle = np.arccos((r - T) / r)  # from the keel to the waterline
    n = 2 * max(4, int(np.ceil(r * half_angle / panel_size)))  # ≥ 8 chords: ∇ within 2 %
    angle = np.linspace(-half_angle, half_angle, n + 1)
    y, z = r * np.sin(angle), (r - T) - r * np.cos(angle)
    return np.broadcast_to(y, (x.size, y.size)), np.broadcast_to(z, (x.size, z.size))


def _side(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Quads between sections (stations i, girth j); normal t_girth × t_x, outward on port."""
    nx, ng = y.shape
    vertices = np.stack([np.broadcast_to(x[:, None], y.shape), y, z], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ng - 1), indexing="ij")
    k = (i * ng + j).ravel()
    return vertices, np.stack([k, k + 1, k + ng + 1, k + ng], -1)


def _end_caps(
    hull: Hull, x_end: float, y: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Flat transom panels (normal +x) at x = x_end closing one port-half section (y, z)."""
    if hull.shape == "box":  # a grid over the rectangle 0 ≤ y ≤ B/2, -T ≤ z ≤ 0
        ys, zs = np.unique(y), np.unique(z)
        gy, gz = np.meshgrid(ys, zs, indexing="ij")
        vertices = np.stack([np.full(gy.size, x_end), gy.ravel(), gz.ravel()], -1)
        i, j = np.meshgrid(np.arange(ys.size - 1), np.arange(zs.size - 1), indexing="ij")
        k = (i * zs.size + j).ravel()
        return vertices, np.stack([k, k + zs.size, k + zs.size + 1, k + 1], -1)
    # twin_cylinder: horizontal strips between the inner point j and outer point n - j.
    n = y.size - 1
    vertices = np.stack([np.full(y.size, x_end), y, z], -1)
    inner = np.arange(n // 2)
    return vertices, np.stack([inner, inner + 1, n - inner - 1, n - inner], -1)


def _triangles(vertices: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split each quad (a, b, c, d) into the flat triangles (a, b, c, c) and (a, c, d, d).

    A mirrored warped quad is split along the other diagonal by Capytaine (it reverses the
    vertex order), which breaks the port-starboard symmetry at 1e-4; flat panels mirror
    exactly. Triangles lying in the centreplane y = 0 (at the stem foot) are dropped: mirrored,
    they would form a double fin of zero thickness.
    """
    triangles = np.concatenate([quads[:, [0, 1, 2, 2]], quads[:, [0, 2, 3, 3]]])
    return vertices, triangles[np.any(vertices[triangles, 1] != 0.0, axis=1)]


def _mirror(vertices: np.ndarray, faces: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """Reflection across the plane `axis` = 0; the reversed order keeps normals outward."""
    flipped = vertices.copy()
    flipped[:, axis] *= -1
    return flipped, faces[:, ::-1]


def _join(*parts: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """One (vertices, faces) from several, face indices shifted to the stacked vertices."""
    offsets = np.cumsum([0] + [v.shape[0] for v, _ in parts[:-1]])
    return (
        np.concatenate([v for v, _ in parts]),
        np.concatenate([f + o for (_, f), o in zip(parts, offsets, strict=True)]),
    )


def wetted_surface(hull: Hull, panel_size: float) -> tuple[np.ndarray, np.ndarray]:
    """Panels of the wetted hull surface below the still waterline, normals outward.

    Args:
        hull: the hull to panel.
        panel_size: [m] target panel edge length.

    Returns:
        vertices: (V, 3) [m] in the z-up vessel frame; seams repeat vertices.
        faces: (F, 4) vertex indices, counter-clockwise seen from the water; a triangle repeats
            a vertex (Nemoh's convention; Capytaine merges both).
    """
    if not panel_size > 0:
        raise TwinError(f"panel_size must be > 0 m, got {panel_size}")
    nx = 2 * int(np.ceil(hull.length / (2 * panel_size)))
    x = np.linspace(-hull.length / 2, hull.length / 2, nx + 1)
    y, z = _sections(hull, x, panel_size)
    if hull.shape == "twin_cylinder":
        y = y + hull.hull_spacing / 2  # the port float
    port = [_side(x, y, z)]
    if hull.shape == "wigley":  # doubly curved, and its ends have no area
        port = [_triangles(*port[0])]
    else:  # box and floats end in flat transoms
        bow = _end_caps(hull, x[-1], y[0], z[0])
        port += [bow, _mirror(*bow, axis=0)]
    port_half = _join(*port)
    return _join(port_half, _mirror(*port_half, axis=1))


def panel_geometry(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area vectors (F, 3) [m²] (normal × area, from the diagonals) and centroids (F, 3) [m].

    The centroid weighs the triangles (0, 1, 2) and (0, 2, 3) by area, so a repeated vertex
    (a triangle) contributes nothing twice.
    """
    p = vertices[faces]  # (F, 4, 3)
    area_vector = 0.5 * np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])
    a1 = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)[:, None]
    a2 = np.linalg.norm(np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]), axis=1)[:, None]
    centroid = (a1 * (p[:, 0] + p[:, 1] + p[:, 2]) + a2 * (p[:, 0] + p[:, 2] + p[:, 3])) / (
        3 * (a1 + a2)
    )
    return area_vector, centroid


def displaced_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """∇ = ∫ z n_z dS over the wetted surface [m³] (Gauss; the waterplane has z = 0)."""
    area_vector, centroid = panel_geometry(vertices, faces)
    return float(np.sum(centroid[:, 2] * area_vector[:, 2]))

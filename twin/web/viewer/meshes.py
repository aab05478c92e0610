"""The scene's static geometry, in the frames it is drawn in: the sea grid, the vessel (hull,
topsides, deck structure), and the targets (transition piece, UAV, container, landing pad).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import trimesh

from twin.sim.registries import (
    HULL_GRIDS,
    HULLS,
    MOUNTS,
    Hull,
    WaveComponents,
    wetted_surface,
    wigley_half_breadth,
)
from twin.sim.scenario import Scenario
from twin.spatial import pose_to_transform

#: vertices per side of the waves' square of the sea mesh, and rings of ever wider cells
#: around it out to the horizon ((40 + 2 × 8)² × 12 B ≈ 38 kB per frame)
OCEAN_RESOLUTION = 40
OCEAN_RINGS = 8
#: [-] the flat sea reaches this many wave squares from the work site; the fog starts at
#: FOG_NEAR and hides everything at FOG_FAR of them (the edge never shows), and the camera
#: draws from NEAR to 1.2 FOG_FAR of them (beyond it all is fog: nothing shows clipped)
HORIZON = 40.0
FOG_NEAR = 1.5
FOG_FAR = 14.0
NEAR = 5e-4
#: most wave components drawn; the smaller ones are invisible at this grid spacing and would
#: make a frame cost grow with `n_components` (up to 2048)
OCEAN_COMPONENTS = 96
#: [-] Gerstner steepness Q of the drawn surface (sharper crests, no effect on heights): 1 is
#: linear theory's own surface particle orbit (`twin.sea.surface.gerstner_points`)
GERSTNER_Q = 1.0

#: [-] deck height above the waterline as a fraction of the draft (a monohull's freeboard)
FREEBOARD = 0.7

SEA = (28, 92, 140)
SKY = (214, 226, 236)  # the background and the fog: a hazy horizon
HULL = (54, 62, 82)
BOTTOM = (150, 48, 40)  # antifouling below the waterline
DECK = (128, 132, 136)
#: the comparison lane's ghost: RGB in [0, 1] and opacity
GHOST = (0.25, 0.8, 1.0, 0.4)
SUPERSTRUCTURE = (236, 236, 232)
WINDOWS = (30, 44, 60)
FUNNEL = (200, 60, 40)
#: [m] height of the bulwark along the deck edge
BULWARK = 1.2
#: vessel parts drawn with smooth normals (curved plating); the rest, boxes, flat-shaded so
#: their faces read as faces, not as one rounded blob
SMOOTH_PARTS = ("hull", "topsides", "bulwark", "wetted", "float_port", "float_starboard")
STEEL = (112, 116, 122)
YELLOW = (236, 190, 30)
WHITE = (240, 242, 245)
GREEN = (40, 170, 80)
TRAIL = (214, 40, 160)
#: the ghost's tip-error trail: its blue, opaque
GHOST_TRAIL: tuple[int, int, int] = (int(255 * GHOST[0]), int(255 * GHOST[1]), int(255 * GHOST[2]))


def ocean_faces(n: int) -> np.ndarray:
    """Triangles (2 (n-1)², 3) of an n × n vertex grid in "ij" order, counter-clockwise
    seen from +z (x along i, y along j)."""
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    v00 = (i * n + j).ravel()
    v10, v01, v11 = v00 + n, v00 + 1, v00 + n + 1
    return np.concatenate([np.stack([v00, v10, v11], -1), np.stack([v00, v11, v01], -1)])


def ocean_axis(core: float, n: int = OCEAN_RESOLUTION, rings: int = OCEAN_RINGS) -> np.ndarray:
    """Grid coordinates [m] along one axis about the work site: n evenly spaced over the
    waves' square of side `core`, then `rings` cells on each side growing geometrically out
    to `HORIZON` × core."""
    inner = np.linspace(-core / 2, core / 2, n)
    outer = core / 2 * (2.0 * HORIZON) ** (np.arange(1, rings + 1) / rings)
    return np.r_[-outer[::-1], inner, outer]


def wave_weight(x: np.ndarray, y: np.ndarray, core: float) -> np.ndarray:
    """(len(x), len(y)) [-] how much of the waves a grid point shows: 1 in the waves' square,
    0 from the first ring out (a coarse cell cannot carry them), so the sea calms into the
    flat water that runs to the horizon."""
    reach = np.maximum(np.abs(x)[:, None], np.abs(y)[None, :]) / (core / 2)
    return np.clip(2.0 - reach, 0.0, 1.0)


def drawn_sea(sea: WaveComponents) -> WaveComponents:
    """The `OCEAN_COMPONENTS` largest-amplitude components of `sea` (all if fewer)."""
    if sea.amplitude.size <= OCEAN_COMPONENTS:
        return sea
    keep = np.sort(np.argsort(sea.amplitude)[-OCEAN_COMPONENTS:])
    return WaveComponents(
        sea.omega[keep], sea.amplitude[keep], sea.phase[keep], sea.direction[keep]
    )


def hull_for(scenario: Scenario) -> Hull:
    """The hull drawn for a scenario: its vessel's, else its mount's."""
    return HULLS.get(scenario.vessel or "", HULLS[MOUNTS[scenario.mechanism].vessel])


def mount_transform(mechanism: str) -> np.ndarray:
    """ᵛT_B (4, 4): the base in the vessel frame (`twin.vessel.MOUNTS`)."""
    mount = MOUNTS[mechanism]
    return pose_to_transform(np.r_[mount.lever_arm, 0.0, 0.0, mount.yaw])


def _cylinder(
    radius: float, z0: float, z1: float, xy: Iterable[float] = (0.0, 0.0)
) -> trimesh.Trimesh:
    mesh = trimesh.creation.cylinder(radius=radius, height=z1 - z0, sections=40)
    return mesh.apply_translation([*xy, 0.5 * (z0 + z1)])


def _box(extents: Iterable[float], centre: Iterable[float], yaw: float = 0.0) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(extents=list(extents))
    mesh.apply_transform(trimesh.transformations.rotation_matrix(yaw, [0, 0, 1]))
    return mesh.apply_translation(list(centre))


def panel_mesh(vertices: np.ndarray, quads: np.ndarray) -> trimesh.Trimesh:
    """Quads (F, 4) (a triangle repeats a vertex, Nemoh's convention) as a triangle mesh."""
    triangles = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    p = vertices[triangles]
    area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return trimesh.Trimesh(vertices, triangles[area > 1e-12], process=False)


def wetted_mesh(hull: Hull) -> trimesh.Trimesh:
    """The hull below the waterline as its RAOs were computed: the panels of
    `twin.vessel.hulls.wetted_surface` at the panel size of `twin.vessel.bem.GRIDS` (the mesh
    `scripts/compute_raos.py` hands Capytaine)."""
    return panel_mesh(*wetted_surface(hull, HULL_GRIDS[hull.name].panel_size))


def topsides(hull: Hull, deck: float) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """A monohull above the waterline: walls standing on the waterline of the wetted surface
    (the Wigley form's, or the box's) up to the deck at height `deck`, and the deck."""
    L, B = hull.length, hull.beam
    panel = HULL_GRIDS[hull.name].panel_size
    x = np.linspace(-L / 2, L / 2, 2 * int(np.ceil(L / (2 * panel))) + 1)
    half = np.full_like(x, B / 2)
    if hull.shape == "wigley":
        half = B / 2 * wigley_half_breadth(2 * x / L, np.zeros_like(x))
    n = x.size
    # vertices: port waterline, port deck edge, starboard waterline, starboard deck edge
    rows = [(half, 0.0), (half, deck), (-half, 0.0), (-half, deck)]
    vertices = np.concatenate([np.stack([x, y, np.full(n, z)], -1) for y, z in rows])
    i = np.arange(n - 1)
    quads = [np.stack([i, i + 1, n + i + 1, n + i], -1),  # port wall
             np.stack([2 * n + i, 3 * n + i, 3 * n + i + 1, 2 * n + i + 1], -1)]  # fmt: skip
    if hull.shape == "box":  # flat ends
        quads.append(np.array([[0, n, 3 * n, 2 * n], [n - 1, 3 * n - 1, 4 * n - 1, 2 * n - 1]]))
    walls = panel_mesh(vertices, np.concatenate(quads))
    deck_quads = np.stack([n + i, n + i + 1, 3 * n + i + 1, 3 * n + i], -1)
    return walls, panel_mesh(vertices, deck_quads)


def hull_parts(hull: Hull, lever_arm: Iterable[float]) -> dict[str, tuple[trimesh.Trimesh, tuple]]:
    """Meshes of a vessel in its own frame (x bow, y port, z up, origin at the waterline
    midships), name → (mesh, colour): the hull below the waterline as the panels its RAOs were
    solved on (`wetted_mesh`), the same form above it, deck structure and the pedestal that
    carries the mechanism base up to its mount height."""
    L, B, T = hull.length, hull.beam, hull.draft
    x_b, y_b, z_b = lever_arm
    wetted = wetted_mesh(hull)
    if hull.shape == "twin_cylinder":
        r, s = 0.5 * B, 0.5 * hull.hull_spacing
        # the floats' cylinders, a hair inside the wetted panels that lie on them
        float_ = trimesh.creation.cylinder(radius=0.99 * r, height=0.999 * L, sections=32)
        float_.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
        parts = {
            f"float_{side}": (float_.copy().apply_translation([0, y, r - T]), HULL)
            for side, y in (("port", s), ("starboard", -s))
        }
        parts["wetted"] = (wetted, BOTTOM)
        for k, x in enumerate((-0.3 * L, 0.3 * L)):
            parts[f"beam_{k}"] = (_box((0.1, 2 * s, 0.08), (x, 0, z_b - 0.1)), STEEL)
        return parts
    deck = FREEBOARD * T
    walls, deck_plate = topsides(hull, deck)
    # the deck edge: a light bulwark on the hull's outline, so the deck reads against the sea
    bulwark, _ = topsides(hull, BULWARK)
    bulwark.apply_translation([0.0, 0.0, deck])
    # a forward accommodation block, its bridge over it with a band of dark windows all
    # round, a mast on the bridge and a funnel aft of it: a ship's silhouette, in boxes
    x_s, length = 0.21 * L, 0.2 * L
    top = deck + 6.0  # [m] two decks of accommodation, 3 m each
    parts = {
        "hull": (wetted, BOTTOM),
        "topsides": (walls, HULL),
        "deck": (deck_plate, DECK),
        "bulwark": (bulwark, SUPERSTRUCTURE),
        "superstructure": (_box((length, 0.8 * B, 6.0), (x_s, 0, deck + 3.0)), SUPERSTRUCTURE),
        "bridge": (_box((0.5 * length, 0.9 * B, 3.0), (x_s + 0.2 * length, 0, top + 1.5)),
                   SUPERSTRUCTURE),
        "windows": (_box((0.5 * length + 0.1, 0.9 * B + 0.1, 1.1),
                         (x_s + 0.2 * length, 0, top + 1.9)), WINDOWS),
        "mast": (_cylinder(0.25, top + 3.0, top + 9.0, (x_s + 0.2 * length, 0.0)), WHITE),
        "funnel": (_box((0.25 * length, 0.25 * B, 4.0), (x_s - 0.3 * length, 0, top + 2.0)),
                   FUNNEL),
    }  # fmt: skip
    if z_b - deck > 0.5:
        parts["pedestal"] = (_box((3.5, 3.5, z_b - deck), (x_b, y_b, 0.5 * (z_b + deck))), STEEL)
    return parts


def transition_piece(
    held: np.ndarray, transform_base: np.ndarray
) -> dict[str, tuple[trimesh.Trimesh, tuple]]:
    """An offshore wind turbine's foundation whose access platform carries the gangway tip's
    held pose, in inertial coordinates; the tower stands beyond the tip, away from the base."""
    tip = held[:3, 3]
    away = tip[:2] - transform_base[:2, 3]
    away = away / np.linalg.norm(away) if np.linalg.norm(away) > 1e-6 else np.array([0.0, -1.0])
    radius, deck_radius, floor = 3.0, 5.5, tip[2] - 0.3  # [m] TP, access platform; tip rests
    axis = tip[:2] + away * (deck_radius - 0.8)  # the tip lands 0.8 m inside the deck edge
    top = floor + 60.0  # [m] tower top
    ladder = axis - away * (radius + 0.3)  # boat-landing ladder, facing the vessel
    yaw = float(np.arctan2(away[1], away[0]))
    return {
        "monopile": (_cylinder(radius, -30.0, -2.0, axis), STEEL),
        "transition_piece": (_cylinder(radius, -2.0, floor - 0.4, axis), YELLOW),
        "access_platform": (_cylinder(deck_radius, floor - 0.4, floor, axis), STEEL),
        "ladder": (_box((0.3, 0.8, floor + 2.0), (*ladder, floor / 2 - 1.0)), STEEL),
        "landing_zone": (_box((2.0, 2.0, 0.04), (*tip[:2], floor + 0.02), yaw), GREEN),
        "tower": (_cylinder(2.3, floor, top, axis), WHITE),
        "nacelle": (_box((11.0, 4.0, 4.0), (*(axis + away * 2.0), top + 2.0), yaw), WHITE),
    }  # fmt: skip


def hovering_uav(pad_side: float) -> dict[str, tuple[trimesh.Trimesh, tuple, float | None]]:
    """A quadcopter 1.6 m above the held pad pose and the held pad as a ghost, in the held
    frame: name → (mesh, colour, opacity)."""
    h = 1.6  # [m] hover height above the held pad
    arm = 0.65  # [m] rotor distance from the body centre
    parts: dict[str, tuple[trimesh.Trimesh, tuple, float | None]] = {
        "held_pad": (_box((pad_side, pad_side, 0.02), (0, 0, 0)), GREEN, 0.35),
        "body": (_box((0.45, 0.45, 0.14), (0, 0, h)), (40, 40, 46), None),
    }
    for k, yaw in enumerate((np.pi / 4, -np.pi / 4)):
        parts[f"arm_{k}"] = (_box((2 * arm, 0.06, 0.04), (0, 0, h + 0.04), yaw), (40, 40, 46), None)
    for k, (sx, sy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1))):
        xy = np.array([sx, sy]) * arm / np.sqrt(2.0)
        parts[f"rotor_{k}"] = (_cylinder(0.24, h + 0.07, h + 0.09, xy), (200, 205, 210), 0.6)
    for k, x in enumerate((-0.16, 0.16)):
        parts[f"skid_{k}"] = (_box((0.04, 0.55, 0.03), (x, 0, h - 0.2)), (40, 40, 46), None)
    return parts


def hanging_container() -> dict[str, tuple[trimesh.Trimesh, tuple, float | None]]:
    """A crane-hung cargo box waiting over the held platform pose and the held pose as a ghost,
    in the held frame: name → (mesh, colour, opacity)."""
    return {
        "held_top": (_cylinder(0.7, -0.01, 0.01), GREEN, 0.35),
        "container": (_box((1.6, 1.0, 0.8), (0, 0, 1.9)), (30, 90, 170), None),
        "hook": (_box((0.12, 0.12, 0.3), (0, 0, 2.45)), STEEL, None),
        "wire": (_box((0.03, 0.03, 20.0), (0, 0, 12.6)), (30, 30, 30), None),
    }


def landing_pad(pad_side: float) -> dict[str, tuple[trimesh.Trimesh, tuple]]:
    """The 4-UPR's landing pad with an "H", in the platform frame (the URDF draws only the
    hinge plate)."""
    z = 0.05
    return {
        "pad": (_box((pad_side, pad_side, 0.03), (0, 0, z)), (62, 64, 70)),
        "h_left": (_box((0.12, 0.9, 0.01), (-0.3, 0, z + 0.02)), YELLOW),
        "h_right": (_box((0.12, 0.9, 0.01), (0.3, 0, z + 0.02)), YELLOW),
        "h_bar": (_box((0.6, 0.12, 0.01), (0, 0, z + 0.02)), YELLOW),
    }

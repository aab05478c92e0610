"""The live twin in viser: the 3D scene, and `start_viewer`, which serves it with its GUI.

The scene is drawn in the simulation's inertial (equilibrium) frame, z up:

- the sea surface: one mesh whose vertices move every frame (Gerstner points of the simulated
  sea, `twin.sea.surface`), centred on the work site; beyond the waves its grid widens to
  the horizon, flat, and the scene's fog (the sky's colour) hides its far edge;
- the vessel hull (`twin.vessel.HULLS`) as the panels its RAOs were solved on below the
  waterline (`twin.vessel.hulls.wetted_surface` at `twin.vessel.bem.GRIDS`' panel size),
  topsides above, posed from the base pose and the mount: ᴵT_B = ᴵT_V · ᵛT_B, so
  ᴵT_V = ᴵT_B · ᵛT_B⁻¹;
- the mechanism from its URDF (`assets/urdf`) under a frame that follows the base pose, its
  joints from `twin.mechanisms.urdf.joint_configuration`; with a second planner compared
  (`compare_planner`), its lane again as a translucent ghost on the same base;
- the legs again as thick lines coloured by their margin to the stroke limits, green → red;
- the fixed target in the inertial frame: a wind-turbine transition piece with its access
  platform (hybrid gangway), a hovering UAV over the landing pad's held pose (4-UPR), a
  crane-hung container over the cargo platform's held pose (3UPU_UP);
- a trail of the tip error (where the landing point is minus where it is held,
  `FrameState.landing_offset`), magnified by a fixed factor per mechanism
  (`TRAIL_MAGNIFICATION`) that its label states.

Nodes are added when a mechanism is built (at start and when the session switches mechanism,
when every browser's camera is pointed at the new mechanism) and otherwise only updated
through their handles, so viser's per-client buffers keep just the
newest value of each property and a slow browser only ever receives the latest frame.

The viewer's port passes the REST API's Host check: any request to it (the page, its assets,
the websocket handshake) whose Host is missing or not a name the server answers to (loopback
names, the bind address, `--allow-host`) is refused (400), so a page reached through a DNS
name of its own (DNS rebinding) gets nothing. Its websocket also refuses a cross-origin
handshake (403): a page from another site cannot open it, so it can neither read the scene
nor send a control. Allowed origins are the server's own (http on an allowed host at the
viewer's or the REST port) and those given with `--allow-origin` (`twin.web.access`).
viser offers no hook for the handshake, so `start_viewer` adds the checks to the one
`websockets` server viser starts (`_checked_handshake`), and fails to start if it could not.
It also drops viser's handlers of share-URL requests: any browser could otherwise ask the
server to open a public tunnel to itself.
"""

from __future__ import annotations

import contextlib
import http
import json
import logging
import secrets
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from functools import partial
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

import numpy as np
import trimesh
import viser
import yourdfpy
from viser.extras import ViserUrdf

try:  # optional: without it the render loop runs, slower (see `Viewer._frame`)
    import threadpoolctl
except ImportError:
    threadpoolctl = None

from twin.assets import asset_path
from twin.errors import TwinError
from twin.sea.components import WaveComponents
from twin.sea.surface import gerstner_points
from twin.sim.live import LiveSession
from twin.sim.scenario import Scenario
from twin.spatial import invert_transform, matrix_to_wxyz, pose_to_transform
from twin.vessel import MOUNTS
from twin.vessel.hulls import HULLS, Hull
from twin.web.access import Access
from twin.web.connections import quiet_malformed_messages
from twin.web.frame import VIEWS, FrameState, View, read_frame
from twin.web.gui import GRAPHICS, TwinGui, si

logger = logging.getLogger(__name__)

#: [Hz] render-loop rate; issue 6 asks for ≥ 30 fps, the margin absorbs slow frames
FPS = 40.0
#: what the browsers render: `twin.web.gui.GRAPHICS` (imported above, used here too)

#: [-] the ambient light of "light" graphics, in place of the environment map: low enough
#: that the sun's shading of the wave slopes shows (at 1.2 it washed the sea flat)
AMBIENT = 0.6
#: the key light (`configure_graphics`): a low sun, 21° above the horizon where the waves
#: run to (`sun_azimuth`), where a wave slope of 5° changes the light it gets by ±20 %
#: (overhead: 0.4 %) and the sea's toon bands split the slopes facing the sun from those
#: facing away (`SEA_MATERIAL`)
SUN_ELEVATION = float(np.radians(21.0))
SUN_AZIMUTH = 0.0  # [rad] from +x towards +y, until a sea is drawn
SUN_INTENSITY = 2.6
SUN = (255, 244, 226)
#: [-] the fill light from above (viser's own key light was 3.0 from there)
OVERHEAD_INTENSITY = 0.8
#: lower-case words of a WebGL renderer string that mean software rendering
SOFTWARE_RENDERERS = ("swiftshader", "llvmpipe", "softpipe", "software", "basic render")
#: where a page reports its WebGL renderer (relative to the page, as its websocket is)
RENDERER_PATH = "/twin-renderer"
#: what the viewer runs in a browser once (viser's RunJavascriptMessage, as viser sends
#: plotly.js): read the WebGL renderer of a throw-away canvas and report it with the key
#: the server gave this browser alone; `__KEY__` and `__PATH__` are filled in (JSON)
DETECT_RENDERER_JS = """(() => {
  let name = "unknown";
  try {
    const gl = document.createElement("canvas").getContext("webgl");
    if (gl === null) {
      name = "no WebGL";
    } else {
      const info = gl.getExtension("WEBGL_debug_renderer_info");
      name = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
      const lose = gl.getExtension("WEBGL_lose_context");
      if (lose) lose.loseContext();
    }
  } catch (err) {
    name = "error: " + err;
  }
  const url = new URL(__PATH__.slice(1), window.location.href);
  url.searchParams.set("key", __KEY__);
  url.searchParams.set("renderer", name.slice(0, 200));
  fetch(url, { cache: "no-store" }).catch(() => {});
})();"""
#: [-] the URDF parts' PBR material: painted steel. Their `<color>` alone reaches the browser
#: as vertex colours with no material, which three.js draws as rough full metal (glTF's
#: default): lit by the environment map alone, black in "light" graphics. Mostly diffuse, they
#: read under any light.
PAINT_METALLIC = 0.2
PAINT_ROUGHNESS = 0.55
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
#: the sea's material: three.js' toon shading in three bands of the sun's incidence
#: (MeshToonMaterial: band edges at N·L = ±1/3). With the sun a little higher than
#: asin(1/3) = 19.5° (`SUN_ELEVATION`), a level sea sits in the upper band and every wave
#: slope turned more than 1.5° away from the sun drops into the middle one: the waves' backs
#: draw as darker bands, so wave fronts and crests read at a glance, in either graphics
#: mode (the per-vertex normals are three.js', computed from the moving vertices); a calm
#: sea stays one colour. Per pixel it costs what the standard material does, less.
SEA_MATERIAL = "toon3"
#: the view every browser gets when a mechanism is built: the mechanism and its target fill
#: it, however small the mechanism is next to its vessel
FRAMING: View = "close-up"
#: [rad] the cameras' vertical field of view (viser's default, set on every camera)
FOV = float(np.radians(75.0))
#: [px] the overview draws the mechanism's longest side at least this long, face on, in a
#: window this tall (a laptop's browser): seen at the overview's slant, ≥ 80 px (the issue's
#: least; measured in tests/web/test_browser_scene.py). A small
#: mechanism on a large vessel (the 3UPU_UP's 1.3 m on 70 m) is not shrunk to fit the whole
#: vessel: the overview then comes in to the deck around it (the cameras zoom; the scene is
#: never drawn out of scale)
OVERVIEW_MIN_PX, VIEW_HEIGHT_PX = 120.0, 720.0
#: [-] the close-up's distance over the one at which the mechanism and its target's bounding
#: sphere just fits the field of view
CLOSE_UP_MARGIN = 1.3
#: [-] the views put what they show this fraction of the view's half-width left of its middle,
#: clear of the control panel (about a third of a 1200 px window, on the right), for a
#: window of width / height `VIEW_ASPECT`
PANEL_SHIFT, VIEW_ASPECT = 0.3, 1.6
#: [m] height of each target's prop above its held pose (UAV, hanging container), framed too
TARGET_HEIGHT = {"hybrid": 0.0, "upu3up": 2.6, "upr4": 1.8}
#: render frames kept in the tip-error trail
TRAIL_LENGTH = 240
#: [-] the tip-error trail's fixed magnification per mechanism, stated in its label: the
#: gangway tip is held to within about 0.1 mm (×10⁴: 0.1 mm draws as 1 m), the platforms'
#: tops drift by up to a metre or so at sea state 4 (the 3UPU_UP's stroke cannot follow
#: the heave; the 4-UPR holds level only), so they draw at true size
TRAIL_MAGNIFICATION = {"hybrid": 1e4, "upu3up": 1.0, "upr4": 1.0}
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
GHOST_TRAIL = tuple(int(255 * c) for c in GHOST[:3])
#: leg colour at margins 0 (at a limit), 0.25, 0.5 and 1 (mid-stroke)
_MARGIN_STOPS = np.array([0.0, 0.25, 0.5, 1.0])
_MARGIN_COLOURS = np.array([[220, 30, 30], [245, 150, 20], [190, 210, 40], [40, 190, 70]])


def margin_colours(margin: np.ndarray) -> np.ndarray:
    """RGB (n, 3) uint8 of leg margins (n,) [-]: green at mid-stroke → red at a limit."""
    m = np.clip(margin, 0.0, 1.0)
    return np.stack(
        [np.interp(m, _MARGIN_STOPS, _MARGIN_COLOURS[:, c]) for c in range(3)], -1
    ).astype(np.uint8)


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


def trail_label(scale: float) -> str:
    """The tip-error trail's label: its magnification and what a millimetre draws as."""
    if scale == 1.0:
        return "tip error ×1 (true size)"
    return f"tip error ×{scale:,.0f} (1 mm draws as {si(1e-3 * scale, 'm')})".replace(",", " ")


def mechanism_size(mechanism: Any) -> float:
    """[m] radius of the base hinge circle: the length scale of cameras, lines and props."""
    return float(np.max(np.linalg.norm(mechanism.layout.base_hinges, axis=-1)))


def mechanism_points(fs: FrameState) -> np.ndarray:
    """(n, 3) [m] inertial points that span the mechanism at the frame's state: its base
    hinges, its platform hinges and its landing point (the gangway tip, the top)."""
    layout, T_IB = fs.mechanism.layout, fs.transform_base
    T_IP = T_IB @ fs.transform_platform
    base = layout.base_hinges @ T_IB[:3, :3].T + T_IB[:3, 3]
    top = layout.platform_hinges @ T_IP[:3, :3].T + T_IP[:3, 3]
    return np.concatenate([base, top, fs.landing[None]])


def framed_points(fs: FrameState) -> np.ndarray:
    """(n, 3) [m] what a view of the mechanism and its target keeps in sight: the mechanism
    (`mechanism_points`), the held pose and the top of the target's prop over it."""
    held = fs.held[:3, 3]
    prop = held + np.array([0.0, 0.0, TARGET_HEIGHT[fs.scenario.mechanism]])
    return np.concatenate([mechanism_points(fs), [held, prop]])


def beside_panel(
    centre: np.ndarray, direction: np.ndarray, distance: float
) -> tuple[np.ndarray, np.ndarray]:
    """(camera position, look-at point) [m] that show `centre` from `direction` (unit, from
    the centre to the camera) at `distance`, a little left of the middle of the view: viser's
    control panel covers the right of the window (`PANEL_SHIFT`)."""
    right = np.cross(-direction, np.array([0.0, 0.0, 1.0]))
    right /= max(float(np.linalg.norm(right)), 1e-9)
    look_at = centre + PANEL_SHIFT * distance * np.tan(FOV / 2) * VIEW_ASPECT * right
    return look_at + distance * direction, look_at


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
    from twin.vessel.bem import GRIDS
    from twin.vessel.hulls import wetted_surface

    return panel_mesh(*wetted_surface(hull, GRIDS[hull.name].panel_size))


def topsides(hull: Hull, deck: float) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """A monohull above the waterline: walls standing on the waterline of the wetted surface
    (the Wigley form's, or the box's) up to the deck at height `deck`, and the deck."""
    from twin.vessel.bem import GRIDS
    from twin.vessel.hulls import wigley_half_breadth

    L, B = hull.length, hull.beam
    panel = GRIDS[hull.name].panel_size
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


def quaternion_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a ⊗ b for wxyz quaternions (..., 4)."""
    w1, v1, w2, v2 = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([w1 * w2 - np.sum(v1 * v2, -1, keepdims=True),
                           w1 * v2 + w2 * v1 + np.cross(v1, v2)], -1)  # fmt: skip


def paint(scene: trimesh.Scene) -> None:
    """Give each mesh of a URDF's scene (coloured by its link's `<color>`) a PBR material of
    that colour, `PAINT_METALLIC` and `PAINT_ROUGHNESS`, in place.

    A `<color>` is a display colour, as RViz shows it (sRGB); glTF's base colour factor is
    linear, so it is converted (IEC 61966-2-1), or every part would show paler than its URDF
    says (the platform's orange 0.85, 0.55, 0.15 as cream).
    """
    for mesh in scene.geometry.values():
        srgb = np.asarray(mesh.visual.main_color, dtype=float) / 255.0
        colour = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
        colour[3] = srgb[3]  # alpha is not a colour
        material = trimesh.visual.material.PBRMaterial(
            baseColorFactor=colour, metallicFactor=PAINT_METALLIC, roughnessFactor=PAINT_ROUGHNESS
        )
        mesh.visual = trimesh.visual.TextureVisuals(material=material)


def painted_urdf(path: Path) -> yourdfpy.URDF:
    """The URDF at `path` with its meshes (loaded as ViserUrdf loads them), `paint`ed."""
    urdf = yourdfpy.URDF.load(
        path, load_meshes=True, build_scene_graph=True,
        filename_handler=partial(yourdfpy.filename_handler_magic, dir=path.parent),
    )  # fmt: skip
    paint(urdf.scene)
    return urdf


class LiveUrdf(ViserUrdf):
    """`ViserUrdf` of the URDF at `path`, painted (`painted_urdf`), whose `update_cfg` sets
    only what each joint moves (`kwargs` go to ViserUrdf).

    ViserUrdf's own update runs yourdfpy's scene-graph forward kinematics and re-assigns both
    halves of every joint frame's pose: most of a frame's budget for the hybrid system's 28
    joints. A joint frame's pose in its parent is the joint origin times the joint's own
    motion, so a revolute joint only turns its frame (wxyz = q_origin ⊗ q(axis, θ)) and a
    prismatic joint only slides it (position = p_origin + R_origin axis d): one vectorised
    computation and one property per joint. (ViserUrdf's docstring invites copying or
    modifying it for finer control; loading and node naming stay ViserUrdf's.) The first call
    poses every frame, fixed joints included, through ViserUrdf; URDFs with mimic joints keep
    its update throughout.
    """

    def __init__(
        self, target: viser.ViserServer, path: Path, root_node_name: str, **kwargs: Any
    ) -> None:
        super().__init__(target, painted_urdf(path), root_node_name=root_node_name, **kwargs)
        index = {name: k for k, name in enumerate(self.get_actuated_joint_names())}
        joints = list(self._urdf.joint_map.values())
        frames = self._joint_frames[: len(joints)]  # the visual tree's, in joint_map order
        self._posed = False
        self._fast = all(j.mimic is None for j in joints)
        turn = [k for k, j in enumerate(joints) if j.type in ("revolute", "continuous")]
        slide = [k for k, j in enumerate(joints) if j.type == "prismatic"]
        origin = np.stack([np.eye(4) if j.origin is None else j.origin for j in joints])
        axis = np.stack([np.asarray(j.axis, float) for j in joints])
        self._turn = ([frames[k] for k in turn], [index[joints[k].name] for k in turn])
        self._turn_origin = matrix_to_wxyz(origin[turn, :3, :3])
        self._turn_axis = axis[turn]
        self._slide = ([frames[k] for k in slide], [index[joints[k].name] for k in slide])
        self._slide_origin = origin[slide, :3, 3]
        self._slide_direction = (origin[slide, :3, :3] @ axis[slide, :, None])[..., 0]

    def update_cfg(self, configuration: np.ndarray) -> None:
        """Pose the joint frames for joint values in `get_actuated_joint_names()` order."""
        if not (self._posed and self._fast):
            super().update_cfg(configuration)
            self._posed = True
            return
        frames, index = self._turn
        half = 0.5 * configuration[index]
        turn = np.concatenate([np.cos(half)[:, None], self._turn_axis * np.sin(half)[:, None]], -1)
        for frame, wxyz in zip(frames, quaternion_product(self._turn_origin, turn), strict=True):
            frame.wxyz = wxyz
        frames, index = self._slide
        positions = self._slide_origin + self._slide_direction * configuration[index][:, None]
        for frame, position in zip(frames, positions, strict=True):
            frame.position = position


class Trail:
    """A tip-error trail: the newest `TRAIL_LENGTH` deviations of a tip from its held position
    [m] (inertial) and the line segments that draw them, older samples fading to white.

    Args:
        scene: the viser scene; name: its node; colour: the newest segment's RGB.
        thickness: [m] of the segments.
    """

    def __init__(
        self, scene: Any, name: str, colour: tuple[int, int, int], thickness: float
    ) -> None:
        fade = np.linspace(0.25, 1.0, TRAIL_LENGTH - 1)[:, None, None]
        self.handle = scene.add_line_segments(
            name,
            points=np.zeros((TRAIL_LENGTH - 1, 2, 3)),
            colors=np.broadcast_to(
                (255 - fade * (255 - np.array(colour))).astype(np.uint8), (TRAIL_LENGTH - 1, 2, 3)
            ),
            thickness=thickness,
        )
        self.samples = np.zeros((TRAIL_LENGTH, 3))

    def reset(self, deviation: np.ndarray) -> None:
        """Every sample the deviation (3,) [m]: a (re)start."""
        self.samples[:] = deviation

    def push(self, deviation: np.ndarray) -> None:
        """The newest deviation (3,) [m] in, the oldest out."""
        self.samples = np.roll(self.samples, -1, axis=0)
        self.samples[-1] = deviation

    def draw(self, anchor: np.ndarray, scale: float, visible: bool) -> None:
        """The segments from `anchor` (3,) [m], the deviations magnified by `scale`."""
        points = anchor + scale * self.samples
        self.handle.points = np.stack([points[:-1], points[1:]], 1)
        self.handle.visible = visible


class TwinScene:
    """The scene nodes of one live session, built per mechanism and updated per frame.

    Args:
        server: the viser server to draw in.
    """

    def __init__(self, server: viser.ViserServer) -> None:
        self.server = server
        self.mechanism_name: str | None = None
        self.hull: Hull | None = None
        self.last: FrameState | None = None
        self.joint_values: dict[str, float] = {}  # last configuration sent to the URDF
        self.trail_scale = 1.0
        self._grid: tuple[np.ndarray, np.ndarray] = (np.zeros(1), np.zeros(1))
        self._weight = np.ones((1, 1, 1))
        self._flat = np.zeros((1, 1, 3))
        self.clip = (0.01, 1000.0)  # [m] the cameras' near and far planes
        self.ghost: LiveUrdf | None = None  # the comparison lane's mechanism
        self._sea_source: WaveComponents | None = None
        self.sun_azimuth = SUN_AZIMUTH  # [rad] (`sun_azimuth`)
        self._sea: WaveComponents | None = None
        self._trail_t = -np.inf  # [s] the newest sample of the trails
        self.ghost_trail: Trail | None = None  # the comparison lane's, while it is shown
        self._roots: list[str] = []

    # -- building -----------------------------------------------------------------------------
    def build(self, fs: FrameState) -> None:
        """(Re)build every node for the frame's mechanism: sea, vessel, URDF, legs, target."""
        for name in self._roots:  # removes the URDF too, a subtree of /base
            self.server.scene.remove_by_name(name)
        scene = self.server.scene
        name = fs.scenario.mechanism
        self.size = mechanism_size(fs.mechanism)
        self.hull = hull_for(fs.scenario)
        mount = MOUNTS[name]
        self._vessel_from_base = invert_transform(mount_transform(name))

        extent = float(np.clip(3.0 * self.hull.length, 40.0, 240.0))
        centre = 0.5 * fs.held[:2, 3]  # between the vessel and the target
        axis = ocean_axis(extent)
        self._grid = (centre[0] + axis, centre[1] + axis)
        self._weight = wave_weight(axis, axis, extent)[..., None]
        x, y = np.meshgrid(*self._grid, indexing="ij")
        self._flat = np.stack([x, y, np.zeros_like(x)], -1)
        self.ocean = scene.add_mesh_simple(
            "/ocean",
            vertices=self._ocean_vertices(fs),
            faces=ocean_faces(axis.size),
            color=SEA,
            material=SEA_MATERIAL,
            side="double",
            cast_shadow=False,
        )
        self.clip = (NEAR * extent, 1.2 * FOG_FAR * extent)
        scene.configure_fog(FOG_NEAR * extent, FOG_FAR * extent, color=SKY)

        self.vessel = scene.add_frame("/vessel", show_axes=False)
        for part, (mesh, colour) in hull_parts(self.hull, mount.lever_arm).items():
            scene.add_mesh_simple(
                f"/vessel/{part}", mesh.vertices, mesh.faces, color=colour, side="double",
                flat_shading=part not in SMOOTH_PARTS,
            )  # fmt: skip

        self.base = scene.add_frame("/base", show_axes=False)
        scene.add_frame("/base/robot", show_axes=False)
        self.robot = LiveUrdf(
            self.server, asset_path("urdf", f"{name}.urdf"), root_node_name="/base/robot"
        )
        self.top = scene.add_frame("/base/top", show_axes=False)
        if name == "upr4":
            for part, (mesh, colour) in landing_pad(fs.mechanism.pad_side).items():
                scene.add_mesh_simple(f"/base/top/{part}", mesh.vertices, mesh.faces, color=colour)
        n = fs.leg_lengths.size
        self.legs = scene.add_line_segments(
            "/base/legs",
            points=np.zeros((n, 2, 3)),
            colors=np.zeros((n, 2, 3), np.uint8),
            thickness=0.06 * float(np.mean(fs.leg_lengths)),
        )
        self.trail = Trail(scene, "/trail", TRAIL, 0.02 * self.size)
        self.trail_scale = TRAIL_MAGNIFICATION[name]
        self.trail_label = scene.add_label(
            "/trail_label", trail_label(self.trail_scale), anchor="bottom-center"
        )
        self.ghost = self.ghost_trail = None
        self._roots = ["/ocean", "/vessel", "/base", "/target", "/trail",
                       "/trail_label", "/ghost_label", "/ghost_trail"]  # fmt: skip
        self.restart(fs)
        # the camera frames the mechanism: new browsers start there, open ones move there
        position, look_at = self.camera_pose(FRAMING, fs)
        camera = self.server.initial_camera
        camera.position, camera.look_at = tuple(position), tuple(look_at)
        camera.up = (0.0, 0.0, 1.0)
        camera.fov = FOV
        camera.near, camera.far = self.clip
        self.last = fs
        self.set_camera(FRAMING, self.server.get_clients().values())
        self.mechanism_name = name  # last: readers see a complete build

    def matches(self, fs: FrameState) -> bool:
        """Whether the built nodes fit the frame (same mechanism on the same hull)."""
        return fs.scenario.mechanism == self.mechanism_name and hull_for(fs.scenario) is self.hull

    def restart(self, fs: FrameState) -> None:
        """After a (re)start: place the target at the new held pose and clear the trail."""
        scene = self.server.scene
        scene.remove_by_name("/target")
        name = fs.scenario.mechanism
        if name == "hybrid":
            scene.add_frame("/target", show_axes=False)
            for part, (mesh, colour) in transition_piece(fs.held, fs.transform_base).items():
                scene.add_mesh_simple(f"/target/{part}", mesh.vertices, mesh.faces, color=colour)
            scene.add_frame(
                "/target/held_tip",
                axes_length=0.3 * self.size,
                axes_radius=0.01 * self.size,
                position=fs.held[:3, 3],
                wxyz=matrix_to_wxyz(fs.held[:3, :3]),
            )
        else:
            parts = hovering_uav(fs.mechanism.pad_side) if name == "upr4" else hanging_container()
            scene.add_frame(
                "/target",
                show_axes=False,
                position=fs.held[:3, 3],
                wxyz=matrix_to_wxyz(fs.held[:3, :3]),
            )
            for part, (mesh, colour, opacity) in parts.items():
                scene.add_mesh_simple(
                    f"/target/{part}", mesh.vertices, mesh.faces, color=colour, opacity=opacity
                )
        self._sync_ghost(fs)
        self._reset_trails(fs)

    def _sync_ghost(self, fs: FrameState) -> None:
        """Add the comparison lane's ghost (a translucent copy of the mechanism on the same
        base, labelled with its planner) and its own tip-error trail when it starts; remove
        them when it stops."""
        scene = self.server.scene
        if fs.ghost is None:
            if self.ghost is not None:
                for name in ("/base/ghost", "/ghost_label", "/ghost_trail"):
                    scene.remove_by_name(name)
                self.ghost = self.ghost_trail = None
            return
        if self.ghost is None:
            scene.add_frame("/base/ghost", show_axes=False)
            self.ghost = LiveUrdf(
                self.server,
                asset_path("urdf", f"{fs.scenario.mechanism}.urdf"),
                root_node_name="/base/ghost",
                mesh_color_override=GHOST,
            )
            self.ghost_label = scene.add_label("/ghost_label", "", anchor="top-center")
            self.ghost_trail = Trail(scene, "/ghost_trail", GHOST_TRAIL, 0.02 * self.size)
        self.ghost_label.text = f"ghost: {fs.ghost.scenario.planner.upper()}"

    # -- per frame ----------------------------------------------------------------------------
    def update(self, fs: FrameState, show_trail: bool = True) -> None:
        """Move every node to the frame's state (call inside `server.atomic()`)."""
        T_IB, T_BP = fs.transform_base, fs.transform_platform
        self.ocean.vertices = self._ocean_vertices(fs)
        T_IV = T_IB @ self._vessel_from_base
        self.vessel.position, self.vessel.wxyz = T_IV[:3, 3], matrix_to_wxyz(T_IV[:3, :3])
        self.base.position, self.base.wxyz = T_IB[:3, 3], matrix_to_wxyz(T_IB[:3, :3])
        self.top.position, self.top.wxyz = T_BP[:3, 3], matrix_to_wxyz(T_BP[:3, :3])
        names = self.robot.get_actuated_joint_names()
        self.robot.update_cfg(np.array([fs.cfg[name] for name in names]))
        self.joint_values = {name: fs.cfg[name] for name in names}

        layout = fs.mechanism.layout
        top = layout.platform_hinges @ T_BP[:3, :3].T + T_BP[:3, 3]
        self.legs.points = np.stack([layout.base_hinges, top], 1)
        self.legs.colors = np.repeat(margin_colours(fs.leg_margin)[:, None], 2, 1)
        if self.ghost is not None and fs.ghost is not None:
            self.ghost.update_cfg(np.array([fs.ghost.cfg[name] for name in names]))
            top = T_IB @ fs.ghost.transform_platform
            self.ghost_label.position = top[:3, 3] - np.array([0.0, 0.0, 0.6 * self.size])

        self._update_trail(fs, show_trail)
        self.last = fs  # last: readers see a complete frame

    def _aim_sun(self, sea: WaveComponents) -> None:
        """Put the sun where the waves run to (`sun_azimuth`), in every browser."""
        self.sun_azimuth = sun_azimuth(sea)
        sun = self.server.scene.get_handle_by_name("/sun")
        if sun is not None:  # a position update reaches each browser's "/sun", its own too
            sun.position = tuple(sun_position(self.sun_azimuth))

    def _ocean_vertices(self, fs: FrameState) -> np.ndarray:
        if fs.sea is not self._sea_source:
            self._sea_source, self._sea = fs.sea, drawn_sea(fs.sea)
            self._aim_sun(self._sea)
        # The drawing frame moves with the vessel's mean velocity; the sea is fixed in the
        # world, where this frame's origin is at U t along x (heading 0).
        shift = fs.scenario.forward_speed * fs.t
        x, y = self._grid
        points = gerstner_points(self._sea, x + shift, y, fs.t, GERSTNER_Q)
        points[..., 0] -= shift
        points = self._flat + self._weight * (points - self._flat)  # calm beyond the waves
        return points.reshape(-1, 3).astype(np.float32)

    @staticmethod
    def _tip_deviation(fs: FrameState) -> np.ndarray:
        """(3,) [m] the landing point minus its held position, inertial
        (`FrameState.landing_offset`)."""
        return fs.landing_offset

    def _trails(self, fs: FrameState) -> list[tuple[Trail, FrameState]]:
        """The trails shown and the frame each follows: the mechanism's, and the ghost's
        while it is shown."""
        shown = [(self.trail, fs)]
        if self.ghost_trail is not None and fs.ghost is not None:
            shown.append((self.ghost_trail, fs.ghost))
        return shown

    def _reset_trails(self, fs: FrameState) -> None:
        for trail, frame in self._trails(fs):
            trail.reset(self._tip_deviation(frame))
        self._trail_t = fs.t

    def _update_trail(self, fs: FrameState, show: bool) -> None:
        """Both trails (the ghost's only while it is shown) at one magnification, so the two
        planners' tip errors compare by eye."""
        if fs.t > self._trail_t:
            for trail, frame in self._trails(fs):
                trail.push(self._tip_deviation(frame))
            self._trail_t = fs.t
        elif fs.t < self._trail_t:  # a restart the version check has not seen yet
            self._reset_trails(fs)
        shown = self._trails(fs)
        scale = self.trail_scale
        anchor = fs.held[:3, 3]
        for trail, _ in shown:
            trail.draw(anchor, scale, show)
        self.trail_label.visible = show
        self.trail_label.position = anchor + np.array([0.0, 0.0, 0.6 * self.size])

    # -- cameras ------------------------------------------------------------------------------
    def camera_pose(self, view: View, fs: FrameState) -> tuple[np.ndarray, np.ndarray]:
        """(camera position, look-at point) [m] of a preset view at the frame's state."""
        T_IB, held = fs.transform_base, fs.held[:3, 3]
        up = np.array([0.0, 0.0, 1.0])
        if view == "overview":  # high over the port bow: vessel, mechanism and target
            centre = 0.5 * (held + T_IB[:3, 3])
            reach = max(self.hull.length, 2.0 * float(np.linalg.norm(held - T_IB[:3, 3])))
            direction = np.array([0.3, 0.8, 0.6]) / np.linalg.norm([0.3, 0.8, 0.6])
            distance = 1.4 * reach * np.linalg.norm([0.3, 0.8, 0.6])
            extent = float(np.ptp(mechanism_points(fs), axis=0).max())  # [m] longest side
            # the farthest the camera may be for the mechanism to span OVERVIEW_MIN_PX
            farthest = extent * VIEW_HEIGHT_PX / (OVERVIEW_MIN_PX * 2.0 * np.tan(FOV / 2))
            if distance > farthest:  # a small mechanism: come in to it and its target
                distance = farthest
                points = framed_points(fs)
                centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
            return beside_panel(centre, direction, distance)
        if view == "walkway":
            if fs.scenario.mechanism == "hybrid":
                # a person at the gangway's slew bearing (3.1 m above the platform, URDF)
                eye = (T_IB @ fs.transform_platform @ np.array([0.0, 0.0, 3.1, 1.0]))[:3]
                return eye + 1.7 * up, held + 1.0 * up
            eye = (T_IB @ np.array([-3.0 * self.size, -3.0 * self.size, 0.0, 1.0]))[:3]
            return eye + 1.7 * up, held
        if view == "close-up":  # from the vessel's side of the target, a little aside
            back = T_IB[:2, 3] - held[:2]
            # a target held over its own mechanism (the platforms) gives no steady "vessel's
            # side": the base wanders around it with the waves, so the view is a fixed one
            far = np.linalg.norm(back) > 3.0 * self.size
            back = back / np.linalg.norm(back) if far else np.array([-0.6, -0.8])
            side = np.array([-back[1], back[0]])
            direction = np.r_[4.0 * np.asarray(back) + 2.5 * side, 3.0]
            direction /= np.linalg.norm(direction)
            # the whole mechanism (base to landing point) and its target's prop fit the view
            points = framed_points(fs)
            centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
            radius = float(np.max(np.linalg.norm(points - centre, axis=-1)))
            distance = CLOSE_UP_MARGIN * radius / np.sin(FOV / 2)
            return beside_panel(centre, direction, distance)
        raise ValueError(f"unknown view {view!r}; allowed: {VIEWS}")

    def set_camera(self, view: View, clients: Iterable[viser.ClientHandle]) -> None:
        """Point the clients' cameras at a preset view of the latest frame."""
        if self.last is None:
            return
        position, look_at = self.camera_pose(view, self.last)
        for client in clients:
            try:
                with client.atomic():
                    client.camera.up_direction = (0.0, 0.0, 1.0)
                    client.camera.fov = FOV
                    client.camera.position = position
                    client.camera.look_at = look_at
                    client.camera.near, client.camera.far = self.clip
            except Exception:  # a browser that is leaving, or has not sent its camera yet
                logger.debug("camera of client %s not set", client.client_id, exc_info=True)


class Viewer:
    """A running viser server showing a live session: scene, GUI and the render thread.

    The render thread reads the session (never steps it) `FPS` times a second and pushes one
    atomic update of existing handles; the session's own thread steps the simulation, so a
    slow or vanished browser (viser buffers per client) never stalls it.

    Attributes:
        session: the live session shown.
        server: the viser server.
        scene: the 3D scene.
        gui: the control panel.
        frames: render frames completed so far.
        frame_cpu: [s] CPU time of the render thread per frame (moving average).
        renderers: client id → the WebGL renderer its page reported (`report_renderer`).
    """

    def __init__(
        self,
        session: LiveSession,
        server: viser.ViserServer,
        access: Access | None = None,
        *,
        store: Any = None,
        sweeps: Any = None,
        api_url: str | None = None,
        graphics: str = "full",
    ) -> None:
        self.session = session
        self.server = server
        self.renderers: dict[int, str] = {}
        self._keys: dict[str, int] = {}  # a page's report key → its client id
        self.frames = 0
        self.frame_cpu = 0.0
        self._blas = threadpoolctl.ThreadpoolController() if threadpoolctl else None
        fs = self._read()
        self.scene = TwinScene(server)
        server.scene.set_background_image(np.full((4, 4, 3), SKY, np.uint8), format="png")
        self.scene.build(fs)
        self.gui = TwinGui(
            server, session, fs, on_camera=self.scene.set_camera, access=access, store=store,
            sweeps=sweeps, api_url=api_url, graphics=graphics,
            on_graphics=lambda client, mode: configure_graphics(
                client.scene, mode, self.scene.sun_azimuth
            ),
        )  # fmt: skip
        server.on_client_connect(self._ask_renderer)
        server.on_client_disconnect(self._forget_renderer)
        self._version = fs.version
        self._shown: tuple | None = None  # what the scene's nodes show (`_draw`)
        self._frame(fs)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="twin-viewer", daemon=True)
        self._thread.start()

    @property
    def port(self) -> int:
        """The port the viser server listens on."""
        return self.server.get_port()

    # -- the browser's WebGL renderer ---------------------------------------------------------
    def _ask_renderer(self, client: viser.ClientHandle) -> None:
        """Have the new browser's page report its WebGL renderer (`DETECT_RENDERER_JS`), with
        a random key of its own: a page cannot report for another browser."""
        key = secrets.token_urlsafe(16)
        self._keys[key] = client.client_id
        source = DETECT_RENDERER_JS.replace("__KEY__", json.dumps(key)).replace(
            "__PATH__", json.dumps(RENDERER_PATH)
        )
        try:  # viser's own message for running a script (it sends plotly.js so)
            client._websock_connection.queue_message(
                viser._messages.RunJavascriptMessage(source=source)
            )
        except Exception:  # a viser without it: the browser keeps the server's graphics
            logger.warning("viewer: cannot ask browser %s for its renderer", client.client_id,
                           exc_info=True)  # fmt: skip

    def _forget_renderer(self, client: viser.ClientHandle) -> None:
        self.renderers.pop(client.client_id, None)
        for key in [k for k, c in self._keys.items() if c == client.client_id]:
            self._keys.pop(key, None)

    def report_renderer(self, key: str, renderer: str) -> None:
        """A page's WebGL renderer (its first report per key counts): a software renderer
        (`software_renderer`) in "full" graphics switches that browser to "light", and a
        notification says why and how to switch back (View → Graphics)."""
        client_id = self._keys.pop(key, None)
        if client_id is None:
            return
        self.renderers[client_id] = renderer
        logger.info("viewer: browser %s renders with %r", client_id, renderer)
        if not software_renderer(renderer):
            return
        # its panel may still be under construction: give it a few seconds
        wait = time.monotonic() + 5.0
        while (panel := self.gui.panels.get(client_id)) is None and time.monotonic() < wait:
            time.sleep(0.05)
        if panel is None or panel.graphics.value != "full":
            return
        self.gui.set_graphics(panel, "light")
        panel.client.add_notification(
            "Light graphics",
            f"This browser draws WebGL on the CPU ({renderer[:80]}), so the viewer switched it "
            "to light graphics (no environment map, no shadows). View → Graphics switches "
            "back to full.",
            auto_close_seconds=12.0,
        )  # fmt: skip

    def stop(self) -> None:
        """Stop the render thread and the viser server (the session keeps running)."""
        self._stop.set()
        self._thread.join(timeout=5)
        self.gui.close()
        self.server.stop()

    def _read(self) -> FrameState:
        while (fs := read_frame(self.session)) is None:
            time.sleep(0.001)
        return fs

    def _run(self) -> None:
        period = 1.0 / FPS
        deadline = time.perf_counter()
        while not self._stop.wait(max(0.0, deadline - time.perf_counter())):
            # a late frame moves the schedule instead of bursting to catch up
            deadline = max(deadline + period, time.perf_counter())
            cpu = time.thread_time()
            try:
                fs = read_frame(self.session)
                if fs is not None:
                    self._frame(fs)
            except Exception:  # one bad frame must not end the view of a running session
                logger.exception("render frame failed")
            self.frame_cpu += 0.05 * (time.thread_time() - cpu - self.frame_cpu)

    def _frame(self, fs: FrameState) -> None:
        # A frame's matrix products are small (the sea: 3 × (48 × 96) @ (96 × 48) complex),
        # yet OpenBLAS spreads them over every core and its workers then spin-wait for the
        # next call; at 40 calls a second they never sleep, burning a core and starving this
        # loop (measured: 18-27 fps at ~110 % CPU; one BLAS thread: 40 fps at ~25 %).
        with (
            self._blas.limit(limits=1, user_api="blas") if self._blas else contextlib.nullcontext()
        ):
            self._draw(fs)
        self.frames += 1

    def _draw(self, fs: FrameState) -> None:
        if fs.version != self._version:
            self._version = fs.version
            self._shown = None
            if self.scene.matches(fs):
                self.scene.restart(fs)
            else:  # another mechanism or vessel
                self.scene.build(fs)
            self.gui.restart(fs)
        # a paused session (or replay) shows the same sample frame after frame: its nodes are
        # not sent again, which spares every browser decoding the same sea 40 times a second
        shown = (fs.version, fs.t, id(fs.sea), self.gui.trail, fs.ghost is None)
        with self.server.atomic():
            if shown != self._shown:
                self._shown = shown
                self.scene.update(fs, show_trail=self.gui.trail)
            self.gui.update(fs)


#: one viewer starts its websocket server at a time (the handshake check is added to it then)
_STARTING = threading.Lock()
#: messages from a browser that ask the server to open (or close) a public share tunnel
_SHARE_MESSAGES = ("ShareUrlRequest", "ShareUrlDisconnect")

Handshake = Callable[[Any, Any], Any]


@contextlib.contextmanager
def _checked_handshake(check: Handshake) -> Iterator[list[bool]]:
    """While viser starts its websocket server, give it `check` as the first step of every
    opening handshake: `check(connection, request)` returns a refusal (an HTTP response) or
    None to let viser's own handling go on. Yields a list that holds True once installed.

    viser (1.1) serves through `websockets.asyncio.server.serve` with a `process_request` of
    its own (its static files); the wrapper composes the two, for that call only.
    """
    import websockets.asyncio.server as ws_server

    original = ws_server.serve
    installed: list[bool] = []

    def serve(handler: Any, *args: Any, process_request: Any = None, **kwargs: Any) -> Any:
        viser_own = process_request

        def checked(connection: Any, request: Any) -> Any:
            refusal = check(connection, request)
            if refusal is not None:
                return refusal
            return None if viser_own is None else viser_own(connection, request)

        installed.append(True)
        return original(handler, *args, process_request=checked, **kwargs)

    with _STARTING:
        ws_server.serve = serve  # type: ignore[assignment]
        try:
            yield installed
        finally:
            ws_server.serve = original  # type: ignore[misc]


def sun_azimuth(sea: WaveComponents) -> float:
    """[rad] the sun's azimuth from +x towards +y: where the drawn sea's waves run to (the
    amplitude-weighted mean of the components' directions), so their slopes face towards
    and away from it and its light tells them apart (`SEA_MATERIAL`)."""
    a = sea.amplitude
    return float(np.arctan2(np.sum(a * np.sin(sea.direction)), np.sum(a * np.cos(sea.direction))))


def sun_position(azimuth: float) -> np.ndarray:
    """(3,) [m] where the sun node stands: far away at `SUN_ELEVATION` and `azimuth` (a
    three.js directional light shines from its position towards the world origin)."""
    return 1000.0 * np.array([np.cos(azimuth) * np.cos(SUN_ELEVATION),
                              np.sin(azimuth) * np.cos(SUN_ELEVATION),
                              np.sin(SUN_ELEVATION)])  # fmt: skip


def configure_graphics(scene: Any, graphics: str, azimuth: float = 0.0) -> None:
    """Light a scene (the server's: every browser; a client's: that browser alone) for one
    of `GRAPHICS`.

    viser's default lights are replaced: its key light stands overhead, where a wave slope
    of a few degrees barely changes the light it gets. A low sun (`SUN_ELEVATION`) shades the
    wave slopes and the vessel's sides; a weaker light from above and, in "light", the
    sky's ambient light (in place of the environment map, at no cost per pixel) fill the
    rest. "full" adds the environment map (viser's built-in one, "city") and the sun's
    cascaded shadows. `azimuth` [rad]: the sun's (`sun_azimuth`).
    """
    full = graphics == "full"
    scene.configure_environment_map("city" if full else None)
    scene.configure_default_lights(enabled=False, cast_shadow=False)
    scene.add_light_directional(
        "/sun", color=SUN, intensity=SUN_INTENSITY, cast_shadow=full,
        position=tuple(sun_position(azimuth)),
    )  # fmt: skip
    scene.add_light_directional(
        "/overhead", intensity=OVERHEAD_INTENSITY, position=(-200.0, 0.0, 1000.0)
    )
    scene.add_light_ambient("/sky_light", color=SKY, intensity=0.0 if full else AMBIENT)


def software_renderer(renderer: str) -> bool:
    """Whether a WebGL renderer string (WEBGL_debug_renderer_info's) names a renderer that
    draws on the CPU: the names viser's own client warns about (SwiftShader, llvmpipe,
    softpipe, "software"), and Windows' "Microsoft Basic Render Driver"."""
    name = renderer.lower()
    return any(word in name for word in SOFTWARE_RENDERERS)


def check_graphics(graphics: str) -> None:
    """Raises TwinError (a ValueError) unless `graphics` is one of `GRAPHICS`."""
    if graphics not in GRAPHICS:
        raise TwinError(f"graphics {graphics!r} unknown; one of: {', '.join(GRAPHICS)}")


def start_viewer(
    session: LiveSession,
    host: str = "127.0.0.1",
    port: int = 8080,
    access: Access | None = None,
    *,
    store: Any = None,
    sweeps: Any = None,
    api_url: str | None = None,
    graphics: str = "full",
) -> Viewer:
    """Serve the live twin in viser: build scene and GUI and start the render thread.

    The caller runs the session (`session.start()`); the viewer only reads it, and its GUI
    writes through `session.patch`, `play`, `pause`, `step` and `reset`.

    Args:
        session: the live session to show and control.
        host: interface to bind (viser's own default would be 0.0.0.0: all of them).
        port: port to listen on; viser takes the next free one if it is in use.
        access: the server's access policy: the Host names every request must carry, the
            origins the websocket accepts (its own, at the viewer's actual port too) and the
            token that unlocks a browser's controls. Default: loopback names and origins, no
            token.
        store: the run store (`twin.web.store.RunStore`): its done runs can be replayed
            from the panel's Replay folder.
        sweeps: the runner of sweeps (`twin.web.jobs.SweepRunner`, the REST app's): with a
            store, the Operability folder runs sweeps around the current sea.
        api_url: the REST API's address, for links to stored sweeps.
        graphics: one of `GRAPHICS`: "light" renders without the environment map and
            shadows (measured in headless Chromium's software WebGL, at `?fixedDpr=0.5`,
            while the session runs: the page answers a call in 0.45 s instead of 5-8 s).

    Returns:
        The running viewer: `.port`, `.stop()`.

    Raises:
        TwinError: `graphics` is not one of `GRAPHICS` (`check_graphics`); nothing is
            started.
        TwinError: the handshake check could not be added to viser's server (a viser that
            starts its websocket server another way): nothing is left running.
    """
    check_graphics(graphics)
    quiet_malformed_messages()  # a client's garbage: one line per client per minute (issue 30)
    access = access if access is not None else Access()
    bound: list[int] = []
    viewers: list[Viewer] = []  # the viewer, once it is built (renderer reports)

    def check(connection: Any, request: Any) -> Any:
        # Host first, on every request (the page, its assets, the websocket): as REST does.
        hosts = request.headers.get_all("Host")  # one, or it is no Host (RFC 9112 § 3.2)
        named = hosts[0] if len(hosts) == 1 else ", ".join(hosts) or None
        if len(hosts) != 1 or not access.allows_host(named):
            logger.warning("viewer: request for Host %r refused", named)
            return connection.respond(
                http.HTTPStatus.BAD_REQUEST,
                f"Host {named!r} is not a name this server answers to; start it with "
                "--allow-host NAME to allow one\n",
            )
        url = urlsplit(request.path)
        if url.path.endswith(RENDERER_PATH):  # a page telling its WebGL renderer
            query = parse_qs(url.query)
            key, name = query.get("key", [""])[0], query.get("renderer", [""])[0][:200]
            for viewer in viewers:  # a key it gave out: handled off the server's event loop
                if key in viewer._keys:  # (it sends to the browser, and may wait for a panel)
                    threading.Thread(
                        target=viewer.report_renderer, args=(key, name), daemon=True
                    ).start()
            return connection.respond(http.HTTPStatus.OK, "noted\n")
        if request.headers.get("Upgrade", "").lower() != "websocket":
            return None  # the page and its assets: the same for anyone it answers to
        origins = request.headers.get_all("Origin")
        if not origins:
            return None  # no Origin: not a browser page (a script); the token still applies
        try:  # websockets reads headers as ASCII with surrogate escapes; UTF-8 text or 400
            origins = [o.encode("ascii", "surrogateescape").decode("utf-8") for o in origins]
        except UnicodeError:
            logger.warning("viewer: websocket with a non-UTF-8 Origin refused")
            return connection.respond(
                http.HTTPStatus.BAD_REQUEST, "Origin header is not UTF-8 text: not an origin\n"
            )
        origin = ", ".join(origins)  # two Origins are no origin: refused below
        if len(origins) == 1 and access.allows_origin(origin, port=bound[0] if bound else port):
            return None
        logger.warning("viewer: cross-origin websocket from %s refused", origin)
        return connection.respond(
            http.HTTPStatus.FORBIDDEN, f"cross-origin websocket from {origin} refused\n"
        )

    with _checked_handshake(check) as installed:
        server = viser.ViserServer(host=host, port=port, label="wave-twin", verbose=False)
    bound.append(server.get_port())
    if not installed:
        server.stop()
        raise TwinError(
            f"viser {viser.__version__}: could not add the Host and origin checks; the viewer "
            "is not started (serve REST only with --no-viewer, or use a supported viser)"
        )
    websock = server._websock_server  # viser's own server object (no public accessor)
    for name in _SHARE_MESSAGES:
        message = getattr(viser._messages, name, None)
        if message is not None and message in websock._incoming_handlers:
            websock.unregister_handler(message)
    server.gui.configure_theme(control_width="large", show_share_button=False)
    configure_graphics(server.scene, graphics)
    try:
        viewer = Viewer(session, server, access, store=store, sweeps=sweeps, api_url=api_url,
                        graphics=graphics)  # fmt: skip
        viewers.append(viewer)
        return viewer
    except Exception:
        server.stop()
        raise

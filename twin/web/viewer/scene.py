"""The 3D scene of the live twin (`TwinScene`), drawn in the simulation's inertial
(equilibrium) frame, z up:

- the sea surface: one mesh whose vertices move every frame (Gerstner points of the simulated
  sea, `twin.sea.surface`), centred on the work site; beyond the waves its grid widens to
  the horizon, flat, and the scene's fog (the sky's colour) hides its far edge;
- the vessel hull (`twin.vessel.HULLS`) as the panels its RAOs were solved on below the
  waterline (`twin.web.viewer.meshes`), topsides above, posed from the base pose and the
  mount: ᴵT_B = ᴵT_V · ᵛT_B, so ᴵT_V = ᴵT_B · ᵛT_B⁻¹;
- the mechanism from its URDF (`assets/urdf`, `twin.web.viewer.urdf`) under a frame that
  follows the base pose, its joints from `twin.mechanisms.urdf.joint_configuration`; with a
  second planner compared (`compare_planner`), its lane again as a translucent ghost on the
  same base;
- the legs again as thick lines coloured by their margin to the stroke limits, green → red;
- the fixed target in the inertial frame: a wind-turbine transition piece with its access
  platform (hybrid gangway), a hovering UAV over the landing pad's held pose (4-UPR), a
  crane-hung container over the cargo platform's held pose (3UPU_UP);
- a trail of the tip error (where the landing point is minus where it is held,
  `FrameState.landing_offset`), magnified by a power of ten that fits the error shown to the
  mechanism (`trail_magnification`) and that its label states.

Nodes are added when a mechanism is built (at start and when the session switches mechanism,
when every browser's camera is pointed at the new mechanism, `twin.web.viewer.cameras`) and
otherwise only updated through their handles, so viser's per-client buffers keep just the
newest value of each property and a slow browser only ever receives the latest frame.
"""

from __future__ import annotations

import logging
from typing import Any, Literal

import numpy as np
import viser

from twin.assets import asset_path
from twin.sim.registries import MOUNTS, Hull, WaveComponents, gerstner_points
from twin.spatial import invert_transform, matrix_to_wxyz
from twin.web.viewer.cameras import FOV, FRAMING, Cameras, mechanism_size
from twin.web.viewer.frame_state import FrameState
from twin.web.viewer.graphics import SUN_AZIMUTH, sun_azimuth, sun_position
from twin.web.viewer.meshes import (
    FOG_FAR,
    FOG_NEAR,
    GERSTNER_Q,
    GHOST,
    GHOST_TRAIL,
    NEAR,
    SEA,
    SKY,
    SMOOTH_PARTS,
    TRAIL,
    drawn_sea,
    hanging_container,
    hovering_uav,
    hull_for,
    hull_parts,
    landing_pad,
    mount_transform,
    ocean_axis,
    ocean_faces,
    transition_piece,
    wave_weight,
)
from twin.web.viewer.readout import si
from twin.web.viewer.urdf import LiveUrdf

logger = logging.getLogger(__name__)

#: the sea's material: three.js' toon shading in three bands of the sun's incidence
#: (MeshToonMaterial: band edges at N·L = ±1/3). With the sun a little higher than
#: asin(1/3) = 19.5° (`SUN_ELEVATION`), a level sea sits in the upper band and every wave
#: slope turned more than 1.5° away from the sun drops into the middle one: the waves' backs
#: draw as darker bands, so wave fronts and crests read at a glance, in either graphics
#: mode (the per-vertex normals are three.js', computed from the moving vertices); a calm
#: sea stays one colour. Per pixel it costs what the standard material does, less.
SEA_MATERIAL: Literal["standard", "toon3", "toon5"] = "toon3"

#: render frames kept in the tip-error trail
TRAIL_LENGTH = 240
#: [-] the tip-error trail's largest magnification: the gangway tip held to 0.1 mm draws as 1 m
MAX_MAGNIFICATION = 1e4
#: [-] the trail's largest offset drawn, a fraction of the mechanism's size: the trail stays
#: on the mechanism, never a line across the scene
TRAIL_SPAN = 0.5


def trail_magnification(deviation: float, size: float) -> float:
    """[-] the tip-error trail's magnification: the largest power of ten, from 1 (true size)
    to `MAX_MAGNIFICATION`, that draws the largest deviation shown [m] within `TRAIL_SPAN` of
    the mechanism's size [m]; a trail of a tip held to a tenth of a millimetre draws magnified,
    one a metre off at true size."""
    if deviation <= 0.0:
        return MAX_MAGNIFICATION
    power = np.floor(np.log10(TRAIL_SPAN * size / deviation))
    return float(10.0 ** np.clip(power, 0.0, np.log10(MAX_MAGNIFICATION)))

#: leg colour at margins 0 (at a limit), 0.25, 0.5 and 1 (mid-stroke)
_MARGIN_STOPS = np.array([0.0, 0.25, 0.5, 1.0])
_MARGIN_COLOURS = np.array([[220, 30, 30], [245, 150, 20], [190, 210, 40], [40, 190, 70]])


def margin_colours(margin: np.ndarray) -> np.ndarray:
    """RGB (n, 3) uint8 of leg margins (n,) [-]: green at mid-stroke → red at a limit."""
    m = np.clip(margin, 0.0, 1.0)
    return np.stack(
        [np.interp(m, _MARGIN_STOPS, _MARGIN_COLOURS[:, c]) for c in range(3)], -1
    ).astype(np.uint8)


def trail_label(scale: float) -> str:
    """The tip-error trail's label: its magnification and what a millimetre draws as."""
    if scale == 1.0:
        return "tip error ×1 (true size)"
    return f"tip error ×{scale:,.0f} (1 mm draws as {si(1e-3 * scale, 'm')})".replace(",", " ")


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


class TwinScene(Cameras):
    """The scene nodes of one live session, built per mechanism and updated per frame.

    Args:
        server: the viser server to draw in.
    """

    def __init__(self, server: viser.ViserServer) -> None:
        super().__init__()
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
        self.trail_scale = MAX_MAGNIFICATION  # fits the error shown from the first frame on
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
        self.frame(self.server.get_clients().values())
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
        self.ghost_label.text = f"ghost: {fs.ghost.scenario.planner_name.upper()}"

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
        assert self._sea is not None  # drawn above on the first frame
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
        largest = max(float(np.linalg.norm(trail.samples, axis=1).max()) for trail, _ in shown)
        scale = trail_magnification(largest, self.size)
        if scale != self.trail_scale:
            self.trail_scale = scale
            self.trail_label.text = trail_label(scale)
        anchor = fs.held[:3, 3]
        for trail, _ in shown:
            trail.draw(anchor, scale, show)
        self.trail_label.visible = show
        self.trail_label.position = anchor + np.array([0.0, 0.0, 0.6 * self.size])

    # -- cameras ------------------------------------------------------------------------------

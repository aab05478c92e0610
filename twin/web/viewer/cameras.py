"""The camera presets (overview, walkway, close-up): what each view keeps in sight and where
its camera stands, clear of the control panel.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterable
from typing import Any, Literal

import numpy as np
import viser

from twin.web.viewer.frame_state import FrameState

logger = logging.getLogger(__name__)

#: the camera presets
VIEWS = ("overview", "walkway", "close-up")
View = Literal["overview", "walkway", "close-up"]

#: the view every browser gets when a mechanism is built: the mechanism and its target fill
#: it, however small the mechanism is next to its vessel
FRAMING: View = "close-up"
#: [s] after a build, a browser whose camera reports another view than the framing is put back
#: at it until it has reported the framing once: the camera message it sent before the new
#: framing reached it can arrive after it, and viser then takes that old view for the
#: browser's (seen on a loaded machine, 2 s and more after the build). The hold ends at the
#: browser's first report of the framing (messages from one browser arrive in order, so none
#: sent before it is still to come), or after this long for a browser that never reports (a
#: hidden tab draws no frame, so it sends no camera)
FRAMING_HOLD = 30.0
#: [s] least time between two re-framings of the browsers still held (one that is slow to
#: answer is not sent the same view at every frame)
FRAMING_RESEND = 0.25
#: [-] a reported view within this share of the framing's distance is the framing
FRAMING_TOLERANCE = 0.05
#: [rad] the cameras' vertical field of view (viser's default, set on every camera)
FOV = float(np.radians(75.0))
#: [px] the overview draws the mechanism's longest side at least this long, face on, in a
#: window this tall (a laptop's browser): seen at the overview's slant, ≥ 80 px (the issue's
#: least; measured in tests/web/viewer/test_browser_scene.py). A small
#: mechanism on a large vessel (the 3UPU_UP's 1.3 m on 70 m) is not shrunk to fit the whole
#: vessel: the overview then comes in to the deck around it (the cameras zoom; the scene is
#: never drawn out of scale)
OVERVIEW_MIN_PX, VIEW_HEIGHT_PX = 120.0, 720.0
#: [-] the close-up's distance over the one at which the bounding sphere of the mechanism and its
#: target's underside just fits the field of view (their box, inside it, leaves a margin)
CLOSE_UP_MARGIN = 1.0
#: [-] the views put what they show this fraction of the view's half-width left of its middle,
#: clear of the control panel (about a third of a 1200 px window, on the right), for a
#: window of width / height `VIEW_ASPECT`
PANEL_SHIFT, VIEW_ASPECT = 0.3, 1.6
#: [m] height of each target prop's underside above its held pose (the UAV's skids, the
#: hanging container's floor, `twin.web.viewer.meshes`), framed too: the prop above it may
#: leave the close-up at its top, so the mechanism fills at least a third of the view
TARGET_HEIGHT = {"hybrid": 0.0, "upu3up": 1.5, "upr4": 1.4}


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


class Cameras:
    """`TwinScene`'s camera presets (it has `hull`, `size`, `last`, `clip`, `server`)."""

    hull: Any
    size: float
    last: FrameState | None
    clip: tuple[float, float]
    server: viser.ViserServer

    def __init__(self) -> None:
        #: [s] monotonic time until which `settle_framing` puts browsers back at the framing
        self.framing_until = 0.0
        #: client ids of the browsers held at the framing: not yet reported it since the build
        self.unframed: frozenset[int] = frozenset()
        #: [s] monotonic time of the last re-framing (`FRAMING_RESEND`)
        self.reframed_at = -np.inf
        #: guards `unframed`, which viser's event loop (`camera_reported`) and the render
        #: thread (`frame`, `settle_framing`, `set_camera`) both replace: a lost update would
        #: hold a browser that has reported the framing, and snap its user's camera back. The
        #: cameras are sent under it too, so a view's message and the hold's change are one step
        self._holding = threading.Lock()

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

    def frame(self, clients: Iterable[viser.ClientHandle]) -> None:
        """Point the clients' cameras at the framing of a new build, and hold them there until
        each reports it (`settle_framing`, `camera_reported`)."""
        clients = list(clients)
        with self._holding:
            self._send(FRAMING, clients)
            self.unframed = frozenset(client.client_id for client in clients)
            self.framing_until = time.monotonic() + FRAMING_HOLD

    def _framing_view(self) -> np.ndarray | None:
        """(3,) [m] the framing's view, from its look-at point to its position, at the latest
        frame (None before the first)."""
        if self.last is None:
            return None
        position, look_at = self.camera_pose(FRAMING, self.last)
        return position - look_at

    @staticmethod
    def _shows_framing(camera: viser.CameraHandle, view: np.ndarray | None) -> bool:
        """Whether the camera's view (from its look-at point to its position) is the framing's
        `view` (`_framing_view`), within `FRAMING_TOLERANCE` of its distance."""
        if view is None:
            return False
        reported = camera.position - camera.look_at
        return bool(
            np.linalg.norm(reported - view) <= FRAMING_TOLERANCE * float(np.linalg.norm(view))
        )

    async def camera_reported(self, camera: viser.CameraHandle) -> None:
        """A browser's camera message (viser awaits this on its event loop right after it
        took the message in, so `camera` holds what the browser sent): its first report of
        the framing ends its hold."""
        client_id = camera.client.client_id
        with self._holding:
            if client_id in self.unframed and self._shows_framing(camera, self._framing_view()):
                self.unframed = self.unframed - {client_id}

    def settle_framing(self, clients: Iterable[viser.ClientHandle]) -> None:
        """Each frame: a held browser (`unframed`) whose camera shows another view than the
        framing is put at the framing again, at most every `FRAMING_RESEND`. Decided and sent
        under the hold's lock: a view asked for meanwhile (`set_camera`) ends the hold, and a
        re-framing decided before it but sent after would replace the view asked for."""
        if not self.unframed:
            return
        now = time.monotonic()
        present = {client.client_id: client for client in clients}
        view = self._framing_view()
        with self._holding:
            if now > self.framing_until:
                self.unframed = frozenset()
            self.unframed = self.unframed.intersection(present)
            off = []
            for client_id in self.unframed:
                try:
                    if not self._shows_framing(present[client_id].camera, view):
                        off.append(present[client_id])
                except Exception:  # a browser that has not sent its camera yet
                    continue
            if off and now - self.reframed_at >= FRAMING_RESEND:
                self.reframed_at = now
                self._send(FRAMING, off)

    def set_camera(self, view: View, clients: Iterable[viser.ClientHandle]) -> None:
        """Point the clients' cameras at a preset view of the latest frame (another view than
        the framing ends `settle_framing`'s hold)."""
        with self._holding:
            if view != FRAMING:
                self.unframed = frozenset()
            self._send(view, clients)

    def _send(self, view: View, clients: Iterable[viser.ClientHandle]) -> None:
        """Send the clients' cameras to a preset view of the latest frame (the caller holds
        `_holding`)."""
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

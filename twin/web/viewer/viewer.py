"""The live twin in viser: `start_viewer` serves the scene (`twin.web.viewer.scene`) and the
control panel (`twin.web.viewer.gui`) of a live session, and `Viewer` runs the render loop.

The render loop reads the session (never steps it) and pushes one atomic update of existing
handles per frame, `FPS` times a second, while at least one browser is connected. With none
it does no render work at all (no sea vertices, no URDF, no plots, no readout): it sleeps
until a browser connects, and a browser that connects gets the newest frame at once (a
mechanism built meanwhile included). The session's own thread steps the simulation, so a
slow or vanished browser (viser buffers per client) never stalls it.

Before viser serves anything, every request to the viewer's port passes the REST API's Host
check and every websocket handshake an Origin check (`twin.web.viewer.handshake`, installed
through `twin.web.viewer.viser_adapter`); the share-tunnel requests a browser may send are not
handled at all.
"""

from __future__ import annotations

import contextlib
import json
import logging
import secrets
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
import viser

try:  # optional: without it the render loop runs, slower (see `Viewer._frame`)
    import threadpoolctl
except ImportError:
    threadpoolctl = None

from twin.errors import TwinError
from twin.sim.live import LiveSession
from twin.web.viewer import viser_adapter
from twin.web.viewer.frame_state import FrameState, read_frame
from twin.web.viewer.graphics import (
    DETECT_RENDERER_JS,
    RENDERER_PATH,
    check_graphics,
    configure_graphics,
    software_renderer,
)
from twin.web.viewer.gui import TwinGui
from twin.web.viewer.handshake import request_check
from twin.web.viewer.meshes import SKY
from twin.web.viewer.scene import TwinScene

if TYPE_CHECKING:  # the server's policy, handed in (`start_viewer`)
    from twin.web.access import Access

logger = logging.getLogger(__name__)

#: [Hz] render-loop rate; issue 6 asks for ≥ 30 fps, the margin absorbs slow frames
FPS = 40.0
#: [s] longest sleep of the render loop while no browser is connected: a connecting browser
#: wakes it at once (`Viewer._connected`); this only bounds how late a stop is noticed
IDLE_WAIT = 1.0


class Viewer:
    """A running viser server showing a live session: scene, GUI and the render thread.

    The render thread reads the session (never steps it) `FPS` times a second and pushes one
    atomic update of existing handles, while a browser is connected; with none it sleeps
    (`idle_waits` counts its sleeps). The session's own thread steps the simulation, so a slow
    or vanished browser (viser buffers per client) never stalls it.

    Attributes:
        session: the live session shown.
        server: the viser server.
        scene: the 3D scene.
        gui: the control panel.
        frames: render frames completed so far.
        idle_waits: times the render loop slept for want of a browser.
        frame_cpu: [s] CPU time of the render thread per frame (moving average).
        renderers: client id → the WebGL renderer its page reported (`report_renderer`).
    """

    def __init__(
        self,
        session: LiveSession,
        server: viser.ViserServer,
        access: Access,
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
        self._keys_lock = threading.Lock()  # renderers and keys: viser's and report threads
        self.frames = 0
        self.idle_waits = 0
        self._stop = threading.Event()
        self._wake = threading.Event()  # a browser connected (or the viewer stops)
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
        server.on_client_connect(self._connected)
        server.on_client_disconnect(self._forget_renderer)
        self._version = fs.version
        self._shown: tuple | None = None  # what the scene's nodes show (`_draw`)
        self._frame(fs)
        self._thread = threading.Thread(target=self._run, name="twin-viewer", daemon=True)
        self._thread.start()

    @property
    def port(self) -> int:
        """The port the viser server listens on."""
        return self.server.get_port()

    # -- the browser's WebGL renderer ---------------------------------------------------------
    def _connected(self, client: viser.ClientHandle) -> None:
        """A browser connected: wake the render loop, and have its page report its WebGL
        renderer (`DETECT_RENDERER_JS`), with a random key of its own: a page cannot report
        for another browser. Its camera messages end its framing hold (`camera_reported`)."""
        self._wake.set()
        client.camera.on_update(self.scene.camera_reported)
        key = secrets.token_urlsafe(16)
        with self._keys_lock:
            self._keys[key] = client.client_id
        source = DETECT_RENDERER_JS.replace("__KEY__", json.dumps(key)).replace(
            "__PATH__", json.dumps(RENDERER_PATH)
        )
        try:  # viser's own message for running a script (it sends plotly.js so)
            viser_adapter.run_javascript(client, source)
        except Exception:  # a viser without it: the browser keeps the server's graphics
            logger.warning("viewer: cannot ask browser %s for its renderer", client.client_id,
                           exc_info=True)  # fmt: skip

    def _forget_renderer(self, client: viser.ClientHandle) -> None:
        with self._keys_lock:
            self.renderers.pop(client.client_id, None)
            for key in [k for k, c in self._keys.items() if c == client.client_id]:
                self._keys.pop(key, None)

    def renderer_reported(self, key: str, renderer: str) -> None:
        """A page's renderer report (from the handshake check, on viser's event loop): one
        with a key this viewer gave out is handled on a thread of its own
        (`report_renderer`, which sends to the browser and may wait for its panel)."""
        with self._keys_lock:
            known = key in self._keys
        if known:
            threading.Thread(
                target=self.report_renderer, args=(key, renderer), daemon=True
            ).start()

    def report_renderer(self, key: str, renderer: str) -> None:
        """A page's WebGL renderer (its first report per key counts): a software renderer
        (`software_renderer`) in "full" graphics switches that browser to "light", and a
        notification says why and how to switch back (View → Graphics)."""
        with self._keys_lock:
            client_id = self._keys.pop(key, None)
            if client_id is None:
                return
            self.renderers[client_id] = renderer
        logger.info("viewer: browser %s renders with %r", client_id, renderer)
        if not software_renderer(renderer):
            return
        # its panel may still be under construction: give it a few seconds
        wait = time.monotonic() + 5.0
        while (panel := self.gui.panel(client_id)) is None and time.monotonic() < wait:
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
        self._wake.set()
        self._thread.join(timeout=5)
        self.gui.close()
        self.server.stop()

    def _read(self) -> FrameState:
        while (fs := read_frame(self.session)) is None:
            time.sleep(0.001)
        return fs

    def watched(self) -> bool:
        """Whether a browser is connected (the render loop draws only then)."""
        return bool(self.server.get_clients())

    def _run(self) -> None:
        period = 1.0 / FPS
        deadline = time.perf_counter()
        while not self._stop.wait(max(0.0, deadline - time.perf_counter())):
            if not self.watched():  # nobody to draw for: sleep until a browser connects
                self._wake.clear()
                if not self.watched():  # (one that connected since the check woke it)
                    self.idle_waits += 1
                    self._wake.wait(IDLE_WAIT)
                deadline = time.perf_counter()
                continue
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
        self.scene.settle_framing(self.server.get_clients().values())


def start_viewer(
    session: LiveSession,
    host: str = "127.0.0.1",
    port: int = 8080,
    *,
    access: Access,
    quiet_logs: Callable[[], object] | None = None,
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
        access: the server's access policy (`twin.web.access.Access`): the Host names every
            request must carry, the origins the websocket accepts (its own, at the viewer's
            actual port too) and the token that unlocks a browser's controls.
        quiet_logs: called once before it listens (the server's `twin.web.connections.
            quiet_malformed_messages`: one line per client per interval); None: logs as are.
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
        TwinError: the handshake check could not be added to viser's server, or viser lacks
            an internal the adapter needs (`viser_adapter.ViserInternalsMissing`, a viser
            upgrade): nothing is left running.
    """
    check_graphics(graphics)
    viser_adapter.check_internals()  # a viser this adapter does not know: say so, start nothing
    if quiet_logs is not None:  # a client's garbage: one line per client per minute (issue 30)
        quiet_logs()
    bound: list[int] = []
    viewers: list[Viewer] = []  # the viewer, once it is built (renderer reports)

    def on_renderer(key: str, renderer: str) -> None:
        for viewer in viewers:
            viewer.renderer_reported(key, renderer)

    check = request_check(access, lambda: bound[0] if bound else port, on_renderer)
    with viser_adapter.checked_handshake(check) as installed:
        server = viser.ViserServer(host=host, port=port, label="wave-twin", verbose=False)
    bound.append(server.get_port())
    if not installed:
        server.stop()
        raise TwinError(
            f"viser {viser.__version__}: could not add the Host and origin checks; the viewer "
            "is not started (serve REST only with --no-viewer, or use a supported viser)"
        )
    try:
        viser_adapter.check_internals(server)
        viser_adapter.drop_share_handlers(server)
        # a frame is encoded once for all browsers, not once per browser (issue 30 item 7)
        viser_adapter.share_broadcast_encoding(server)
        server.gui.configure_theme(control_width="large", show_share_button=False)
        configure_graphics(server.scene, graphics)
        viewer = Viewer(session, server, access, store=store, sweeps=sweeps, api_url=api_url,
                        graphics=graphics)  # fmt: skip
        viewers.append(viewer)
        return viewer
    except Exception:
        server.stop()
        raise

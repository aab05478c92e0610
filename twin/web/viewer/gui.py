"""The live twin's control panel: `TwinGui`, one `ClientPanel` per browser
(`twin.web.viewer.panel`) in folders shared by all, with the shared readout
(`twin.web.viewer.readout`), live plots (`twin.web.viewer.plots`), the replay of stored runs
(`twin.web.viewer.replay`) and operability sweeps (`twin.web.viewer.operability`), and a help
panel.

Callbacks only call the session (`patch`, `play`, `pause`, `step`, `reset`), whose own thread
applies them (`twin.sim.live.LiveSession`: a command queue), and show a notification when it
refuses a value; they never step the simulation themselves. The render loop calls
`TwinGui.update` every frame, which moves every browser's widgets to the session's values (so
a REST PATCH shows in every browser) and feeds the plots and the readout.

Threads: viser runs callbacks on its thread pool, the render loop runs `update`. What both
write is guarded: the panels, the unlocked browsers, the trail switch, the last error and the
running sweep by `TwinGui`'s lock; a panel's own state by its lock (`ClientPanel`).
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import viser

from twin.sim.live import COMPARE, LiveControls, LiveSession
from twin.web.viewer import viser_adapter
from twin.web.viewer.cameras import View
from twin.web.viewer.frame_state import FrameState
from twin.web.viewer.graphics import GRAPHICS
from twin.web.viewer.knobs import PLANNER_KNOBS, READOUT_ORDER, SEA_KNOBS, assign
from twin.web.viewer.onboard import OnboardFolder
from twin.web.viewer.operability import Sweeps
from twin.web.viewer.panel import FOLDERS, LOCKED, NO_COMPARE, ClientPanel
from twin.web.viewer.plots import PLOT_PERIOD, PLOT_SAMPLES, LivePlots, PlotSpec
from twin.web.viewer.readout import Readout
from twin.web.viewer.replay import NO_RUN, RUNS_PERIOD, Replays, replay_line

if TYPE_CHECKING:  # the server's policy, handed in (`start_viewer`)
    from twin.web.access import Access

log = logging.getLogger(__name__)

#: [s] wall-clock periods of the readout and the buffer metrics
READOUT_PERIOD = 0.2
METRICS_PERIOD = 2.0

HELP = """**Legs** are coloured by their margin to the stroke ends: green at mid-stroke, through
yellow and orange, to red at a limit.

**Tip error**, for every mechanism: the distance in mm between where its landing point is
and where it is held still in the sea. The hybrid system holds its gangway tip on the
turbine's landing spot; the 3UPU_UP holds its platform top (the cargo's seat) where it was
at the start, level, under the container (the green disc); the 4-UPR holds its pad's centre
where it was at the start, level, under the UAV (the green pad). The 4-UPR can only keep
its pad level: its height rides on the vessel, and surge and sway carry it off the held
pad, so its tip error is the vessel's drift, up to metres. The readout, the
plot and the trail all show this distance.

**Tip-error trail** (magenta): the landing point's offset from its held place, drawn from
the held place, magnified by the power of ten that fits the error shown to the mechanism
(×1, true size, up to ×10 000: 1 mm draws as 10 m), as its label states; it changes as the
error grows or shrinks, so no trail runs across the scene. Older samples fade.

**At a limit**: the readout names each leg or joint that sits at its limit and since when
("leg 3 at its stroke limit since 41.2 s"); the leg margin reads in mm, or "at the limit".

**Targets**, fixed in the sea while the vessel moves: the hybrid gangway lands on a wind
turbine's access platform (the grey tower is the turbine, the green square its landing
zone); the 4-UPR holds its pad under a hovering UAV; the 3UPU_UP holds its top under a
crane-hung container. The green ghost pad or disc is the held pose.

**Ghost** (translucent blue): a second planner on the same vessel motion and knobs
("Compare with"); the plots draw it dashed, and its tip-error trail is the light-blue one, at
the magenta trail's magnification.

**Faults** count steps a numerical fault held the mechanism still (a non-finite sea sample,
a planner or kinematics failure). **Limit handling** counts steps the planner shortened to stop
on a limit (joint limits "hold"), damped near a singularity, or solved approximately: the
machine staying within its limits. **Limit violations** are samples beyond a limit (legs by
more than 0.5 mm): "now" for the newest sample, "samples" over the plotted history.

**Replay** plays a stored run (no simulation): the time slider seeks, Play/Pause and speed
act on it, "Back to live" or any change returns to the live twin.

**Operability** runs a grid of sea states around the current one on the server, with the
current planner and knobs: "Hs cells" values of Hs from (100 − span) % to (100 + span) % of
the current Hs ("Hs span"; 0 … 2 × span / 100 m on a calm sea) times "Tp cells" values of Tp
within the current Tp ± "Tp span" seconds (kept within 1 … 30 s), evenly spaced with the
current sea one of the cells; each cell runs "Seeds per cell" sea records of "Run length"
seconds, so a sweep is cells × seeds runs. The heatmap rings the current sea. A cell's
operability is the share of its seeds' runs that stayed operable over the whole run length
(a run with one sample beyond a limit, or a tip error over the threshold, is not), so the
ringed cell can differ from the live run, which is one seed and shows only its last 30 s.
"""


class TwinGui(LivePlots, Readout, Replays, Sweeps):
    """The control panel of one live session: a `ClientPanel` per browser, and the shared
    readout and plots.

    Args:
        server: the viser server.
        session: the live session the widgets control.
        fs: the first frame (mechanism, scenario).
        on_camera: sets the given clients' cameras to a preset view.
        access: the server's access policy: with a token, a browser's controls stay
            read-only until it enters it (wrong ones rate-limited per address).
        store: the run store: with it, the Replay folder (its done runs) and, with `sweeps`,
            the Operability folder.
        sweeps: the runner of sweeps (the REST app's).
        api_url: the REST API's address, for links to stored sweeps.
        graphics: every browser's graphics at the start (`GRAPHICS`).
        on_graphics: lights one browser's scene for a graphics mode (client, mode).

    Attributes:
        panels: client id → its controls.
        folders: the shared folders the panels' widgets sit in.
        readout: the metrics and limits markdown (shared).
        plots: the live uPlot handles in use (shared; those of other layouts are hidden).
        run_options: the replay dropdown's choices (`NO_RUN`, then "id · what" per done run).
        sweep_status: the sweep's progress and link (shared markdown), `heatmap` its image.
        trail: whether the tip-error trail shows (a control: unlocked browsers toggle it).
        last_error: the last value the session refused, or the last refusal (its message).
    """

    def __init__(
        self,
        server: viser.ViserServer,
        session: LiveSession,
        fs: FrameState,
        on_camera: Callable[[View, Iterable[viser.ClientHandle]], None],
        access: Access,
        store: Any = None,
        sweeps: Any = None,
        api_url: str | None = None,
        graphics: str = "full",
        on_graphics: Callable[[viser.ClientHandle, str], None] | None = None,
    ) -> None:
        self.server = server
        self.session = session
        self.graphics = graphics
        self.on_graphics = on_graphics
        self.store = store
        self.sweeps = sweeps
        self.api_url = (api_url or "").rstrip("/")
        self.run_options: tuple[str, ...] = (NO_RUN,)
        self.sweep_id: str | None = None  # the sweep followed (progress, then heatmap)
        self.submitting = False  # a browser's sweep is being submitted (`Sweeps.run_sweep`)
        self.heatmap: viser.GuiImageHandle | None = None
        self._stop = threading.Event()
        self.on_camera = on_camera
        self.access = access
        self._failures = self.access.failure_limit()
        self._unlocked: set[int] = set()  # client ids that entered the token
        # panels, unlocked ids, trail, last_error, sweep_id and submitting: callbacks, render loop
        self._lock = threading.Lock()
        self._building = threading.Lock()  # a shared folder is entered by one thread at a time
        self.panels: dict[int, ClientPanel] = {}
        self.trail = True
        self.last_error: str | None = None
        self.plots: list[viser.GuiUplotHandle] = []
        self._plot_sets: dict[tuple, list[viser.GuiUplotHandle]] = {}
        self._specs: tuple[PlotSpec, ...] = ()
        self._samples = np.zeros((0, 0))
        self._count = 0
        self._next = {"plot": 0.0, "readout": 0.0, "metrics": 0.0, "runs": 0.0}
        self._metrics: dict[str, Any] = {}
        self._faults: dict[str, Any] = {}
        self._compare: dict[str, Any] | None = None
        # (|tip error|, the ghost's) [m] at the plots' samples: the readout's window
        self._tips: deque[tuple[float, float]] = deque(maxlen=PLOT_SAMPLES)
        self.restarted: tuple[float, str] | None = None  # (monotonic time, why), see update
        self._since: dict[str, float] = {}  # what sits at a limit → since when (the readout)
        self._compare_seen: str | None = None
        gui = server.gui
        shown: tuple[str, ...] = FOLDERS if store is not None else FOLDERS[:4]
        if sweeps is None:
            shown = tuple(f for f in shown if f != "Operability")
        self.folders = {name: gui.add_folder(name, order=i) for i, name in enumerate(shown)}
        with self.folders["Run"]:
            self.readout = gui.add_markdown("", order=READOUT_ORDER)
        if "Replay" in self.folders:
            with self.folders["Replay"]:
                self.replay_status = gui.add_markdown("", order=READOUT_ORDER)
            self._refresh_runs()
        if "Operability" in self.folders:
            with self.folders["Operability"]:
                self.sweep_status = gui.add_markdown(
                    "Hs × Tp around the current sea (the cells and spans set above), with the "
                    "current mechanism, planner and knobs, on the server's executor.",
                    order=READOUT_ORDER,
                )
        data_dir = None if store is None else Path(store.path).parent  # the cells' cache
        self.onboard = OnboardFolder(self, gui, session, data_dir, order=len(shown) - 0.5)
        self._plot_folder = gui.add_folder("Plots", order=len(shown))
        with gui.add_folder("Help", order=len(shown) + 1, expand_by_default=False):
            gui.add_markdown(HELP)
        self.restart(fs)
        server.on_client_connect(self._connect)
        server.on_client_disconnect(self._disconnect)

    # -- browsers -----------------------------------------------------------------------------
    def panel(self, client_id: int) -> ClientPanel | None:
        """The panel of a connected browser, if built."""
        with self._lock:
            return self.panels.get(client_id)

    def set_trail(self, shown: bool) -> None:
        """Show or hide the tip-error trail (every browser's checkbox follows)."""
        with self._lock:
            self.trail = bool(shown)

    def note_error(self, message: str) -> None:
        """Keep the last refusal or refused value (`last_error`)."""
        with self._lock:
            self.last_error = message

    def _connect(self, client: viser.ClientHandle) -> None:
        with self._building:
            panel = ClientPanel(self, client, locked=not self.allowed(client))
        with self._lock:
            if client.client_id in self.server.get_clients():
                self.panels[client.client_id] = panel
                return
        self._drop(panel)  # it left while its panel was being built

    def _disconnect(self, client: viser.ClientHandle) -> None:
        # viser itself unhooks a leaving client's widgets from the shared folders
        with self._lock:
            self.panels.pop(client.client_id, None)
            self._unlocked.discard(client.client_id)

    @staticmethod
    def _drop(panel: ClientPanel) -> None:
        """Remove a panel built for a browser that had already left (viser's teardown of it
        ran before these widgets existed, so they would stay listed in the shared folders)."""
        handles = [*panel.inputs.values(), *panel.settings.values(), *panel.buttons.values()]
        for handle in [*handles, panel.show_trail, panel.graphics]:
            try:
                handle.remove()
            except Exception:
                log.debug("removing a panel's widget failed", exc_info=True)

    def _remote(self, client: viser.ClientHandle) -> str:
        """The browser's address (viser keeps it on its connection), else one shared key."""
        return viser_adapter.remote_address(self.server, client) or "viewer"

    def unlock(self, client: viser.ClientHandle, token: str) -> Literal[True] | str:
        """Let a browser's edits apply if `token` is the server's (constant-time compare).

        Returns:
            True, or why not (a wrong token, or too many wrong ones from its address).
        """
        key = self.access.failure_key(self._remote(client), token)  # per failure, not address
        wait = self._failures.wait(key)
        if wait > 0:
            return f"too many wrong tokens; retry in {wait:.0f} s"
        if not self.access.token_matches(token):
            self._failures.acquire(key)
            return "wrong token: controls stay locked"
        with self._lock:
            self._unlocked.add(client.client_id)
            panel = self.panels.get(client.client_id)
        if panel is not None:
            panel.set_locked(False)
        return True

    def set_graphics(self, panel: ClientPanel, mode: str) -> None:
        """Light one browser's scene for `mode` (one of `GRAPHICS`) and show it on its
        dropdown; an unknown mode is undone."""
        if mode not in GRAPHICS:
            mode = self.graphics
        if panel.graphics.value != mode:
            assign(panel.graphics, "value", mode)
        if self.on_graphics is not None:
            self.on_graphics(panel.client, mode)

    def allowed(self, client: viser.ClientHandle | None) -> bool:
        """Whether edits from `client` apply (None: the server itself)."""
        if self.access.token is None or client is None:
            return True
        with self._lock:
            return client.client_id in self._unlocked

    def refuse(self, client: viser.ClientHandle) -> str:
        """Tell a locked browser its edit did not apply."""
        self.note_error(LOCKED)
        client.add_notification("Not applied", LOCKED, auto_close_seconds=8.0, color="red")
        return LOCKED

    def act(
        self, action: Callable[[], Any], client: viser.ClientHandle | None, panel: ClientPanel
    ) -> None:
        """A run button: the action if the browser may, else a refusal."""
        if client is None:
            return
        if not self.allowed(client):
            self.refuse(client)
            return
        action()

    def patch(
        self, changes: dict[str, Any], client: viser.ClientHandle, panel: ClientPanel
    ) -> None:
        """A browser's edit through `session.patch`; refused or bad, it is undone on that
        browser's widgets only."""
        if not self.allowed(client):
            self.refuse(client)
            panel.revert(changes)
            return
        try:
            self.session.patch(changes)
        except ValueError as err:
            self.note_error(str(err))
            client.add_notification("Not applied", str(err), auto_close_seconds=8.0, color="red")
            panel.revert(changes)

    def current(self, name: str) -> Any:
        """The session's value of a field or control (`compare_planner`: `NO_COMPARE` when
        none)."""
        if name == COMPARE:
            return self.session.compare_planner or NO_COMPARE
        if name in LiveControls.model_fields:
            return getattr(self.session.controls, name)
        return getattr(self.session.scenario, name)

    def close(self) -> None:
        """Stop following a sweep and the onboard report (the viewer is stopping)."""
        self._stop.set()
        self.onboard.close()

    # -- session → GUI ------------------------------------------------------------------------
    def update(self, fs: FrameState) -> None:
        """Per frame: every browser's widgets follow the session, then plots and readout."""
        values = {
            name: fs.speed if name in LiveControls.model_fields else getattr(fs.scenario, name)
            for name in ("speed", "mechanism", "planner", "joint_limits", "spectrum",
                         *(k.name for k in (*PLANNER_KNOBS, *SEA_KNOBS)))
        }  # fmt: skip
        values[COMPARE] = fs.ghost.scenario.planner if fs.ghost is not None else NO_COMPARE
        now = time.monotonic()
        compare = self.current(COMPARE)
        if self._compare_seen is not None and compare != self._compare_seen:
            # a compare change restarts both lanes from t = 0 (`LiveSession.patch`): say so
            what = ("the compare planner was removed" if compare == NO_COMPARE
                    else f"the compare planner is now {compare}")  # fmt: skip
            self.restarted = (now, what)
            self._next["readout"] = 0.0
        self._compare_seen = compare
        if self.store is not None and now >= self._next["runs"]:
            self._next["runs"] = now + RUNS_PERIOD
            self._refresh_runs()
        slow = now >= self._next["readout"]  # the replay slider moves at the readout's rate
        with self._lock:
            panels = list(self.panels.values())
        for panel in panels:
            try:
                panel.sync(values, self.trail)
                if slow:
                    panel.sync_replay(fs.replay, self.run_options)
            except Exception:  # one browser's panel must not stop the others' frames
                log.debug("panel sync failed", exc_info=True)
        self._sample(fs)
        if now >= self._next["plot"]:
            self._next["plot"] = now + PLOT_PERIOD
            self._push_plots()
        if now >= self._next["metrics"]:
            self._next["metrics"] = now + METRICS_PERIOD
            snapshot = self.session.snapshot()
            self._metrics, self._faults = snapshot["metrics"], snapshot["faults"]
            self._compare = snapshot.get("compare")
        if slow:
            self._next["readout"] = now + READOUT_PERIOD
            self.readout.content = self._readout(fs)
            self.onboard.update()
            if "Replay" in self.folders:
                self.replay_status.content = replay_line(fs)

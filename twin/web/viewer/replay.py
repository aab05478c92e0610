"""The replay of stored runs in the panel: each browser's controls (a stored run, Watch in 3D,
the time slider, Back to live), which act as `POST /api/live/replay` does
(`twin.web.actions`), and the list of done runs the dropdowns offer.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any, cast

import viser

from twin.web.viewer.frame_state import FrameState
from twin.web.viewer.knobs import assign

if TYPE_CHECKING:
    import threading

    from twin.web.viewer.gui import TwinGui
    from twin.web.viewer.panel import ClientPanel

log = logging.getLogger(__name__)

#: [s] how often the list of stored runs to replay is read again
RUNS_PERIOD = 3.0
#: the replay dropdown's "no run chosen"
NO_RUN = "—"


class ReplayControls:
    """`ClientPanel`'s replay controls (with a run store)."""

    gui: TwinGui
    client: viser.ClientHandle
    settings: dict[str, Any]
    buttons: dict[str, Any]
    _lock: threading.RLock
    _replay_t: float

    def _add_replay(self, folder: Any) -> None:
        """This browser's replay controls: a stored run, Watch, the time slider, Back to live."""
        cg, gui = self.client.gui, self.gui
        panel = cast("ClientPanel", self)  # this mixin is only ever a ClientPanel
        with folder:
            self.settings["replay_run"] = cg.add_dropdown(
                "Stored run", gui.run_options, initial_value=NO_RUN, order=0,
                hint="a done run of the store (newest first)",
            )  # fmt: skip
            self.buttons["Watch in 3D"] = cg.add_button(
                "Watch in 3D", icon=viser.Icon.PLAYER_PLAY, order=1
            )
            self.settings["replay_t"] = cg.add_slider(
                "Replay time [s]", min=0.0, max=1.0, step=0.05, initial_value=0.0, order=2,
                hint="seek in the run replayed (Play, Pause and speed under Run act on it)",
            )  # fmt: skip
            self.buttons["Back to live"] = cg.add_button(
                "Back to live", icon=viser.Icon.REFRESH, order=3
            )
        self.buttons["Watch in 3D"].on_click(
            lambda event: gui.act(lambda: gui.watch(panel), event.client, panel)
        )
        self.buttons["Back to live"].on_click(
            lambda event: gui.act(gui.session.reset, event.client, panel)
        )
        self.settings["replay_t"].on_update(self._on_seek)
        self.settings["replay_run"].on_update(panel._on_setting("replay_run"))

    def _on_seek(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return
        handle = self.settings["replay_t"]
        shown = self.gui.session.replaying
        if not self.gui.allowed(event.client):
            self.gui.refuse(event.client)
        elif shown is None:
            self.client.add_notification(
                "No replay", "choose a stored run and press Watch in 3D first",
                auto_close_seconds=5.0, color="yellow",
            )  # fmt: skip
        else:
            try:
                self.gui.session.seek(float(handle.value))
                with self._lock:
                    self._replay_t = float(handle.value)
                return
            except ValueError as err:
                self.client.add_notification("Not applied", str(err), color="red")
        assign(handle, "value", shown["t"] if shown else 0.0)

    def sync_replay(self, replay: dict[str, Any] | None, runs: tuple[str, ...]) -> None:
        """The replay widgets follow the session: the time slider spans the run replayed and
        shows its time; the run list follows the store."""
        if "replay_t" not in self.settings:
            return
        run = self.settings["replay_run"]
        if tuple(run.options) != runs:
            assign(run, "options", runs)
        slider = self.settings["replay_t"]
        if replay is None:
            return
        if slider.max != replay["duration"]:
            assign(slider, "max", max(replay["duration"], 0.05))
        with self._lock:
            moved = abs(replay["t"] - self._replay_t) > 1e-9
            if moved:
                self._replay_t = replay["t"]
        if moved:
            assign(slider, "value", round(replay["t"] / 0.05) * 0.05)


class Replays:
    """`TwinGui`'s replay actions and the run list."""

    session: Any
    store: Any
    run_options: tuple[str, ...]

    def note_error(self, message: str) -> None: ...

    def watch(self, panel: ClientPanel) -> None:
        """The run a browser chose, replayed (as `POST /api/live/replay`)."""
        from twin.web.actions import start_replay

        choice = str(panel.settings["replay_run"].value)
        if choice == NO_RUN:
            panel.client.add_notification("No run chosen", "choose a stored run first",
                                          auto_close_seconds=5.0, color="yellow")  # fmt: skip
            return
        try:
            start_replay(self.session, self.store, choice.split(" ", 1)[0])
        except ValueError as err:  # RunNotFound is one too
            self.note_error(str(err))
            panel.client.add_notification("Not replayed", str(err), color="red")

    def _refresh_runs(self) -> None:
        """The replay dropdown's choices: the newest done runs of the store."""
        try:
            runs = self.store.list_runs(20)
        except Exception:  # a store gone away: keep the list as it was
            log.debug("listing runs failed", exc_info=True)
            return
        options = [NO_RUN]
        for run in runs:
            if run.status == "done":
                s = run.scenario
                sea = f"Hs {s['hs']:g} m" if s.get("hs") is not None else f"WMO {s['sea_state']:g}"
                options.append(f"{run.id} · {s['mechanism']}/{s['planner']} · {sea} · "
                               f"{s['duration']:g} s")  # fmt: skip
        self.run_options = tuple(options)


def replay_line(fs: FrameState) -> str:
    """The Replay folder's status: the run shown and its time, or live."""
    if fs.replay is None:
        return "Showing the live simulation. Choose a stored run to watch it."
    r = fs.replay
    return (f"**Replaying run {r['run_id'][:8]}** ({fs.scenario.mechanism} / "
            f"{fs.scenario.planner}): t = {r['t']:.2f} of {r['duration']:.2f} s")  # fmt: skip

"""One browser's controls (`ClientPanel`): mechanism, planner and its knobs (and a second
planner to compare), sea, run controls, camera views, graphics, and with a run store its
replay and sweep controls (`twin.web.viewer.replay`, `twin.web.viewer.operability`).

Every browser gets its own controls (viser handles of that client alone), laid out in folders
shared by all. Whatever a browser sends, viser applies it to its own handles only: it can
neither move another browser's widgets nor change a widget's shared state (with shared
handles, one message could overwrite any property of a widget every browser uses, its
callbacks included). With a token (a server reachable from other machines), a browser's
controls are read-only until it enters the token in its own "Access" panel: its edits are
refused and undone, for it alone, while the scene, plots and its own camera views stay open
to it. Wrong tokens are rate-limited per client address, as over REST.

A panel's own state (the values it last showed, its kept settings, its replay time, whether
it is locked) is written by viser's callback threads and by the render loop: its lock
guards it.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

import viser

from twin.sim.live import COMPARE, live_demo
from twin.sim.registries import PLANNERS
from twin.sim.scenario import Scenario
from twin.web.viewer.cameras import View
from twin.web.viewer.graphics import GRAPHICS
from twin.web.viewer.knobs import (
    JOINT_LIMITS,
    MECHANISM_NAMES,
    PLANNER_KNOBS,
    SEA_KNOBS,
    SPECTRA,
    SPEED_KNOB,
    Knob,
    assign,
    planners_for,
)
from twin.web.viewer.operability import SweepControls
from twin.web.viewer.replay import ReplayControls

if TYPE_CHECKING:
    from twin.web.viewer.gui import TwinGui

log = logging.getLogger(__name__)

#: the compare dropdown's "no second planner"
NO_COMPARE = "none"
#: knobs shown for every planner (disabled where the planner does not read them)
ALWAYS_SHOWN = ("beta", "k_e", "k_c")

#: the camera buttons' labels
VIEW_LABELS: dict[View, str] = {
    "overview": "Overview",
    "walkway": "Gangway walkway",
    "close-up": "Close-up",
}

#: layout: the shared folders, in order (the last two only with a run store)
FOLDERS = ("Run", "Mechanism and planner", "Sea", "View", "Replay", "Operability")
#: buttons that act on the session or the store (disabled while locked); views stay open
ACTIONS = ("Play", "Pause", "Step", "Reset", "Watch in 3D", "Back to live", "Run sweep")
LOCKED = "controls are locked: enter the server's token under Access"


class ClientPanel(ReplayControls, SweepControls):
    """One browser's controls: handles of that client alone, in the shared folders.

    Read-only (disabled) while the browser is locked; an edit it sends anyway is refused and
    undone on its own widgets. Created when a browser connects (`TwinGui`), dropped when it
    leaves.

    Attributes:
        client: the browser.
        inputs: scenario or control field (and `compare_planner`) → its widget.
        settings: the replay's run and time, the sweep's grid (cells and spans), seeds and run
            length → its widget (with a run store).
        buttons: button label → its handle (run controls, replay, sweep and camera views).
        show_trail: checkbox of the tip-error trail.
        graphics: this browser's graphics dropdown (`GRAPHICS`; never locked: it changes
            what this browser draws, nothing else).
        locked: whether its edits are refused.
    """

    def __init__(self, gui: TwinGui, client: viser.ClientHandle, locked: bool) -> None:
        self.gui = gui
        self.client = client
        self._lock = threading.RLock()  # the state below: callback threads and render loop
        self.locked = locked
        self._kept: dict[str, Any] = {}
        self._replay_t = 0.0
        self._seen: dict[str, Any] = {}
        self.inputs: dict[str, viser.GuiInputHandle] = {}
        self.settings: dict[str, viser.GuiInputHandle] = {}
        self.buttons: dict[str, viser.GuiButtonHandle] = {}
        self._access: Any = None
        session, cg = gui.session, client.gui
        s, controls = session.scenario, session.controls
        folders = gui.folders
        with folders["Run"]:
            for order, (label, icon, action) in enumerate((
                ("Play", viser.Icon.PLAYER_PLAY, session.play),
                ("Pause", viser.Icon.PLAYER_PAUSE, session.pause),
                ("Step", viser.Icon.PLAYER_TRACK_NEXT, session.step),
                ("Reset", viser.Icon.REFRESH, session.reset),
            )):  # fmt: skip
                self.buttons[label] = cg.add_button(label, icon=icon, order=order)
                self.buttons[label].on_click(self._run_button(action))
            self.inputs["speed"] = self._add_knob(SPEED_KNOB, controls.speed, order=10)
        with folders["Mechanism and planner"]:
            self.inputs["mechanism"] = cg.add_dropdown(
                "Mechanism", MECHANISM_NAMES, initial_value=s.mechanism
            )
            self.inputs["planner"] = cg.add_dropdown(
                "Planner", planners_for(s.mechanism), initial_value=s.planner
            )
            self.inputs[COMPARE] = cg.add_dropdown(
                "Compare with",
                (NO_COMPARE, *planners_for(s.mechanism)),
                initial_value=gui.current(COMPARE),
                hint="a second planner on the same vessel motion and knobs, drawn as a "
                "translucent ghost and dashed in the plots (restarts at t = 0)",
            )
            self.inputs["joint_limits"] = cg.add_dropdown(
                "Joint limits",
                JOINT_LIMITS,
                initial_value=s.joint_limits,
                hint=Scenario.model_fields["joint_limits"].description,
            )
            for k in PLANNER_KNOBS:
                self.inputs[k.name] = self._add_knob(k, getattr(s, k.name))
        with folders["Sea"]:
            for k in SEA_KNOBS:
                self.inputs[k.name] = self._add_knob(k, getattr(s, k.name))
            self.inputs["spectrum"] = cg.add_dropdown(
                "Spectrum", SPECTRA, initial_value=s.spectrum
            )
        with folders["View"]:
            for view in VIEW_LABELS:  # the keys of VIEWS, typed as View
                button = cg.add_button(VIEW_LABELS[view], icon=viser.Icon.CAMERA)
                button.on_click(self._view_button(view))
                self.buttons[VIEW_LABELS[view]] = button
            self.show_trail = cg.add_checkbox("Tip-error trail", initial_value=gui.trail)
            self.graphics = cg.add_dropdown(
                "Graphics", GRAPHICS, initial_value=gui.graphics,
                hint="what this browser draws: full (environment map, shadows) or light (for "
                "a browser without a GPU); switched to light by itself on a software WebGL "
                "renderer",
            )  # fmt: skip
            self.graphics.on_update(self._on_graphics)
        if gui.store is not None:
            self._add_replay(folders["Replay"])
        if gui.store is not None and gui.sweeps is not None:
            self._add_sweep(folders["Operability"])
        self.show_trail.on_update(self._on_trail)
        with self._lock:
            self._kept.update({k: h.value for k, h in self.settings.items()})
            self._seen.update({name: handle.value for name, handle in self.inputs.items()})
        for name, handle in self.inputs.items():
            handle.on_update(self._callback(name))
        self._planner = s.planner
        self._show_planner_knobs(s.planner)
        if locked:
            self._offer_unlock()

    def _on_setting(self, name: str) -> Callable[[viser.GuiEvent], None]:
        """A setting only this browser uses: a locked browser's edit is undone."""

        def on_update(event: viser.GuiEvent) -> None:
            if event.client is None:
                return
            handle = self.settings[name]
            with self._lock:
                if not self.gui.allowed(event.client):
                    kept = self._kept.get(name, handle.value)
                else:
                    self._kept[name], kept = handle.value, None
            if kept is not None:
                self.gui.refuse(event.client)
                assign(handle, "value", kept)

        return on_update

    def _run_button(self, action: Callable[[], Any]) -> Callable[[viser.GuiEvent], None]:
        """A run button's callback: `action` if the browser may (`TwinGui.act`)."""
        return lambda event: self.gui.act(action, event.client, self)

    def _view_button(self, view: View) -> Callable[[viser.GuiEvent], None]:
        """A camera button's callback: this browser's camera to the preset `view`."""
        return lambda event: self.gui.on_camera(view, [self.client])

    # -- access -------------------------------------------------------------------------------
    def _offer_unlock(self) -> None:
        """This browser's own Access panel: the token typed here reaches no other browser."""
        cg = self.client.gui
        with cg.add_folder("Access", order=-1) as folder:
            field = cg.add_text("Token", "", hint="the server's TWIN_TOKEN")
            button = cg.add_button("Unlock controls", icon=viser.Icon.LOCK_OPEN)
        self._access = folder

        def unlock(event: viser.GuiEvent) -> None:
            if event.client is None:
                return
            outcome = self.gui.unlock(self.client, field.value)
            if outcome is True:
                folder.remove()
                self._access = None
                self.client.add_notification("Unlocked", "controls apply", auto_close_seconds=3.0)
            else:
                # viser's typing: _GuiInputHandle.value has a setter, but mypy takes the
                # plain field of GuiTextProps (GuiTextHandle's other base) as read-only
                field.value = ""  # type: ignore[misc]
                self.client.add_notification("Not unlocked", outcome, color="red")

        button.on_click(unlock)

    def set_locked(self, locked: bool) -> None:
        """Make the controls read-only (locked) or editable."""
        with self._lock:
            self.locked = locked
        self._apply_disabled()

    def _apply_disabled(self) -> None:
        used = PLANNERS[self._planner].parameters
        for name, handle in self.inputs.items():
            unused = name in {k.name for k in PLANNER_KNOBS} and name not in used
            assign(handle, "disabled", self.locked or unused)
        for label in ACTIONS:
            if label in self.buttons:
                assign(self.buttons[label], "disabled", self.locked)
        for handle in self.settings.values():
            assign(handle, "disabled", self.locked)
        assign(self.show_trail, "disabled", self.locked)

    # -- GUI → session ------------------------------------------------------------------------
    def _add_knob(self, k: Knob, value: float, order: float | None = None) -> viser.GuiInputHandle:
        cg = self.client.gui
        if k.slider:
            return cg.add_slider(
                k.label, min=k.min, max=k.max, step=k.step, initial_value=value, hint=k.hint,
                order=order,
            )  # fmt: skip
        return cg.add_number(
            k.label, value, min=k.min, max=k.max, step=k.number_step, hint=k.hint, order=order
        )

    def _callback(self, name: str) -> Callable[[viser.GuiEvent], None]:
        def on_update(event: viser.GuiEvent) -> None:
            if event.client is None:
                return  # the server showing the session's value: nothing to send back
            value = self.inputs[name].value
            changes = {name: None if name == COMPARE and value == NO_COMPARE else value}
            if name == "mechanism":  # it starts at its demo's planner and sea
                changes.update(live_demo(str(value)))
            self.gui.patch(changes, event.client, self)

        return on_update

    def _on_graphics(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return  # the server's own change (`TwinGui.set_graphics`)
        self.gui.set_graphics(self, str(self.graphics.value))

    def _on_trail(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return
        if not self.gui.allowed(event.client):
            self.gui.refuse(event.client)
            assign(self.show_trail, "value", self.gui.trail)
            return
        self.gui.set_trail(bool(self.show_trail.value))

    def revert(self, names: Iterable[str]) -> None:
        """Show the values in force again on these widgets."""
        for name in names:
            assign(self.inputs[name], "value", self.gui.current(name))
            with self._lock:
                self._seen[name] = self.inputs[name].value

    # -- session → GUI ------------------------------------------------------------------------
    def sync(self, values: dict[str, Any], trail: bool) -> None:
        """Move the widgets to the session's values (only those that changed since the last
        frame, so an edit this browser has just made is not overwritten before it lands)."""
        with self._lock:
            mechanism_moved = values["mechanism"] != self._seen["mechanism"]
        if mechanism_moved:
            assign(self.inputs["planner"], "options", planners_for(values["mechanism"]))
            assign(self.inputs[COMPARE], "options",
                    (NO_COMPARE, *planners_for(values["mechanism"])))  # fmt: skip
        if values["planner"] != self._planner:
            self._planner = values["planner"]
            self._show_planner_knobs(values["planner"])
        with self._lock:
            moved = {name: value for name, value in values.items() if value != self._seen[name]}
            self._seen.update(moved)
        for name, value in moved.items():
            assign(self.inputs[name], "value", value)
        if self.show_trail.value != trail:
            assign(self.show_trail, "value", trail)

    def _show_planner_knobs(self, planner: str) -> None:
        used = PLANNERS[planner].parameters
        for k in PLANNER_KNOBS:
            assign(self.inputs[k.name], "visible", k.name in used or k.name in ALWAYS_SHOWN)
        self._apply_disabled()

"""The live twin's control panel: mechanism, planner and its knobs, sea, run controls, camera
views, live plots and a readout of the metrics and limit violations.

Ranges, defaults and hints come from one place, the pydantic fields (`PlannerParameters`,
`Scenario`, `LiveControls`). Callbacks only call the session (`patch`, `play`, `pause`,
`step`, `reset`) and show a notification when it refuses a value; they never step the
simulation themselves.

Every browser gets its own controls (`ClientPanel`: viser handles of that client alone), laid
out in folders shared by all. Whatever a browser sends, viser applies it to its own handles
only: it can neither move another browser's widgets nor change a widget's shared state (with
shared handles, one message could overwrite any property of a widget every browser uses, its
callbacks included). The shared part (readout and plots) has no input a browser can write.
With a token (a server reachable from other machines), a browser's controls are read-only
until it enters the token in its own "Access" panel: its edits are refused and undone, for it
alone, while the scene, plots and its own camera views stay open to it. Wrong tokens are
rate-limited per client address, as over REST. The render loop calls `TwinGui.update` every
frame, which moves every browser's widgets to the session's values (so a REST PATCH shows in
every browser) and feeds the plots and the readout.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, get_args

import annotated_types as at
import numpy as np
import viser
import viser.uplot as up
from pydantic import BaseModel

from twin.planners import PlannerParameters
from twin.planners.registry import PLANNERS
from twin.sim.live import LiveControls, LiveSession
from twin.sim.scenario import Scenario
from twin.web.access import Access
from twin.web.frame import VIEWS, FrameState, View

log = logging.getLogger(__name__)

#: [s] simulated time between plotted samples, and samples kept (a 30 s window)
PLOT_DT = 0.1
PLOT_SAMPLES = 300
#: [s] wall-clock periods of the plot data, the readout and the buffer metrics
PLOT_PERIOD = 0.1
READOUT_PERIOD = 0.2
METRICS_PERIOD = 2.0
#: [m] leg-length tolerance of the limit readout (Table 1's millimetre precision)
LEG_TOL = 5e-4
#: knobs shown for every planner (disabled where the planner does not read them)
ALWAYS_SHOWN = ("beta", "k_e", "k_c")
LABELS = {
    "k_e": "k_e [1/s]",
    "beta": "β",
    "l": "l",
    "k_c": "k_c",
    "sigma": "σ [deg]",
    "q1_rate_max": "q̇1,max [deg/s]",
    "yaw_hold": "yaw hold",
    "k_a2": "k_a2 [1/s]",
    "damping": "λ_max",
    "kp": "kp [1/s]",
    "ki": "ki [1/s²]",
    "kd": "kd",
    "actuator_speed": "actuator speed [m/s]",
    "actuator_mass": "actuator mass [kg]",
    "w_orientation": "w orientation (qp)",
    "w_secondary": "w secondary (qp)",
    "limit_gain": "limit gain (qp)",
    "qp_damping": "μ (qp)",
}
VIEW_LABELS: dict[View, str] = {
    "overview": "Overview",
    "walkway": "Gangway walkway",
    "close-up": "Close-up",
}
PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf")


@dataclass(frozen=True)
class Knob:
    """A numeric field as a widget: range, step and default from its pydantic constraints.

    Attributes:
        name: field name (a `session.patch` key).
        label: widget label.
        min: lowest value (a strict bound `gt` becomes `gt + step`).
        max: highest value.
        step: slider step.
        default: the field's default.
        hint: the field's description.
    """

    name: str
    label: str
    min: float
    max: float
    step: float
    default: float
    hint: str

    @property
    def slider(self) -> bool:
        """Whether the default lies on the slider's grid; if not (ki = 8e-4 on 0-200), the
        knob is a number box, which keeps any value."""
        ratio = self.default / self.step
        return abs(ratio - round(ratio)) < 1e-6

    @property
    def number_step(self) -> float:
        """Step of the number box: a tenth of the default's order of magnitude."""
        return 10.0 ** (np.floor(np.log10(abs(self.default))) - 1) if self.default else self.step


def knob(model: type[BaseModel], name: str, label: str, step: float | None = None) -> Knob:
    """The `Knob` of a bounded numeric field of `model`.

    Args:
        model: a pydantic model class (`Scenario`, `PlannerParameters`, `LiveControls`).
        name: the field.
        label: the widget label.
        step: slider step; default a power of ten giving ≥ 100 steps over the range.
    """
    info = model.model_fields[name]
    low = high = None
    strict = False
    for constraint in info.metadata:
        if isinstance(constraint, at.Ge):
            low = constraint.ge
        elif isinstance(constraint, at.Gt):
            low, strict = constraint.gt, True
        elif isinstance(constraint, at.Le):
            high = constraint.le
        elif isinstance(constraint, at.Lt):
            high = constraint.lt
    if low is None or high is None:
        raise ValueError(f"{model.__name__}.{name} needs lower and upper bounds for a widget")
    step = step or 10.0 ** np.floor(np.log10((high - low) / 100.0))
    return Knob(
        name=name,
        label=label,
        min=float(low + step if strict else low),
        max=float(high),
        step=float(step),
        default=float(info.default),
        hint=info.description or "",
    )


#: every planner knob, in the order of `PlannerParameters` (a field without a label above
#: shows under its own name)
PLANNER_KNOBS = tuple(
    knob(PlannerParameters, name, LABELS.get(name, name.replace("_", " ")))
    for name in PlannerParameters.model_fields
)
SEA_KNOBS = (
    knob(Scenario, "sea_state", "Sea state (WMO)", step=0.1),
    knob(Scenario, "heading", "Wave heading [deg]"),
)
SPEED_KNOB = knob(LiveControls, "speed", "Sim speed ×", step=0.25)
MECHANISM_NAMES: tuple[str, ...] = get_args(Scenario.model_fields["mechanism"].annotation)
SPECTRA: tuple[str, ...] = get_args(Scenario.model_fields["spectrum"].annotation)
JOINT_LIMITS: tuple[str, ...] = get_args(Scenario.model_fields["joint_limits"].annotation)


def planners_for(mechanism: str) -> tuple[str, ...]:
    """Registry names of the planners that plan for `mechanism`."""
    return tuple(name for name, spec in PLANNERS.items() if mechanism in spec.mechanisms)


@dataclass(frozen=True)
class PlotSpec:
    """One live plot: its uPlot options and the values it takes from a frame.

    Attributes:
        title: chart title.
        series: the y series (the x series, t [s], is added).
        scales: uPlot scales by key.
        axes: uPlot axes for the y scales (the x axis is added).
        values: frame → (len(series),) values.
    """

    title: str
    series: tuple[up.Series, ...]
    scales: dict[str, up.Scale]
    axes: tuple[up.Axis, ...]
    values: Callable[[FrameState], np.ndarray]


def _line(label: str, k: int, scale: str = "y", dash: bool = False) -> up.Series:
    series = up.Series(label=label, stroke=PALETTE[k % len(PALETTE)], width=1.5, scale=scale)
    if dash:
        series.update(stroke="#d62728", dash=(6.0, 4.0), width=1.0)
    return series


def plot_specs(fs: FrameState) -> tuple[PlotSpec, ...]:
    """The live plots of a mechanism: legs with their limits, gangway joints (hybrid) or the
    platform state, tip error, and manipulability (hybrid) or tilt."""
    n = fs.leg_lengths.size
    y = {"y": up.Scale(auto=True)}
    legs = PlotSpec(
        "Leg lengths [m]",
        (*(_line(f"leg {i + 1}", i) for i in range(n)), _line("min", 0, dash=True),
         _line("max", 0, dash=True)),
        y,
        (up.Axis(scale="y"),),
        lambda f: np.r_[f.leg_lengths, f.leg_min.min(), f.leg_max.max()],
    )  # fmt: skip
    two = {"a": up.Scale(auto=True), "b": up.Scale(auto=True)}
    two_axes = (up.Axis(scale="a"), up.Axis(scale="b", side=1, grid=up.Axis_Grid(show=False)))
    error = PlotSpec(
        # µrad, not degrees: uPlot's tick labels keep three decimals, and the hybrid
        # system's orientation error is ~1e-4 deg
        "Tip error: position [mm] (left), orientation [µrad] (right)",
        (_line("|e_p| [mm]", 0, "a"), _line("|e_r| [µrad]", 1, "b")),
        two,
        two_axes,
        lambda f: np.r_[
            1e3 * np.linalg.norm(f.record["tip_error"][:3]),
            1e6 * np.linalg.norm(f.record["tip_error"][3:]),
        ],
    )
    if fs.scenario.mechanism == "hybrid":
        joints = PlotSpec(
            "Gangway joints: q1, q2 [deg] (left), d3 [m] (right)",
            (_line("q1 [deg]", 0, "a"), _line("q2 [deg]", 1, "a"), _line("d3 [m]", 2, "b")),
            two,
            two_axes,
            lambda f: np.r_[np.degrees(f.state[6:8]), f.state[8]],
        )
        extra = PlotSpec(
            "Manipulability (Stewart part)",
            (_line("w", 3),),
            y,
            (up.Axis(scale="y"),),
            lambda f: np.atleast_1d(f.record["manipulability"]),
        )
        return legs, joints, error, extra
    unit = "mm" if fs.scenario.mechanism == "upu3up" else "m"
    z, a1, a2 = fs.mechanism.state_names
    joints = PlotSpec(
        f"Platform state: {z} [{unit}] (left), {a1}, {a2} [deg] (right)",
        (
            _line(f"{z} [{unit}]", 0, "a"),
            _line(f"{a1} [deg]", 1, "b"),
            _line(f"{a2} [deg]", 2, "b"),
        ),
        two,
        two_axes,
        lambda f: np.r_[f.state[0], np.degrees(f.state[1:])],
    )
    extra = PlotSpec(
        "Tilt from vertical [deg]: top vs base",
        (_line("top", 3), _line("base", 4)),
        y,
        (up.Axis(scale="y"),),
        lambda f: np.degrees(np.r_[f.record["alpha_top"], f.record["alpha_bottom"]]),
    )
    return legs, joints, error, extra


def _layout(specs: Iterable[PlotSpec]) -> list[tuple[str, ...]]:
    """What a plot handle is built from: titles and series labels."""
    return [(p.title, *(str(s.get("label")) for s in p.series)) for p in specs]


def limit_violations(fs: FrameState) -> list[str]:
    """Readable limit violations of the frame's legs and state (empty: all within limits)."""
    out = []
    for i in np.flatnonzero(fs.leg_lengths < fs.leg_min - LEG_TOL):
        out.append(f"leg {i + 1}: {fs.leg_lengths[i]:.3f} m < {fs.leg_min[i]:.3f} m")
    for i in np.flatnonzero(fs.leg_lengths > fs.leg_max + LEG_TOL):
        out.append(f"leg {i + 1}: {fs.leg_lengths[i]:.3f} m > {fs.leg_max[i]:.3f} m")
    low, high = fs.mechanism.state_limits
    names = fs.mechanism.state_names
    for i in np.flatnonzero((fs.state < low - 1e-9) | (fs.state > high + 1e-9)):
        out.append(f"{names[i]}: {fs.state[i]:.4g} outside [{low[i]:.4g}, {high[i]:.4g}]")
    return out


def fault_line(faults: dict[str, Any]) -> str:
    """The readout's line of numerical faults (`LiveSession.snapshot()["faults"]`)."""
    counts = {k: n for k, n in faults.get("counts", {}).items() if n}
    if not counts and not faults.get("loop_errors"):
        return "**Faults:** none"
    parts = [f"{k.replace('_', ' ')} {n}" for k, n in counts.items()]
    if faults.get("loop_errors"):
        parts.append(f"loop errors {faults['loop_errors']}")
    line = "**⚠ Faults:** " + ", ".join(parts) + f" · {faults.get('held', 0)} steps held"
    if faults.get("events"):
        last = faults["events"][-1]
        line += f" · last at t = {last['end']:.2f} s: {', '.join(last['kinds'])}"
        if last["message"]:
            line += f" ({last['message'][:120]})"
    return line


#: layout: the shared folders, in order, and where the shared readout sits in "Run"
FOLDERS = ("Run", "Mechanism and planner", "Sea", "View")
READOUT_ORDER = 100.0
LOCKED = "controls are locked: enter the server's token under Access"


def _assign(handle: Any, name: str, value: Any) -> None:
    """Set a widget's property; a widget its browser broke for itself (a hostile message can
    mark its own handle removed, say) is skipped, so the rest of its panel still follows."""
    try:
        setattr(handle, name, value)
    except (RuntimeError, TypeError, ValueError, AttributeError):
        log.debug("widget property %s not set", name, exc_info=True)


class ClientPanel:
    """One browser's controls: handles of that client alone, in the shared folders.

    Read-only (disabled) while the browser is locked; an edit it sends anyway is refused and
    undone on its own widgets. Created when a browser connects (`TwinGui`), dropped when it
    leaves.

    Attributes:
        client: the browser.
        inputs: scenario or control field → its widget.
        buttons: button label → its handle (run controls and camera views).
        show_trail: checkbox of the tip-error trail.
        locked: whether its edits are refused.
    """

    def __init__(self, gui: TwinGui, client: viser.ClientHandle, locked: bool) -> None:
        self.gui = gui
        self.client = client
        self.locked = locked
        self.inputs: dict[str, viser.GuiInputHandle] = {}
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
                self.buttons[label].on_click(
                    lambda event, action=action: gui.act(action, event.client, self)
                )
            self.inputs["speed"] = self._add_knob(SPEED_KNOB, controls.speed, order=10)
        with folders["Mechanism and planner"]:
            self.inputs["mechanism"] = cg.add_dropdown(
                "Mechanism", MECHANISM_NAMES, initial_value=s.mechanism
            )
            self.inputs["planner"] = cg.add_dropdown(
                "Planner", planners_for(s.mechanism), initial_value=s.planner
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
            for view in VIEWS:
                button = cg.add_button(VIEW_LABELS[view], icon=viser.Icon.CAMERA)
                button.on_click(lambda event, view=view: gui.on_camera(view, [client]))
                self.buttons[VIEW_LABELS[view]] = button
            self.show_trail = cg.add_checkbox("Tip-error trail", initial_value=gui.trail)
        self.show_trail.on_update(self._on_trail)
        self._seen: dict[str, Any] = {}
        for name, handle in self.inputs.items():
            self._seen[name] = handle.value
            handle.on_update(self._callback(name))
        self._planner = s.planner
        self._show_planner_knobs(s.planner)
        if locked:
            self._offer_unlock()

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
                field.value = ""
                self.client.add_notification("Not unlocked", outcome, color="red")

        button.on_click(unlock)

    def set_locked(self, locked: bool) -> None:
        """Make the controls read-only (locked) or editable."""
        self.locked = locked
        self._apply_disabled()

    def _apply_disabled(self) -> None:
        used = PLANNERS[self._planner].parameters
        for name, handle in self.inputs.items():
            unused = name in {k.name for k in PLANNER_KNOBS} and name not in used
            _assign(handle, "disabled", self.locked or unused)
        for label in ("Play", "Pause", "Step", "Reset"):
            _assign(self.buttons[label], "disabled", self.locked)
        _assign(self.show_trail, "disabled", self.locked)

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
            changes = {name: self.inputs[name].value}
            if name == "mechanism" and self.gui.session.scenario.planner not in planners_for(
                changes[name]
            ):
                changes["planner"] = None  # the new mechanism's default planner
            self.gui.patch(changes, event.client, self)

        return on_update

    def _on_trail(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return
        if not self.gui.allowed(event.client):
            self.gui.refuse(event.client)
            self.show_trail.value = self.gui.trail
            return
        self.gui.trail = bool(self.show_trail.value)

    def revert(self, names: Iterable[str]) -> None:
        """Show the values in force again on these widgets."""
        for name in names:
            _assign(self.inputs[name], "value", self.gui.current(name))
            self._seen[name] = self.inputs[name].value

    # -- session → GUI ------------------------------------------------------------------------
    def sync(self, values: dict[str, Any], trail: bool) -> None:
        """Move the widgets to the session's values (only those that changed since the last
        frame, so an edit this browser has just made is not overwritten before it lands)."""
        if values["mechanism"] != self._seen["mechanism"]:
            _assign(self.inputs["planner"], "options", planners_for(values["mechanism"]))
        if values["planner"] != self._planner:
            self._planner = values["planner"]
            self._show_planner_knobs(values["planner"])
        for name, value in values.items():
            if value != self._seen[name]:
                self._seen[name] = value
                _assign(self.inputs[name], "value", value)
        if self.show_trail.value != trail:
            _assign(self.show_trail, "value", trail)

    def _show_planner_knobs(self, planner: str) -> None:
        used = PLANNERS[planner].parameters
        for k in PLANNER_KNOBS:
            _assign(self.inputs[k.name], "visible", k.name in used or k.name in ALWAYS_SHOWN)
        self._apply_disabled()


class TwinGui:
    """The control panel of one live session: a `ClientPanel` per browser, and the shared
    readout and plots.

    Args:
        server: the viser server.
        session: the live session the widgets control.
        fs: the first frame (mechanism, scenario).
        on_camera: sets the given clients' cameras to a preset view.
        access: the server's access policy: with a token, a browser's controls stay
            read-only until it enters it (wrong ones rate-limited per address).

    Attributes:
        panels: client id → its controls.
        folders: the shared folders the panels' widgets sit in.
        readout: the metrics and limits markdown (shared).
        plots: the live uPlot handles (shared).
        trail: whether the tip-error trail shows (a control: unlocked browsers toggle it).
        last_error: the last value the session refused, or the last refusal (its message).
    """

    def __init__(
        self,
        server: viser.ViserServer,
        session: LiveSession,
        fs: FrameState,
        on_camera: Callable[[View, Iterable[viser.ClientHandle]], None],
        access: Access | None = None,
    ) -> None:
        self.server = server
        self.session = session
        self.on_camera = on_camera
        self.access = access if access is not None else Access()
        self._failures = self.access.failure_limit()
        self._unlocked: set[int] = set()  # client ids that entered the token
        self._lock = threading.Lock()  # panels and unlocked ids
        self._building = threading.Lock()  # a shared folder is entered by one thread at a time
        self.panels: dict[int, ClientPanel] = {}
        self.trail = True
        self.last_error: str | None = None
        self.plots: list[viser.GuiUplotHandle] = []
        self._specs: tuple[PlotSpec, ...] = ()
        self._samples = np.zeros((0, 0))
        self._count = 0
        self._next = {"plot": 0.0, "readout": 0.0, "metrics": 0.0}
        self._metrics: dict[str, Any] = {}
        self._faults: dict[str, Any] = {}
        gui = server.gui
        self.folders = {name: gui.add_folder(name, order=i) for i, name in enumerate(FOLDERS)}
        with self.folders["Run"]:
            self.readout = gui.add_markdown("", order=READOUT_ORDER)
        self._plot_folder = gui.add_folder("Plots", order=len(FOLDERS))
        self.restart(fs)
        server.on_client_connect(self._connect)
        server.on_client_disconnect(self._disconnect)

    # -- browsers -----------------------------------------------------------------------------
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
        for handle in [*panel.inputs.values(), *panel.buttons.values(), panel.show_trail]:
            try:
                handle.remove()
            except Exception:
                log.debug("removing a panel's widget failed", exc_info=True)

    def _remote(self, client: viser.ClientHandle) -> str:
        """The browser's address (viser keeps it on its connection), else one shared key."""
        try:
            connection = self.server._websock_server._live_connections[client.client_id]
            return str(connection.remote_address[0])
        except Exception:
            return "viewer"

    def unlock(self, client: viser.ClientHandle, token: str) -> bool | str:
        """Let a browser's edits apply if `token` is the server's (constant-time compare).

        Returns:
            True, or why not (a wrong token, or too many wrong ones from its address).
        """
        key = self._remote(client)
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

    def allowed(self, client: viser.ClientHandle | None) -> bool:
        """Whether edits from `client` apply (None: the server itself)."""
        return self.access.token is None or client is None or client.client_id in self._unlocked

    def refuse(self, client: viser.ClientHandle) -> str:
        """Tell a locked browser its edit did not apply."""
        self.last_error = LOCKED
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
            self.last_error = str(err)
            client.add_notification("Not applied", str(err), auto_close_seconds=8.0, color="red")
            panel.revert(changes)

    def current(self, name: str) -> Any:
        """The session's value of a field or control."""
        if name in LiveControls.model_fields:
            return getattr(self.session.controls, name)
        return getattr(self.session.scenario, name)

    # -- session → GUI ------------------------------------------------------------------------
    def restart(self, fs: FrameState) -> None:
        """After a reset or restart: clear the plots; rebuild them for a new mechanism."""
        specs = plot_specs(fs)
        if _layout(specs) != _layout(self._specs):
            for handle in self.plots:
                handle.remove()
            with self._plot_folder:
                self.plots = [
                    self.server.gui.add_uplot(
                        data=(np.zeros(1), *np.zeros((len(p.series), 1))),
                        series=(up.Series(label="t [s]"), *p.series),
                        title=p.title,
                        scales={"x": up.Scale(time=False, auto=True), **p.scales},
                        axes=(up.Axis(), *p.axes),
                        legend=up.Legend(show=True),
                        aspect=1.6,
                    )
                    for p in specs
                ]
            self._specs = specs
        self._samples = np.zeros((len(specs), PLOT_SAMPLES, 1 + max(len(p.series) for p in specs)))
        self._count = 0
        self._next["plot"] = self._next["metrics"] = 0.0

    def update(self, fs: FrameState) -> None:
        """Per frame: every browser's widgets follow the session, then plots and readout."""
        values = {
            name: fs.speed if name in LiveControls.model_fields else getattr(fs.scenario, name)
            for name in ("speed", "mechanism", "planner", "joint_limits", "spectrum",
                         *(k.name for k in (*PLANNER_KNOBS, *SEA_KNOBS)))
        }  # fmt: skip
        with self._lock:
            panels = list(self.panels.values())
        for panel in panels:
            try:
                panel.sync(values, self.trail)
            except Exception:  # one browser's panel must not stop the others' frames
                log.debug("panel sync failed", exc_info=True)
        self._sample(fs)
        now = time.monotonic()
        if now >= self._next["plot"]:
            self._next["plot"] = now + PLOT_PERIOD
            rows = self._samples[:, : self._count]
            for handle, spec, data in zip(self.plots, self._specs, rows, strict=True):
                handle.data = tuple(data[:, : 1 + len(spec.series)].T)
        if now >= self._next["metrics"]:
            self._next["metrics"] = now + METRICS_PERIOD
            snapshot = self.session.snapshot()
            self._metrics, self._faults = snapshot["metrics"], snapshot["faults"]
        if now >= self._next["readout"]:
            self._next["readout"] = now + READOUT_PERIOD
            self.readout.content = self._readout(fs)

    def _sample(self, fs: FrameState) -> None:
        last = self._samples[0, self._count - 1, 0] if self._count else -np.inf
        if fs.t < last:  # a restart the version check has not seen yet
            self._count, last = 0, -np.inf
        if fs.t < last + PLOT_DT - 1e-9:
            return
        if self._count == PLOT_SAMPLES:
            self._samples = np.roll(self._samples, -1, axis=1)
            self._count -= 1
        for k, spec in enumerate(self._specs):
            values = spec.values(fs)
            self._samples[k, self._count, : 1 + values.size] = np.r_[fs.t, values]
        self._count += 1

    def _readout(self, fs: FrameState) -> str:
        e = fs.record["tip_error"]
        margin = np.minimum(fs.leg_lengths - fs.leg_min, fs.leg_max - fs.leg_lengths)  # [m]
        worst = int(np.argmin(margin))
        s = fs.scenario
        lines = [
            f"**t = {fs.t:.2f} s** · {'playing' if fs.playing else 'paused'} at "
            f"{fs.speed:g}× · {s.mechanism} / {s.planner} · sea state {s.sea_state:g}",
            "",
            f"- tip error: {1e3 * np.linalg.norm(e[:3]):.3g} mm, "
            f"{np.degrees(np.linalg.norm(e[3:])):.3g}°",
            f"- leg margin: {margin[worst]:.3f} m (leg {worst + 1})",
        ]
        if "manipulability" in fs.record:
            lines.append(f"- manipulability: {float(fs.record['manipulability']):.4g}")
        if "phi_e" in fs.record:
            lines.append(
                f"- gangway φe, θe: {np.degrees(float(fs.record['phi_e'])):.3g}°, "
                f"{np.degrees(float(fs.record['theta_e'])):.3g}°"
            )
        m = self._metrics
        if m:
            lines.append(
                f"- buffer: tip error rms {1e3 * m['tip_position_error_rms']:.3g} mm, "
                f"max {1e3 * m['tip_position_error_max']:.3g} mm; "
                f"{m['violations']} samples over a limit"
            )
        violations = limit_violations(fs)
        lines.append("")
        lines.append(fault_line(self._faults))
        lines.append(
            "**Limits:** all within limits"
            if not violations
            else "**Limits violated:** " + "; ".join(violations)
        )
        return "\n".join(lines)

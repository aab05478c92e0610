"""The live twin's control panel: mechanism, planner and its knobs, sea, run controls, camera
views, live plots and a readout of the metrics and limit violations.

Ranges, defaults and hints come from one place, the pydantic fields (`PlannerParameters`,
`Scenario`, `LiveControls`). Callbacks only call the session (`patch`, `play`, `pause`,
`step`, `reset`) and show a notification when it refuses a value; they never step the
simulation themselves. With a token (a server reachable from other machines), each browser
unlocks the controls by entering it; until then its edits are refused and undone, while the
scene, plots and camera views stay open to it. The render loop calls `TwinGui.update` every
frame, which moves the widgets to the session's values (so a REST PATCH shows in every
browser) and feeds the plots and the readout.
"""

from __future__ import annotations

import contextlib
import hmac
import threading
import time
from collections.abc import Callable, Iterable, Iterator
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
from twin.web.frame import VIEWS, FrameState, View

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
    "k_a2": "k_a2 [1/s]",
    "damping": "λ_max",
    "kp": "kp [1/s]",
    "ki": "ki [1/s²]",
    "kd": "kd",
    "actuator_speed": "actuator speed [m/s]",
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


PLANNER_KNOBS = tuple(knob(PlannerParameters, name, LABELS[name]) for name in LABELS)
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


class TwinGui:
    """The control panel of one live session, shared by every browser.

    Args:
        server: the viser server.
        session: the live session the widgets control.
        fs: the first frame (mechanism, scenario).
        on_camera: sets the given clients' cameras to a preset view.
        token: if set, a browser must enter it (its own "Access" panel) before its edits apply.

    Attributes:
        inputs: scenario or control field → its widget.
        buttons: button label → its handle (run controls and camera views).
        show_trail: checkbox of the tip-error trail.
        readout: the metrics and limits markdown.
        plots: the live uPlot handles.
        last_error: the last value the session refused (its message).
    """

    def __init__(
        self,
        server: viser.ViserServer,
        session: LiveSession,
        fs: FrameState,
        on_camera: Callable[[View, Iterable[viser.ClientHandle]], None],
        token: str | None = None,
    ) -> None:
        self.server = server
        self.session = session
        self._token = None if token is None else token.encode()
        self._unlocked: set[int] = set()  # client ids that entered the token
        self.last_error: str | None = None
        self.plots: list[viser.GuiUplotHandle] = []
        self._local = threading.local()  # `syncing` marks widget writes of the render loop
        self._seen: dict[str, Any] = {}
        self._specs: tuple[PlotSpec, ...] = ()
        self._samples = np.zeros((0, 0))
        self._count = 0
        self._next = {"plot": 0.0, "readout": 0.0, "metrics": 0.0}
        self._metrics: dict[str, Any] = {}
        self._faults: dict[str, Any] = {}
        self.inputs: dict[str, viser.GuiInputHandle] = {}
        self.buttons: dict[str, viser.GuiButtonHandle] = {}
        gui = server.gui
        s = fs.scenario

        with gui.add_folder("Run"):
            for label, icon, action in (
                ("Play", viser.Icon.PLAYER_PLAY, session.play),
                ("Pause", viser.Icon.PLAYER_PAUSE, session.pause),
                ("Step", viser.Icon.PLAYER_TRACK_NEXT, session.step),
                ("Reset", viser.Icon.REFRESH, session.reset),
            ):
                self.buttons[label] = gui.add_button(label, icon=icon)
                self.buttons[label].on_click(
                    lambda event, action=action: self._act(action, event.client)
                )
            self.inputs["speed"] = self._add_knob(SPEED_KNOB, fs.speed)
            self.readout = gui.add_markdown("")
        with gui.add_folder("Mechanism and planner"):
            self.inputs["mechanism"] = gui.add_dropdown(
                "Mechanism", MECHANISM_NAMES, initial_value=s.mechanism
            )
            self.inputs["planner"] = gui.add_dropdown(
                "Planner", planners_for(s.mechanism), initial_value=s.planner
            )
            self.inputs["joint_limits"] = gui.add_dropdown(
                "Joint limits",
                JOINT_LIMITS,
                initial_value=s.joint_limits,
                hint=Scenario.model_fields["joint_limits"].description,
            )
            for k in PLANNER_KNOBS:
                self.inputs[k.name] = self._add_knob(k, getattr(s, k.name))
        with gui.add_folder("Sea"):
            for k in SEA_KNOBS:
                self.inputs[k.name] = self._add_knob(k, getattr(s, k.name))
            self.inputs["spectrum"] = gui.add_dropdown(
                "Spectrum", SPECTRA, initial_value=s.spectrum
            )
        with gui.add_folder("View"):
            for view in VIEWS:
                button = gui.add_button(VIEW_LABELS[view], icon=viser.Icon.CAMERA)
                button.on_click(
                    lambda event, view=view: on_camera(view, self._clients(event.client))
                )
                self.buttons[VIEW_LABELS[view]] = button
            self.show_trail = gui.add_checkbox("Tip-error trail", initial_value=True)
        self._plot_folder = gui.add_folder("Plots")

        for name, handle in self.inputs.items():
            self._seen[name] = handle.value
            handle.on_update(self._callback(name))
        self._show_planner_knobs(s.planner)
        self.restart(fs)
        if self._token is not None:
            server.on_client_connect(self._offer_unlock)
            server.on_client_disconnect(lambda client: self._unlocked.discard(client.client_id))

    # -- access -------------------------------------------------------------------------------
    def _offer_unlock(self, client: viser.ClientHandle) -> None:
        """A per-browser panel: the token typed here is never shared with other browsers."""
        with client.gui.add_folder("Access", order=-1) as folder:
            field = client.gui.add_text("Token", "", hint="the server's TWIN_TOKEN")
            button = client.gui.add_button("Unlock controls", icon=viser.Icon.LOCK_OPEN)

        def unlock(_: viser.GuiEvent) -> None:
            if self.unlock(client.client_id, field.value):
                folder.remove()
                client.add_notification("Unlocked", "controls apply", auto_close_seconds=3.0)
            else:
                field.value = ""
                client.add_notification("Wrong token", "controls stay locked", color="red")

        button.on_click(unlock)

    def unlock(self, client_id: int, token: str) -> bool:
        """Let a browser's edits apply if `token` is the server's (constant-time compare)."""
        if self._token is not None and not hmac.compare_digest(token.encode(), self._token):
            return False
        self._unlocked.add(client_id)
        return True

    def allowed(self, client: viser.ClientHandle | None) -> bool:
        """Whether edits from `client` apply (None: the server itself)."""
        return self._token is None or client is None or client.client_id in self._unlocked

    def _locked(self, client: viser.ClientHandle) -> str:
        message = "controls are locked: enter the server's token under Access"
        self.last_error = message
        client.add_notification("Not applied", message, auto_close_seconds=8.0, color="red")
        return message

    def _act(self, action: Callable[[], Any], client: viser.ClientHandle | None) -> None:
        if not self.allowed(client):
            self._locked(client)
            return
        action()

    # -- GUI → session ------------------------------------------------------------------------
    def _add_knob(self, k: Knob, value: float) -> viser.GuiInputHandle:
        gui = self.server.gui
        if k.slider:
            return gui.add_slider(
                k.label, min=k.min, max=k.max, step=k.step, initial_value=value, hint=k.hint
            )
        return gui.add_number(k.label, value, min=k.min, max=k.max, step=k.number_step, hint=k.hint)

    def _callback(self, name: str) -> Callable[[viser.GuiEvent], None]:
        def on_update(event: viser.GuiEvent) -> None:
            if getattr(self._local, "syncing", False):
                return  # the render loop showing the session's value: nothing to send back
            changes = {name: self.inputs[name].value}
            if name == "mechanism" and self.session.scenario.planner not in planners_for(
                changes[name]
            ):
                changes["planner"] = None  # the new mechanism's default planner
            self._patch(changes, event.client)

        return on_update

    def _patch(self, changes: dict[str, Any], client: viser.ClientHandle | None) -> None:
        try:
            if not self.allowed(client):
                raise PermissionError(self._locked(client))
            self.session.patch(changes)
        except (ValueError, PermissionError) as err:
            if isinstance(err, ValueError):
                self.last_error = str(err)
                for c in self._clients(client):
                    c.add_notification("Not applied", str(err), auto_close_seconds=8.0, color="red")
            with self._syncing():  # show the value still in force
                for name in changes:
                    self.inputs[name].value = self._current(name)

    def _current(self, name: str) -> Any:
        if name in LiveControls.model_fields:
            return getattr(self.session.controls, name)
        return getattr(self.session.scenario, name)

    def _clients(self, client: viser.ClientHandle | None) -> Iterable[viser.ClientHandle]:
        return [client] if client is not None else list(self.server.get_clients().values())

    @contextlib.contextmanager
    def _syncing(self) -> Iterator[None]:
        # Assigning `.value` runs on_update synchronously in this thread; the flag makes
        # those callbacks no-ops, while browser edits (viser's thread pool) still patch.
        self._local.syncing = True
        try:
            yield
        finally:
            self._local.syncing = False

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
        """Per frame: widgets follow the session, then plots and readout (throttled)."""
        self._sync_inputs(fs)
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

    def _sync_inputs(self, fs: FrameState) -> None:
        # Only a change of the session's value since the last frame moves a widget, so an
        # edit a browser has just made is not overwritten before its patch lands.
        values = {
            name: fs.speed if name in LiveControls.model_fields else getattr(fs.scenario, name)
            for name in self.inputs
        }
        with self._syncing():
            if values["mechanism"] != self._seen["mechanism"]:
                self.inputs["planner"].options = planners_for(values["mechanism"])
            if values["planner"] != self._seen["planner"]:
                self._show_planner_knobs(values["planner"])
            for name, value in values.items():
                if value != self._seen[name]:
                    self._seen[name] = value
                    self.inputs[name].value = value

    def _show_planner_knobs(self, planner: str) -> None:
        used = PLANNERS[planner].parameters
        for k in PLANNER_KNOBS:
            handle = self.inputs[k.name]
            handle.visible = k.name in used or k.name in ALWAYS_SHOWN
            handle.disabled = k.name not in used

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

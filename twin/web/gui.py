"""The live twin's control panel: mechanism, planner and its knobs (and a second planner to
compare), sea, run controls, camera views, live plots, a readout of the metrics and limit
violations, a help panel; with a run store, the replay of stored runs and operability sweeps
around the current sea.

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

Replay and sweeps act as REST does (`twin.web.actions`); the sweep's progress and heatmap are
shown to every browser. Widgets that get frequent updates (plots, readout, replay time) are
never removed: viser's browser client applies a removal before the updates that came in the
same batch, and logs an error for each ("Tried to update non-existent component"); plots of
another layout are hidden and kept instead.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, get_args

import annotated_types as at
import numpy as np
import viser
import viser.uplot as up
from pydantic import BaseModel

from twin.mechanisms.hybrid import JOINT_NAMES
from twin.planners import PlannerParameters
from twin.planners.registry import PLANNERS
from twin.sim.faults import HOLDS, Fault
from twin.sim.live import COMPARE, LiveControls, LiveSession
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
#: what the browsers render (`twin.web.scene.configure_graphics`): "full" lights the scene
#: with an environment map (image-based reflections) and casts the sun's shadows (three
#: cascaded shadow maps, each drawing the scene again); "light" drops both, for a browser
#: without a GPU (a remote desktop, a virtual machine: WebGL on the CPU), where the
#: environment map costs most of each frame. The server's `--graphics` is every browser's
#: start; each browser switches its own (View → Graphics), and one that reports a software
#: renderer is switched to "light" (`twin.web.scene.Viewer.report_renderer`)
GRAPHICS = ("full", "light")
#: [s] how long the readout says that live time restarted (a compare planner change)
RESTART_NOTE = 15.0
#: what each mechanism holds still in the inertial frame: the landing point its tip error
#: is measured at (`FrameState.landing_offset`)
HOLDS_WHAT = {
    "hybrid": "gangway tip from its landing spot",
    "upu3up": "platform top from its held pose",
    "upr4": "pad centre from its held pose",
}
#: [m] leg-length tolerance of the limit readout (Table 1's millimetre precision)
LEG_TOL = 5e-4
#: [-] tolerance of the state-limit readout, a fraction of each state's range: a state held
#: on its limit (joint_limits "hold") is within it
STATE_TOL = 1e-4
#: [s] how often the list of stored runs to replay is read again
RUNS_PERIOD = 3.0
#: [s] how often a sweep's progress is read
SWEEP_POLL = 0.5
#: the compare dropdown's "no second planner"
NO_COMPARE = "none"
#: the replay dropdown's "no run chosen"
NO_RUN = "—"
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
    knob(Scenario, "heading", "Wave heading [deg] (180 from ahead, 90 from stbd, 270 from port)"),
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
        # position: the landing point's distance from where it is held (`landing_offset`)
        "Tip error: position [mm] (left), orientation [µrad] (right)",
        (_line("|e_p| [mm]", 0, "a"), _line("|e_r| [µrad]", 1, "b")),
        two,
        two_axes,
        lambda f: np.r_[
            1e3 * np.linalg.norm(f.landing_offset),
            1e6 * np.linalg.norm(f.record["tip_error"][3:]),
        ],
    )
    if fs.scenario.mechanism == "hybrid":
        joints: PlotSpec | None = PlotSpec(
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
        return legs, *(_with_ghost(p, fs) for p in (joints, error, extra))
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
    return legs, *(_with_ghost(p, fs) for p in (joints, error, extra))


def _with_ghost(spec: PlotSpec, fs: FrameState) -> PlotSpec:
    """The plot with the comparison lane's lines beside its own (dashed, its planner named),
    or as it is without one."""
    if fs.ghost is None:
        return spec
    name = fs.ghost.scenario.planner
    ghosts = tuple(
        up.Series(**{**dict(line), "label": f"{line.get('label')} · {name}", "dash": (5.0, 3.0)})
        for line in spec.series
    )
    own = spec.values

    def values(f: FrameState) -> np.ndarray:
        mine = own(f)
        other = own(f.ghost) if f.ghost is not None else np.full(mine.size, np.nan)
        return np.r_[mine, other]

    title = f"{spec.title} · dashed: {name}"
    return PlotSpec(title, (*spec.series, *ghosts), spec.scales, spec.axes, values)


def _layout(specs: Iterable[PlotSpec]) -> list[tuple[str, ...]]:
    """What a plot handle is built from: titles and series labels."""
    return [(p.title, *(str(s.get("label")) for s in p.series)) for p in specs]


def plain(value: float, digits: int = 3) -> str:
    """`value` to `digits` significant digits in plain notation, never an exponent."""
    value = float(value)
    if not np.isfinite(value) or value == 0.0:
        return f"{value:g}"
    decimals = max(0, digits - 1 - int(np.floor(np.log10(abs(value)))))
    return f"{value:.{decimals}f}"


#: SI prefixes the readout picks from, largest first
_PREFIXES = ((1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"))


def mm(length: float, digits: int = 3) -> str:
    """A length [m] in millimetres, the one unit of every tip error shown: `digits`
    significant digits in plain notation (1.39 m reads 1390 mm, 18 µm 0.0180 mm)."""
    return f"{plain(1e3 * float(length), digits)} mm"


def si(value: float, unit: str, digits: int = 3) -> str:
    """A quantity with the SI prefix that puts it in 1 … 1000 (n below, k above), in plain
    notation: 2500 mm reads 2.50 m, never 2.5e+03 mm."""
    size = abs(float(value))
    if size == 0.0 or not np.isfinite(size):
        return f"{plain(value, digits)} {unit}"
    scale, prefix = next(
        ((k, p) for k, p in _PREFIXES if size >= k * (1 - 5e-4)), _PREFIXES[-1]
    )
    return f"{plain(value / scale, digits)} {prefix}{unit}"


def state_units(fs: FrameState) -> list[tuple[float, str]]:
    """(factor, unit) that shows each state value: lengths in their own unit, angles in
    degrees."""
    names = fs.mechanism.state_names
    if fs.scenario.mechanism == "hybrid":
        angles = {"roll", "pitch", "yaw", "q1", "q2"}
        return [(np.degrees(1.0), "°") if n in angles else (1.0, " m") for n in JOINT_NAMES]
    length = " mm" if fs.scenario.mechanism == "upu3up" else " m"
    return [(1.0, length)] + [(np.degrees(1.0), "°")] * (len(names) - 1)


def limit_violations(fs: FrameState) -> list[str]:
    """Readable limit violations of the frame's legs and state (empty: all within limits).

    A leg counts beyond its stroke by more than `LEG_TOL`, a state beyond its limit by more
    than `STATE_TOL` of its range (a state held on its limit is within it); values print with
    the digits that show the difference."""
    out = []
    for i in np.flatnonzero(fs.leg_lengths < fs.leg_min - LEG_TOL):
        out.append(f"leg {i + 1}: {fs.leg_lengths[i]:.4f} m < {fs.leg_min[i]:.4f} m")
    for i in np.flatnonzero(fs.leg_lengths > fs.leg_max + LEG_TOL):
        out.append(f"leg {i + 1}: {fs.leg_lengths[i]:.4f} m > {fs.leg_max[i]:.4f} m")
    low, high = (np.asarray(v, float) for v in fs.mechanism.state_limits)
    tol = STATE_TOL * (high - low)
    names = fs.mechanism.state_names
    units = state_units(fs)
    for i in np.flatnonzero((fs.state < low - tol) | (fs.state > high + tol)):
        factor, unit = units[i]
        decimals = max(0, int(np.ceil(-np.log10(tol[i] * factor))) + 1)
        x, limit = fs.state[i] * factor, (low[i] if fs.state[i] < low[i] else high[i]) * factor
        sign = "<" if fs.state[i] < low[i] else ">"
        out.append(f"{names[i]}: {x:.{decimals}f}{unit} {sign} {limit:.{decimals}f}{unit}")
    return out


#: fault kinds that hold the mechanism for a step (a fault proper), and what the others mean
HELD_KINDS = tuple(f.name.lower() for f in Fault if f in HOLDS)
LIMIT_KINDS = {
    "joint_limit": "stopped at a limit",
    "singular": "damped near a singularity",
    "infeasible": "QP infeasible (closest rates taken)",
}


def fault_line(faults: dict[str, Any]) -> str:
    """The readout's line of numerical faults (`LiveSession.snapshot()["faults"]`): steps a
    fault held the mechanism for (base motion, planner, kinematics) and loop errors only."""
    counts = {k: n for k, n in faults.get("counts", {}).items() if n and k in HELD_KINDS}
    if not counts and not faults.get("loop_errors"):
        return "**Faults:** none (no step held)"
    parts = [f"{k.replace('_', ' ')} {n}" for k, n in counts.items()]
    if faults.get("loop_errors"):
        parts.append(f"loop errors {faults['loop_errors']}")
    line = "**⚠ Faults:** " + ", ".join(parts) + f" · {faults.get('held', 0)} steps held"
    events = [e for e in faults.get("events", []) if set(e["kinds"]) & set(HELD_KINDS)]
    if events:
        last = events[-1]
        line += f" · last at t = {last['end']:.2f} s: {', '.join(last['kinds'])}"
        if last["message"]:
            line += f" ({last['message'][:120]})"
    return line


def limit_line(faults: dict[str, Any], joint_limits: str) -> str:
    """Steps the planner shortened at a limit, damped or solved approximately: what the
    machine did to stay within its limits, not violations."""
    counts = faults.get("counts", {})
    parts = [f"{text} {counts[k]}" for k, text in LIMIT_KINDS.items() if counts.get(k)]
    if not parts:
        return "**Limit handling:** no step shortened, damped or approximated"
    how = "held at the limits" if joint_limits == "hold" else "limits recorded"
    return f"**Limit handling** ({how}; steps, not violations): " + ", ".join(parts)


#: the Help panel
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
the held place with a fixed magnification that its label states: ×10 000 for the gangway
tip (1 mm draws as 10 m), true size (×1) for the two platforms; older samples fade.

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


#: layout: the shared folders, in order (the last two only with a run store), and where the
#: shared readout, status lines and heatmap sit in theirs
FOLDERS = ("Run", "Mechanism and planner", "Sea", "View", "Replay", "Operability")
READOUT_ORDER = 100.0
#: buttons that act on the session or the store (disabled while locked); views stay open
ACTIONS = ("Play", "Pause", "Step", "Reset", "Watch in 3D", "Back to live", "Run sweep")
LOCKED = "controls are locked: enter the server's token under Access"
#: a browser's sweep settings (`ClientPanel.settings`, read by `TwinGui.run_sweep`), in panel
#: order: name → (label, min, max, step, initial value, hint)
SWEEP_SLIDERS: dict[str, tuple[str, float, float, float, float, str]] = {
    "sweep_hs_points": ("Hs cells", 3, 9, 1, 5,
                        "Hs values of the grid, evenly over the Hs span; the current Hs is one"),
    "sweep_hs_span": ("Hs span [±%]", 10.0, 90.0, 5.0, 50.0,
                      "the grid's Hs from (100 − span) % to (100 + span) % of the current Hs "
                      "(on a calm sea, Hs = 0: 0 … 2 × span / 100 m)"),
    "sweep_tp_points": ("Tp cells", 3, 7, 1, 3,
                        "Tp values of the grid, evenly over the Tp span; the current Tp is one"),
    "sweep_tp_span": ("Tp span [± s]", 0.5, 5.0, 0.5, 2.0,
                      "the grid's Tp from the current Tp − span to + span (kept within 1 … 30 s)"),
    "sweep_seeds": ("Seeds per cell", 1, 5, 1, 2,
                    "sea seeds per Hs × Tp cell (the same seeds in every cell)"),
    "sweep_duration": ("Run length [s]", 10.0, 200.0, 10.0, 60.0, "simulated time of each run"),
}  # fmt: skip
SWEEP_SETTINGS = tuple(SWEEP_SLIDERS)


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
        self.locked = locked
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
            for view in VIEWS:
                button = cg.add_button(VIEW_LABELS[view], icon=viser.Icon.CAMERA)
                button.on_click(lambda event, view=view: gui.on_camera(view, [client]))
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
        self._kept: dict[str, Any] = {k: h.value for k, h in self.settings.items()}
        self._replay_t = 0.0
        self._seen: dict[str, Any] = {}
        for name, handle in self.inputs.items():
            self._seen[name] = handle.value
            handle.on_update(self._callback(name))
        self._planner = s.planner
        self._show_planner_knobs(s.planner)
        if locked:
            self._offer_unlock()

    def _add_replay(self, folder: Any) -> None:
        """This browser's replay controls: a stored run, Watch, the time slider, Back to live."""
        cg, gui = self.client.gui, self.gui
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
            lambda event: gui.act(lambda: gui.watch(self), event.client, self)
        )
        self.buttons["Back to live"].on_click(
            lambda event: gui.act(gui.session.reset, event.client, self)
        )
        self.settings["replay_t"].on_update(self._on_seek)
        self.settings["replay_run"].on_update(self._on_setting("replay_run"))

    def _add_sweep(self, folder: Any) -> None:
        """This browser's sweep controls: the Hs × Tp grid, seeds, run length, Run sweep."""
        cg, gui = self.client.gui, self.gui
        with folder:
            for order, (name, (label, low, high, step, initial, hint)) in enumerate(
                SWEEP_SLIDERS.items()
            ):
                self.settings[name] = cg.add_slider(
                    label, min=low, max=high, step=step, initial_value=initial, order=order,
                    hint=hint,
                )  # fmt: skip
            self.buttons["Run sweep"] = cg.add_button(
                "Run sweep", icon=viser.Icon.CHART_BAR, order=len(SWEEP_SLIDERS),
                hint="Hs cells × Tp cells around the current sea (the spans above), each with "
                "the seeds per cell, with the current mechanism, planner and knobs, on the "
                "server's executor",
            )  # fmt: skip
        self.buttons["Run sweep"].on_click(
            lambda event: gui.act(lambda: gui.run_sweep(self), event.client, self)
        )
        for name in SWEEP_SETTINGS:
            self.settings[name].on_update(self._on_setting(name))

    def _on_setting(self, name: str) -> Callable[[viser.GuiEvent], None]:
        """A setting only this browser uses: a locked browser's edit is undone."""

        def on_update(event: viser.GuiEvent) -> None:
            if event.client is None:
                return
            handle = self.settings[name]
            if not self.gui.allowed(event.client):
                self.gui.refuse(event.client)
                _assign(handle, "value", self._kept.get(name, handle.value))
                return
            self._kept[name] = handle.value

        return on_update

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
                self._replay_t = float(handle.value)
                return
            except ValueError as err:
                self.client.add_notification("Not applied", str(err), color="red")
        _assign(handle, "value", shown["t"] if shown else 0.0)

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
        for label in ACTIONS:
            if label in self.buttons:
                _assign(self.buttons[label], "disabled", self.locked)
        for handle in self.settings.values():
            _assign(handle, "disabled", self.locked)
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
            value = self.inputs[name].value
            changes = {name: None if name == COMPARE and value == NO_COMPARE else value}
            if name == "mechanism" and self.gui.session.scenario.planner not in planners_for(
                changes[name]
            ):
                changes["planner"] = None  # the new mechanism's default planner
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
            _assign(self.inputs[COMPARE], "options",
                    (NO_COMPARE, *planners_for(values["mechanism"])))  # fmt: skip
        if values["planner"] != self._planner:
            self._planner = values["planner"]
            self._show_planner_knobs(values["planner"])
        for name, value in values.items():
            if value != self._seen[name]:
                self._seen[name] = value
                _assign(self.inputs[name], "value", value)
        if self.show_trail.value != trail:
            _assign(self.show_trail, "value", trail)

    def sync_replay(self, replay: dict[str, Any] | None, runs: tuple[str, ...]) -> None:
        """The replay widgets follow the session: the time slider spans the run replayed and
        shows its time; the run list follows the store."""
        if "replay_t" not in self.settings:
            return
        run = self.settings["replay_run"]
        if tuple(run.options) != runs:
            _assign(run, "options", runs)
        slider = self.settings["replay_t"]
        if replay is None:
            return
        if slider.max != replay["duration"]:
            _assign(slider, "max", max(replay["duration"], 0.05))
        if abs(replay["t"] - self._replay_t) > 1e-9:
            self._replay_t = replay["t"]
            _assign(slider, "value", round(replay["t"] / 0.05) * 0.05)

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
        access: Access | None = None,
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
        self.sweep_id: str | None = None
        self.heatmap: viser.GuiImageHandle | None = None
        self._stop = threading.Event()
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
        self._compare_seen: str | None = None
        gui = server.gui
        shown = FOLDERS if store is not None else FOLDERS[:4]
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
        self._plot_folder = gui.add_folder("Plots", order=len(shown))
        with gui.add_folder("Help", order=len(shown) + 1, expand_by_default=False):
            gui.add_markdown(HELP)
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
        handles = [*panel.inputs.values(), *panel.settings.values(), *panel.buttons.values()]
        for handle in [*handles, panel.show_trail, panel.graphics]:
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
            _assign(panel.graphics, "value", mode)
        if self.on_graphics is not None:
            self.on_graphics(panel.client, mode)

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
        """The session's value of a field or control (`compare_planner`: `NO_COMPARE` when
        none)."""
        if name == COMPARE:
            return self.session.compare_planner or NO_COMPARE
        if name in LiveControls.model_fields:
            return getattr(self.session.controls, name)
        return getattr(self.session.scenario, name)

    # -- replay and sweeps -----------------------------------------------------------------
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
            self.last_error = str(err)
            panel.client.add_notification("Not replayed", str(err), color="red")

    def run_sweep(self, panel: ClientPanel) -> None:
        """A sweep around the current scenario, submitted as `POST /api/sweeps` is; its
        progress, then its heatmap with the current sea ringed, show in every browser."""
        from twin.sim.sweep import spec_around
        from twin.web.actions import submit_sweep
        from twin.web.deps import MAX_PENDING_SWEEPS

        if self.sweep_id is not None:
            panel.client.add_notification("A sweep is running", "wait for its heatmap",
                                          auto_close_seconds=5.0, color="yellow")  # fmt: skip
            return
        try:
            if self.store.pending("sweeps") >= MAX_PENDING_SWEEPS:
                raise ValueError(f"{MAX_PENDING_SWEEPS} sweeps queued or running; retry later")
            scenario = self.session.scenario
            setting = {name: panel.settings[name].value for name in SWEEP_SETTINGS}
            spec = spec_around(
                scenario,
                seeds=int(setting["sweep_seeds"]),
                duration=float(setting["sweep_duration"]),
                hs_points=int(setting["sweep_hs_points"]),
                tp_points=int(setting["sweep_tp_points"]),
                hs_span=float(setting["sweep_hs_span"]) / 100.0,
                tp_span=float(setting["sweep_tp_span"]),
            )
            sweep = submit_sweep(self.store, self.sweeps, spec)
        except (TypeError, ValueError) as err:  # TypeError: a setting that is not a number
            self.last_error = str(err)
            panel.client.add_notification("Sweep not started", str(err), color="red")
            return
        self.sweep_id = sweep.id
        panel.client.add_notification(
            "Sweep started",
            f"Hs {len(spec.hs)} × Tp {len(spec.tp)} cells × {spec.seeds} seeds = {sweep.total} "
            f"runs of {spec.duration:g} s",
            auto_close_seconds=8.0,
        )  # fmt: skip
        threading.Thread(
            target=self._follow_sweep, args=(sweep.id, scenario.sea()), name="twin-gui-sweep",
            daemon=True,
        ).start()  # fmt: skip

    def _follow_sweep(self, sweep_id: str, sea: tuple[float, float]) -> None:
        """Show a sweep's progress until it ends, then its heatmap and links."""
        try:
            while not self._stop.wait(SWEEP_POLL):
                sweep = self.store.get_sweep(sweep_id)
                if sweep.status in ("queued", "running"):
                    self.sweep_status.content = (
                        f"**Sweep {sweep_id[:8]}** {sweep.status}: {sweep.done} of "
                        f"{sweep.total} runs ({100 * sweep.progress:.0f} %)"
                    )
                    continue
                if sweep.status == "failed":
                    self.sweep_status.content = f"**Sweep {sweep_id[:8]} failed:** {sweep.error}"
                else:
                    self._show_heatmap(sweep, sea)
                return
        except Exception as err:  # the store went away: say so, do not kill the viewer
            log.exception("following sweep %s failed", sweep_id)
            self.sweep_status.content = f"**Sweep {sweep_id[:8]}:** {err}"
        finally:
            self.sweep_id = None

    def _show_heatmap(self, sweep: Any, sea: tuple[float, float]) -> None:
        import tempfile
        from pathlib import Path

        import pandas as pd
        from PIL import Image

        from twin.sim.sweep import SweepResult, SweepSpec, heatmap_png

        result = SweepResult(
            SweepSpec(**sweep.spec), pd.DataFrame(), pd.DataFrame(sweep.result["cells"]),
            sweep.result["elapsed"], sweep.result["scheduler"],
        )  # fmt: skip
        with tempfile.TemporaryDirectory() as folder:
            path = heatmap_png(result, Path(folder) / "heatmap.png", mark=sea)
            image = np.asarray(Image.open(path).convert("RGB"))
        link = f"{self.api_url}/api/sweeps/{sweep.id}"
        seeds = int(sweep.spec.get("seeds", 1))
        self.sweep_status.content = sweep_text(
            sweep.id, sweep.total, seeds, float(sweep.spec.get("duration", 0.0)), sea, link
        )
        with self.folders["Operability"]:
            if self.heatmap is None:
                self.heatmap = self.server.gui.add_image(
                    image, label="operability [%]", format="png", order=READOUT_ORDER + 1
                )
            else:
                self.heatmap.image = image

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

    def close(self) -> None:
        """Stop following a sweep (the viewer is stopping)."""
        self._stop.set()

    # -- session → GUI ------------------------------------------------------------------------
    def restart(self, fs: FrameState) -> None:
        """After a reset or restart: clear the plots; rebuild them for a new mechanism."""
        specs = plot_specs(fs)
        key = tuple(_layout(specs))
        if key != tuple(_layout(self._specs)):
            # never removed (see the module's docstring): another layout's plots are hidden
            for handle in self.plots:
                _assign(handle, "visible", False)
            if key not in self._plot_sets:
                with self._plot_folder:
                    self._plot_sets[key] = [
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
            self.plots = self._plot_sets[key]
            for handle in self.plots:
                _assign(handle, "visible", True)
        self._specs = specs
        self._samples = np.zeros((len(specs), PLOT_SAMPLES, 1 + max(len(p.series) for p in specs)))
        self._count = 0
        self._tips.clear()
        self._next["plot"] = self._next["metrics"] = 0.0

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
            rows = self._samples[:, : self._count]
            for handle, spec, data in zip(self.plots, self._specs, rows, strict=True):
                handle.data = tuple(data[:, : 1 + len(spec.series)].T)
        if now >= self._next["metrics"]:
            self._next["metrics"] = now + METRICS_PERIOD
            snapshot = self.session.snapshot()
            self._metrics, self._faults = snapshot["metrics"], snapshot["faults"]
            self._compare = snapshot.get("compare")
        if slow:
            self._next["readout"] = now + READOUT_PERIOD
            self.readout.content = self._readout(fs)
            if "Replay" in self.folders:
                self.replay_status.content = replay_line(fs)

    def _sample(self, fs: FrameState) -> None:
        last = self._samples[0, self._count - 1, 0] if self._count else -np.inf
        if fs.t < last:  # a restart the version check has not seen yet
            self._count, last = 0, -np.inf
            self._tips.clear()
        if fs.t < last + PLOT_DT - 1e-9:
            return
        ghost = fs.ghost.landing_offset if fs.ghost is not None else np.zeros(3)
        self._tips.append((np.linalg.norm(fs.landing_offset), np.linalg.norm(ghost)))
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
        hs, tp = s.sea()
        sea = s.regular_waves or f"sea state {s.sea_state:g} (Hs {plain(hs)} m, Tp {plain(tp)} s)"
        where = f"replay of run {fs.replay['run_id'][:8]}" if fs.replay else "live"
        lines = [
            f"**t = {fs.t:.2f} s** · {where}, {'playing' if fs.playing else 'paused'} at "
            f"{fs.speed:g}× · {s.mechanism} / {s.planner} · {sea}",
            "",
            f"- tip error now: {mm(np.linalg.norm(fs.landing_offset))} "
            f"({HOLDS_WHAT[s.mechanism]}), orientation {si(np.linalg.norm(e[3:]), 'rad')}",
            f"- leg margin: {si(margin[worst], 'm')} (leg {worst + 1})",
        ]
        if "manipulability" in fs.record:
            lines.append(f"- manipulability: {plain(float(fs.record['manipulability']), 4)}")
        if "phi_e" in fs.record:
            lines.append(
                f"- gangway φe, θe: {si(float(fs.record['phi_e']), 'rad')}, "
                f"{si(float(fs.record['theta_e']), 'rad')}"
            )
        span = "the whole run" if fs.replay else "the history"
        m = self._metrics
        tips = np.asarray(self._tips)
        window = f"the last {PLOT_DT * len(tips):.0f} s"
        if tips.size:
            lines.append(
                f"- over {window}: tip error rms {mm(np.sqrt(np.mean(tips[:, 0] ** 2)))}, "
                f"max {mm(tips[:, 0].max())}"
            )
        c = self._compare
        if c is not None and fs.ghost is not None:
            cm = c["metrics"]
            ghost = tips[:, 1] if tips.size else np.zeros(1)
            lines.append(
                f"- ghost {c['planner']}: tip error now "
                f"{mm(np.linalg.norm(fs.ghost.landing_offset))}, over {window} rms "
                f"{mm(np.sqrt(np.mean(ghost**2)))}, max {mm(ghost.max())}; "
                f"{cm['violations']} samples beyond a limit"
            )
        if self.restarted is not None and time.monotonic() < self.restarted[0] + RESTART_NOTE:
            lines.insert(1, f"\n↺ **Live time restarted at t = 0:** {self.restarted[1]}\n")
        violations = limit_violations(fs)
        now = ("none now" if not violations
               else "⚠ now " + "; ".join(violations))  # fmt: skip
        over = f"{m['violations']} samples over {span}" if m else "…"
        # three paragraphs: held steps, what the limits did, what went beyond them
        lines += ["", fault_line(self._faults), "", limit_line(self._faults, s.joint_limits),
                  "", f"**Limit violations:** {now} · {over}"]  # fmt: skip
        return "\n".join(lines)


def plural(n: int, word: str) -> str:
    """`n` and `word`, plural unless n is 1: "1 seed", "2 seeds"."""
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def sweep_text(
    sweep_id: str, total: int, seeds: int, duration: float, sea: tuple[float, float], link: str
) -> str:
    """The Operability folder's text under a sweep's heatmap: what it ran, the ringed current
    sea (Hs to 0.1 m, Tp to 0.1 s, as the heatmap's ticks), why a cell can differ from the
    live run, and short links to the stored sweep (a bare URL would not wrap in the panel)."""
    return (
        f"**Sweep {sweep_id[:8]}** done: {plural(total, 'run')}, {plural(seeds, 'seed')} per "
        f"cell, {duration:g} s each. The ring marks the current sea (Hs {sea[0]:.1f} m, "
        f"Tp {sea[1]:.1f} s).\n\n"
        f"A cell's operability is the share of its runs ({plural(seeds, 'seed')}) that stayed "
        f"operable for the whole {duration:g} s, so it can differ from the live run (one "
        f"seed, seen over its last 30 s).\n\n"
        f"Stored: [sweep {sweep_id[:8]}]({link}) · [heatmap PNG]({link}/heatmap.png)"
    )


def replay_line(fs: FrameState) -> str:
    """The Replay folder's status: the run shown and its time, or live."""
    if fs.replay is None:
        return "Showing the live simulation. Choose a stored run to watch it."
    r = fs.replay
    return (f"**Replaying run {r['run_id'][:8]}** ({fs.scenario.mechanism} / "
            f"{fs.scenario.planner}): t = {r['t']:.2f} of {r['duration']:.2f} s")  # fmt: skip

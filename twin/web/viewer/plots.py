"""The live plots: which a mechanism gets (`plot_specs`: legs with their limits, gangway joints
or platform state, tip error, manipulability or tilt; the comparison lane dashed beside its
own), and `LivePlots`, the part of `TwinGui` that samples frames into them.

Plot handles are never removed: viser's browser client applies a removal before the updates
that came in the same batch, and logs an error for each ("Tried to update non-existent
component"); plots of another layout are hidden and kept instead.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import viser
import viser.uplot as up

from twin.web.viewer.frame_state import FrameState
from twin.web.viewer.knobs import assign

#: [s] simulated time between plotted samples, and samples kept (a 30 s window)
PLOT_DT = 0.1
PLOT_SAMPLES = 300
#: [s] wall-clock period of the plot data
PLOT_PERIOD = 0.1

PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf")


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
        series["stroke"], series["dash"], series["width"] = "#d62728", (6.0, 4.0), 1.0
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
        cast(up.Series, {**line, "label": f"{line.get('label')} · {name}", "dash": (5.0, 3.0)})
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


class LivePlots:
    """`TwinGui`'s plots: shared uPlot handles in the Plots folder, fed from each frame."""

    server: viser.ViserServer
    plots: list[viser.GuiUplotHandle]
    _plot_sets: dict[tuple, list[viser.GuiUplotHandle]]
    _plot_folder: Any
    _specs: tuple[PlotSpec, ...]
    _samples: np.ndarray
    _count: int
    _tips: deque[tuple[float, float]]
    _next: dict[str, float]

    def restart(self, fs: FrameState) -> None:
        """After a reset or restart: clear the plots; rebuild them for a new mechanism."""
        specs = plot_specs(fs)
        key = tuple(_layout(specs))
        if key != tuple(_layout(self._specs)):
            # never removed (see the module's docstring): another layout's plots are hidden
            for handle in self.plots:
                assign(handle, "visible", False)
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
                assign(handle, "visible", True)
        self._specs = specs
        self._samples = np.zeros((len(specs), PLOT_SAMPLES, 1 + max(len(p.series) for p in specs)))
        self._count = 0
        self._tips.clear()
        self._next["plot"] = self._next["metrics"] = 0.0

    def _sample(self, fs: FrameState) -> None:
        last = self._samples[0, self._count - 1, 0] if self._count else -np.inf
        if fs.t < last:  # a restart the version check has not seen yet
            self._count, last = 0, -np.inf
            self._tips.clear()
        if fs.t < last + PLOT_DT - 1e-9:
            return
        ghost = fs.ghost.landing_offset if fs.ghost is not None else np.zeros(3)
        self._tips.append((float(np.linalg.norm(fs.landing_offset)), float(np.linalg.norm(ghost))))
        if self._count == PLOT_SAMPLES:
            self._samples = np.roll(self._samples, -1, axis=1)
            self._count -= 1
        for k, spec in enumerate(self._specs):
            values = spec.values(fs)
            self._samples[k, self._count, : 1 + values.size] = np.r_[fs.t, values]
        self._count += 1

    def _push_plots(self) -> None:
        """Send the sampled window to every plot."""
        rows = self._samples[:, : self._count]
        for handle, spec, data in zip(self.plots, self._specs, rows, strict=True):
            handle.data = tuple(data[:, : 1 + len(spec.series)].T)

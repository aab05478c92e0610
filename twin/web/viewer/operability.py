"""Operability sweeps from the panel: each browser's grid settings (Hs and Tp cells and spans,
seeds, run length) and Run sweep, submitted as `POST /api/sweeps` is (`twin.web.actions`);
the sweep's progress, then its heatmap with the current sea ringed, shown to every browser.
One sweep at a time is followed.
"""

from __future__ import annotations

import logging
import threading
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import viser

from twin.web.viewer.knobs import READOUT_ORDER

if TYPE_CHECKING:
    from twin.web.viewer.gui import TwinGui
    from twin.web.viewer.panel import ClientPanel

log = logging.getLogger(__name__)

#: [s] how often a sweep's progress is read
SWEEP_POLL = 0.5
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


class SweepControls:
    """`ClientPanel`'s sweep controls (with a run store and a sweep runner)."""

    gui: TwinGui
    client: viser.ClientHandle
    settings: dict[str, Any]
    buttons: dict[str, Any]

    def _on_setting(self, name: str) -> Any: ...

    def _add_sweep(self, folder: Any) -> None:
        """This browser's sweep controls: the Hs × Tp grid, seeds, run length, Run sweep."""
        cg, gui = self.client.gui, self.gui
        panel = cast("ClientPanel", self)  # this mixin is only ever a ClientPanel
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
            lambda event: gui.act(lambda: gui.run_sweep(panel), event.client, panel)
        )
        for name in SWEEP_SETTINGS:
            self.settings[name].on_update(self._on_setting(name))


class Sweeps:
    """`TwinGui`'s sweeps: submit one, follow it, show its heatmap."""

    server: viser.ViserServer
    session: Any
    store: Any
    sweeps: Any
    api_url: str
    sweep_id: str | None
    submitting: bool
    heatmap: Any
    sweep_status: Any
    folders: dict[str, Any]
    _lock: threading.Lock
    _stop: threading.Event

    def note_error(self, message: str) -> None: ...

    def run_sweep(self, panel: ClientPanel) -> None:
        """A sweep around the current scenario, submitted as `POST /api/sweeps` is; its
        progress, then its heatmap with the current sea ringed, show in every browser."""
        from twin.runs.sweep import spec_around
        from twin.web.actions import submit_sweep
        from twin.web.deps import MAX_PENDING_SWEEPS

        with self._lock:  # two browsers pressing at once start one sweep
            busy = "starting" if self.submitting else None if self.sweep_id is None else "running"
            if not busy:
                self.submitting = True  # until the sweep is stored (its id known) or refused
        if busy:
            panel.client.add_notification(f"A sweep is {busy}", "wait for its heatmap",
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
            with self._lock:
                self.submitting = False
            self.note_error(str(err))
            panel.client.add_notification("Sweep not started", str(err), color="red")
            return
        except BaseException:
            with self._lock:
                self.submitting = False
            raise
        with self._lock:  # followed from now on: no second sweep until it ends
            self.sweep_id, self.submitting = sweep.id, False
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
            with self._lock:
                self.sweep_id = None

    def _show_heatmap(self, sweep: Any, sea: tuple[float, float]) -> None:
        import tempfile
        from pathlib import Path

        import pandas as pd
        from PIL import Image

        from twin.runs.sweep import SweepResult, SweepSpec, heatmap_png

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

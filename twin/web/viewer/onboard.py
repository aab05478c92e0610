"""The viewer's Onboard folder (issue 40): what the bridge sees of a measured motion source —
the stream or log followed (its status and newest sample), the sea estimated from it (or the
estimator's refusal while the window is short), operability now, the heading advice, the tip
error and leg margin measured over the session's history, and an alert when operability drops
under the threshold of the folder's slider.

The folder's "Motion source" dropdown switches the live session between the synthesised sea
and the live stream (with `twin serve --motion-udp`), as `PATCH /api/live {"motion_source":
…}` does, under the viewer's lock (a locked browser's choice is refused and undone); a log
chosen through REST shows as one more entry. The figures come from
`twin.runs.onboard_live.LiveOnboard`, which evaluates on a thread of its own (the viewer's
render loop only formats its newest result); the source's status from
`LiveSession.motion_state`, read at the readout's rate. The threshold is a display setting of
the folder, shared by every browser: it changes no simulation.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import viser

from twin.runs.onboard_live import LiveOnboard, alerts
from twin.runs.workability import OPERABLE_LEVEL
from twin.sim.live import LiveSession
from twin.web.viewer.readout import plain

if TYPE_CHECKING:
    from twin.web.viewer.gui import TwinGui

#: the folder's title (the browser test finds it by it)
TITLE = "Onboard"
#: the dropdown's entries → the motion source each chooses
SOURCES = {"synthesised sea": {"kind": "sea"}, "UDP stream": {"kind": "udp"}}


class OnboardFolder:
    """The shared Onboard folder: a threshold slider and the report's markdown."""

    def __init__(self, owner: TwinGui, gui: viser.GuiApi, session: LiveSession,
                 data_dir: Path | None, order: float) -> None:  # fmt: skip
        self.owner, self.session = owner, session
        self.onboard = LiveOnboard(session, data_dir)
        names = tuple(SOURCES) if session.motion is not None else tuple(SOURCES)[:1]
        with gui.add_folder(TITLE, order=order):
            self.source = gui.add_dropdown(
                "Motion source", names + _log_entry(session.motion_state()),
                initial_value=_entry(session.motion_state()),
                hint="what moves the hull: the synthesised sea, or the motion sensor's stream "
                "(twin serve --motion-udp); a stored log through PATCH /api/live",
            )  # fmt: skip
            self.source.on_update(self._on_source)
            self.threshold = gui.add_slider(
                "Alert under", min=0.0, max=1.0, step=0.05, initial_value=OPERABLE_LEVEL,
                hint="[0-1] alert when a planner's probability of being operable at the "
                "current relative heading is under it (a display setting of every browser)",
            )  # fmt: skip
            self.text = gui.add_markdown(onboard_text(None, session.motion_state(), 0.0))
        self.onboard.start()

    def update(self) -> None:
        """Show the newest evaluation and the source's status (the readout's rate); the
        dropdown follows a source chosen elsewhere."""
        state = self.session.motion_state()
        self.text.content = onboard_text(self.onboard.latest(), state,
                                         float(self.threshold.value))  # fmt: skip
        self._show(state)

    def _show(self, state: dict[str, Any]) -> None:
        """Put the dropdown on the session's source (a log's entry added while it plays)."""
        names = tuple(n for n in self.source.options if n in SOURCES) + _log_entry(state)
        if tuple(self.source.options) != names:
            self.source.options = names
        if self.source.value != _entry(state):
            self.source.value = _entry(state)  # type: ignore[misc]

    def _on_source(self, event: viser.GuiEvent) -> None:
        """A browser's choice: the session's source if the browser may and it applies."""
        client = event.client
        if client is None or self.source.value not in SOURCES:
            return  # the server's own update, or the log's entry chosen again
        if not self.owner.allowed(client):
            self.owner.refuse(client)
        else:
            try:
                self.session.patch({"motion_source": SOURCES[self.source.value]})
            except ValueError as err:
                self.owner.note_error(str(err))
                client.add_notification("Not applied", str(err), auto_close_seconds=8.0,
                                        color="red")  # fmt: skip
        self._show(self.session.motion_state())

    def close(self) -> None:
        self.onboard.stop()


def onboard_text(result: dict[str, Any] | None, source: dict[str, Any], threshold: float) -> str:
    """The folder's markdown: the source line, the newest sample, then the report's figures
    (`LiveOnboard.evaluate`) with an alert line under `threshold`."""
    lines = [_source_line(source)]
    if result is None:
        return "\n\n".join([*lines, "evaluating…"])
    if result.get("error"):
        return "\n\n".join([*lines, f"onboard report failed: {result['error']}"])
    if result["kind"] != source["kind"]:
        return "\n\n".join([*lines, "evaluating the new source…"])
    sea = result["estimate"]
    if sea is None:
        lines.append(f"**Sea estimate** refused ({result['window_s']:.0f} s of "
                     f"{result['needed_s']:.0f} s): {result['refused']}")  # fmt: skip
    else:
        side = " (port/starboard ambiguous)" if sea["ambiguous"] else ""
        lines.append(f"**Sea estimate** Hs {sea['hs']:.2f} ± {sea['hs_sd']:.2f} m · Tp "
                     f"{sea['tp']:.1f} ± {sea['tp_sd']:.1f} s · direction "
                     f"{sea['direction']:.0f} ± {sea['direction_sd']:.0f}°{side} (report "
                     f"{result.get('report_age_s', 0.0):.0f} s old)")  # fmt: skip
    if result["operability"]:
        lines.append("**Operability now** " + " · ".join(
            f"{p} {v:.2f}" for p, v in result["operability"].items()))  # fmt: skip
        for planner, ranked in result["advice"].items():
            best = " · ".join(f"{a['heading']:.0f}° ({a['probability']:.2f}, turn "
                              f"{a['turn']:+.0f}°)" for a in ranked[:3])  # fmt: skip
            lines.append(f"**Heading advice** {planner}: {best}")
    tip, margin = result["tip_error_max"], result["leg_margin"]
    lines.append(f"**Over the last {plain(result['span_s'], 2)} s** tip error max "
                 f"{_mm(tip)} · leg margin min {_mm(margin)}")  # fmt: skip
    low = alerts(result, threshold)
    if low:
        lines.append("**ALERT** operability under the threshold: " + ", ".join(low))
    return "\n\n".join(lines)


def _source_line(source: dict[str, Any]) -> str:
    """The source, its status and the newest sample of the live input."""
    kind, status = source["kind"], source["status"]
    if kind == "sea":
        return "**Motion source** the synthesised sea (no measured motion)"
    if kind == "log":
        return f"**Motion source** log {source['log']} at {source['speed']:g}× — {status}"
    head = f"**Motion source** stream {status}"
    if status == "stale":
        head += " (holding the last pose)"
    feed = source["input"] or {}
    counts = feed.get("counts", {})
    refused = counts.get("refused sender", 0)
    head += f" · samples {counts.get('samples', 0)} · refused senders {refused}"
    newest = feed.get("latest")
    if newest:
        head += (f"\n\nheave {newest['heave']:+.3f} m · roll {math.degrees(newest['roll']):+.2f}° "
                 f"· pitch {math.degrees(newest['pitch']):+.2f}°")  # fmt: skip
    return head


def _entry(state: dict[str, Any]) -> str:
    """The dropdown entry of a session's motion source."""
    if state["kind"] == "log":
        return _log_entry(state)[0]
    return next(name for name, source in SOURCES.items() if source["kind"] == state["kind"])


def _log_entry(state: dict[str, Any]) -> tuple[str, ...]:
    """The entry of a log being replayed (none otherwise)."""
    return (f"log {state['log']} at {state['speed']:g}×",) if state["kind"] == "log" else ()


def _mm(value: float | None) -> str:
    """A length [m] in millimetres, or "–" without one."""
    return "–" if value is None or not math.isfinite(value) else f"{value * 1000:.0f} mm"

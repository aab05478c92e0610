"""The viewer's Onboard folder (issue 40): what the bridge sees of a measured motion source —
the stream or log followed (its status and newest sample), the sea estimated from it (or the
estimator's refusal while the window is short), operability now, the heading advice, the tip
error and leg margin measured over the session's history, and an alert when operability drops
under the threshold of the folder's slider.

The figures come from `twin.sim.onboard_live.LiveOnboard`, which evaluates on a thread of its
own (the viewer's render loop only formats its newest result); the source's status from
`LiveSession.motion_state`, read at the readout's rate. The threshold is a display setting of
the folder, shared by every browser: it changes no simulation.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import viser

from twin.sim.live import LiveSession
from twin.sim.onboard_live import LiveOnboard, alerts
from twin.sim.workability import OPERABLE_LEVEL

#: the folder's title (the browser test finds it by it)
TITLE = "Onboard"


class OnboardFolder:
    """The shared Onboard folder: a threshold slider and the report's markdown."""

    def __init__(self, gui: viser.GuiApi, session: LiveSession, data_dir: Path | None,
                 order: float) -> None:  # fmt: skip
        self.session = session
        self.onboard = LiveOnboard(session, data_dir)
        with gui.add_folder(TITLE, order=order):
            self.threshold = gui.add_slider(
                "Alert under", min=0.0, max=1.0, step=0.05, initial_value=OPERABLE_LEVEL,
                hint="[0-1] alert when a planner's probability of being operable at the "
                "current relative heading is under it (a display setting of every browser)",
            )  # fmt: skip
            self.text = gui.add_markdown(onboard_text(None, session.motion_state(), 0.0))
        self.onboard.start()

    def update(self) -> None:
        """Show the newest evaluation and the source's status (the readout's rate)."""
        self.text.content = onboard_text(self.onboard.latest(), self.session.motion_state(),
                                         float(self.threshold.value))  # fmt: skip

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
                     f"{sea['direction']:.0f} ± {sea['direction_sd']:.0f}°{side}")  # fmt: skip
    if result["operability"]:
        lines.append("**Operability now** " + " · ".join(
            f"{p} {v:.2f}" for p, v in result["operability"].items()))  # fmt: skip
        for planner, ranked in result["advice"].items():
            best = " · ".join(f"{a['heading']:.0f}° ({a['probability']:.2f}, turn "
                              f"{a['turn']:+.0f}°)" for a in ranked[:3])  # fmt: skip
            lines.append(f"**Heading advice** {planner}: {best}")
    tip, margin = result["tip_error_max"], result["leg_margin"]
    lines.append(f"**Over the last {result['span_s']:.0f} s** tip error max "
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


def _mm(value: float | None) -> str:
    """A length [m] in millimetres, or "–" without one."""
    return "–" if value is None or not math.isfinite(value) else f"{value * 1000:.0f} mm"

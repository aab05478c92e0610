"""The readout: the run's state in words (time, mechanism and planner, sea, tip error, leg
margin, the ghost's figures), numerical faults, limit handling and limit violations; numbers
in plain notation with SI prefixes, never an exponent.
"""

from __future__ import annotations

import time
from collections import deque
from typing import Any

import numpy as np

from twin.sim.faults import HOLDS, Fault
from twin.sim.registries import HYBRID_JOINT_NAMES, LEG_PAST
from twin.web.viewer.frame_state import FrameState
from twin.web.viewer.plots import PLOT_DT

#: [s] how long the readout says that live time restarted (a compare planner change)
RESTART_NOTE = 15.0
#: what each mechanism holds still in the inertial frame: the landing point its tip error
#: is measured at (`FrameState.landing_offset`)
HOLDS_WHAT = {
    "hybrid": "gangway tip from its landing spot",
    "upu3up": "platform top from its held pose",
    "upr4": "pad centre from its held pose",
}
#: [-] tolerance of the state-limit readout, a fraction of each state's range: a state held
#: on its limit (joint_limits "hold") is within it
STATE_TOL = 1e-4
#: [m] a leg this close to a stroke end is at it: `joint_limits` "hold" stops a leg on its
#: limit to within numerical noise (nanometres), which the readout says in words
AT_LIMIT = 5e-5


def margin_text(margin: float) -> str:
    """A leg's distance [m] to its nearer stroke end as the readout says it: in mm, "at the
    limit" within `AT_LIMIT`, or how far beyond."""
    if abs(margin) < AT_LIMIT:
        return "at the limit"
    return mm(margin) if margin > 0.0 else f"{mm(-margin)} beyond the limit"


def at_limits(fs: FrameState) -> list[str]:
    """What sits at a limit in the frame: legs within `AT_LIMIT` of a stroke end, states
    within `STATE_TOL` of their range's end (e.g. "leg 3 at its stroke limit")."""
    margin = np.minimum(fs.leg_lengths - fs.leg_min, fs.leg_max - fs.leg_lengths)
    out = [f"leg {i + 1} at its stroke limit" for i in np.flatnonzero(margin < AT_LIMIT)]
    low, high = (np.asarray(v, float) for v in fs.mechanism.state_limits)
    tol = STATE_TOL * (high - low)
    near = (fs.state < low + tol) | (fs.state > high - tol)
    out += [f"{fs.mechanism.state_names[i]} at its limit" for i in np.flatnonzero(near)]
    return out


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
        return [(np.degrees(1.0), "°") if n in angles else (1.0, " m") for n in HYBRID_JOINT_NAMES]
    length = " mm" if fs.scenario.mechanism == "upu3up" else " m"
    return [(1.0, length)] + [(np.degrees(1.0), "°")] * (len(names) - 1)


def limit_violations(fs: FrameState) -> list[str]:
    """Readable limit violations of the frame's legs and state (empty: all within limits).

    A leg counts beyond its stroke as the metrics count it (`leg_past_lane`: by more than
    `twin.mechanisms.limits.LEG_TOL`), a state beyond its limit by more
    than `STATE_TOL` of its range (a state held on its limit is within it); values print with
    the digits that show the difference."""
    out = []
    past = np.asarray(LEG_PAST(fs.leg_lengths, fs.leg_min, fs.leg_max))
    for i in np.flatnonzero(past < 0.0):
        out.append(f"leg {i + 1}: {fs.leg_lengths[i]:.4f} m < {fs.leg_min[i]:.4f} m")
    for i in np.flatnonzero(past > 0.0):
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
HELD_KINDS = tuple(f.name.lower() for f in Fault if f in HOLDS and f.name)  # members: named
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


class Readout:
    """`TwinGui`'s readout text of a frame, from the metrics it last read."""

    _metrics: dict[str, Any]
    _faults: dict[str, Any]
    _compare: dict[str, Any] | None
    _tips: deque[tuple[float, float]]
    restarted: tuple[float, str] | None
    _since: dict[str, float]  # what sits at a limit → [s] since when (`_limits_since`)

    def _limits_since(self, fs: FrameState) -> str:
        """What sits at a limit and since when, in words ("leg 3 at its stroke limit since
        41.2 s"); "nothing" when all is within. A restart (time going back) starts afresh."""
        now = at_limits(fs)
        self._since = {k: t for k, t in self._since.items() if k in now and t <= fs.t}
        for what in now:
            self._since.setdefault(what, fs.t)
        if not now:
            return "nothing"
        return "⚠ " + "; ".join(f"{what} since {self._since[what]:.1f} s" for what in now)

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
            f"- tip error now: {mm(float(np.linalg.norm(fs.landing_offset)))} "
            f"({HOLDS_WHAT[s.mechanism]}), orientation {si(float(np.linalg.norm(e[3:])), 'rad')}",
            f"- leg margin: {margin_text(float(margin[worst]))} (leg {worst + 1})",
            f"- at a limit: {self._limits_since(fs)}",
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
        window = f"the last {plain(PLOT_DT * len(tips), 2)} s"  # 0.40 s early on, not "0 s"
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
                f"{mm(float(np.linalg.norm(fs.ghost.landing_offset)))}, over {window} rms "
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

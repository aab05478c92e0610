"""Check every figure README.md states against the code it describes, so the README stays true
for a newcomer. Run by tests/test_readme.py (so in CI) and by hand:

    python scripts/check_readme.py      # prints each check; exits 1 naming the wrong ones

Each check reads the README's own words (a regular expression over its text) and compares
them with the value the package computes: the kernel count, the health states, the live demo's
planners and seas, the ports, the image tag, the example's figures, the sweep spec's defaults,
the planner names. Timings are not stated in the README (docs/performance.md has them).
"""

from __future__ import annotations

import io
import json
import re
import sys
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


def flat(text: str) -> str:
    """The text with every run of white space one space: a phrase the README wraps still
    matches."""
    return " ".join(text.split())


def _kernels(text: str) -> list[str]:
    from twin.sim.engine import WARM_TOTAL

    stated = {int(n) for n in re.findall(r"(\d+) kernels\b", text)}
    stated |= {int(n) for n in re.findall(r"kernels \d+ of (\d+)", text)}
    return [] if stated == {WARM_TOTAL} else [f"kernels: README {stated}, engine {WARM_TOTAL}"]


def _health(text: str) -> list[str]:
    from twin.web.warmup import Warmup

    warmup = Warmup(out=io.StringIO())
    warming = warmup.status
    warmup.ready()
    stated = set(re.findall(r'`"status": "([a-z]+)"`', flat(text)))
    return [] if stated == {warming, warmup.status} else [
        f"health: README {stated}, the server {warming!r} then {warmup.status!r}"]  # fmt: skip


def _demo(text: str) -> list[str]:
    from twin.sim.live import LIVE_DEMO

    names = {"hybrid": "gangway", "upu3up": "3UPU_UP", "upr4": "4-UPR"}
    out = []
    for mechanism, demo in LIVE_DEMO.items():
        said = f"the {names[mechanism]} with `{demo['planner']}` at sea state {demo['sea_state']:g}"
        if said not in flat(text):
            out.append(f"live demo: README lacks {said!r}")
    return out


def _sea_state_4(text: str) -> list[str]:
    from twin.sim.scenario import Scenario

    hs = Scenario(sea_state=4).sea()[0]
    ok = f"{hs:.1f} m waves (sea state 4)" in flat(text)
    return [] if ok else [f"sea state 4: Hs is {hs:.1f} m"]


def _ports(text: str) -> list[str]:
    from twin.cli import build_parser, command_parser
    from twin.runs.executor import RUN_BUDGET

    serve = command_parser(build_parser(), "serve")
    defaults = serve.parse_args([])
    out = []
    for option, value in (("--port", defaults.port), ("--viser-port", defaults.viser_port),
                          ("--host", defaults.host), ("--data-dir", defaults.data_dir),
                          ("--run-budget", RUN_BUDGET)):  # fmt: skip
        row = re.search(rf"^\| `{option} [A-Z]+` \| `?([^`|]+)`? \|", text, re.MULTILINE)
        shown = f"{value:g}" if isinstance(value, float) else str(value)
        if row is None or row.group(1).strip() != shown:
            out.append(f"twin serve {option}: README {row and row.group(1)!r}, default {value!r}")
    for port, what in ((defaults.port, "8000"), (defaults.viser_port, "8080")):
        if str(port) != what or f"127.0.0.1:{port}" not in text:
            out.append(f"port {what}: the default is {port}")
    return out


def _image_tag(text: str) -> list[str]:
    docker = (ROOT / "Dockerfile").read_text()
    tags = set(re.findall(r"docker build -t (\S+) \.", text + docker))
    runs = set(re.findall(r"docker run .*\$TWIN_TOKEN (\S+)", text + docker))
    return [] if len(tags) == 1 and runs == tags else [f"image tags: {tags} built, {runs} run"]


def _example(text: str) -> list[str]:
    import numpy as np

    from twin.mechanisms import MECHANISMS

    hybrid = MECHANISMS["hybrid"]()
    xi = hybrid.working_state
    legs = hybrid.leg_lengths(xi)
    tip = hybrid.end_effector(xi)[:3, 3]
    out = []
    said_xi = re.search(r"\[x, y, z, roll, pitch, yaw, q1, q2, d3\] = \[([^\]]+)\]", text)
    if said_xi is None or not np.allclose([float(v) for v in said_xi.group(1).split(",")], xi):
        out.append(f"working state: {xi}")
    if not np.allclose(legs, legs[0]) or f"six legs, {legs[0]:.4f} m each" not in text:
        out.append(f"leg lengths: {legs}")
    if f"gangway tip ({tip[0]:.3f}, {abs(tip[1]):.0f}, {tip[2]:.3f}) m" not in text:
        out.append(f"gangway tip: {tip}")
    return out


def _preset(text: str) -> list[str]:
    from twin.sim import PAPER_PRESETS

    duration = PAPER_PRESETS["seed000"].duration
    ok = f"for {duration:g} simulated seconds" in flat(text)
    return [] if ok else [f"seed000 runs {duration:g} s"]


def _sweep(text: str) -> list[str]:
    from twin.runs.sweep import SweepSpec

    out = []
    spec = SweepSpec.model_validate_json((ROOT / "examples" / "sweep.json").read_text())
    if f"examples/sweep.json runs {len(spec.scenarios())} one-minute" not in text or (
        spec.duration != 60.0
    ):
        out.append(f"examples/sweep.json: {len(spec.scenarios())} runs of {spec.duration} s")
    defaults = SweepSpec().model_dump()
    for name in ("hs", "tp", "heading", "seeds", "duration", "dt", "tip_error_threshold"):
        row = re.search(rf"^\| `{name}` \| [^|]+ \| `([^`]+)` \|", text, re.MULTILINE)
        if row is None or json.loads(row.group(1)) != defaults[name]:
            said = row and row.group(1)
            out.append(f"sweep spec {name}: README {said}, default {defaults[name]}")
    return out


def _planners(text: str) -> list[str]:
    from twin.planners import PLANNERS

    hybrid = {n for n, spec in PLANNERS.items() if "hybrid" in spec.mechanisms}
    platforms = {n for n, spec in PLANNERS.items() if "upr4" in spec.mechanisms}
    said = re.search(r"Planners: ((?:`\w+`,? ?)+) for the hybrid system, ((?:`\w+`,? ?)+) for",
                     flat(text))  # fmt: skip
    if said is None:
        return ["planners: README's list not found"]
    listed = [set(re.findall(r"`(\w+)`", group)) for group in said.groups()]
    return [] if listed == [hybrid, platforms] else [f"planners: {hybrid}, {platforms}"]


def _live_motion(text: str) -> list[str]:
    """The live path's commands take the options the README gives them, the motion sources
    it names are the session's kinds, and its replay speeds are the allowed ones."""
    from twin.cli import build_parser
    from twin.sim.live import LiveMotionSource

    out = []
    for line in re.findall(r"^\.venv/bin/twin (serve --motion-udp .+|motion-replay .+)$", text,
                           re.MULTILINE):  # fmt: skip
        try:
            build_parser().parse_args(line.split())
        except SystemExit:
            out.append(f"live motion: `twin {line}` does not parse")
    kinds = set(re.findall(r'\{"kind": "(\w+)"', text))
    allowed = set(LiveMotionSource.model_json_schema()["properties"]["kind"]["enum"])
    if not kinds or not kinds <= allowed:
        out.append(f"live motion: README kinds {sorted(kinds)}, allowed {sorted(allowed)}")
    speed = LiveMotionSource.model_fields["speed"].metadata
    bounds = sorted(float(getattr(m, k)) for m in speed for k in ("ge", "le") if hasattr(m, k))
    said = re.search(r"at (\d+)–(\d+)×", text)
    if said is None or [float(v) for v in said.groups()] != bounds:
        out.append(f"live motion: README's replay speeds, allowed {bounds}")
    return out


#: every check: what it verifies → the function returning its failures
CHECKS: dict[str, Callable[[str], list[str]]] = {
    "kernel count": _kernels,
    "health states": _health,
    "live demo defaults": _demo,
    "sea state 4's wave height": _sea_state_4,
    "twin serve defaults and ports": _ports,
    "one image tag": _image_tag,
    "Python example figures": _example,
    "seed000's duration": _preset,
    "sweep spec defaults and example": _sweep,
    "planner names": _planners,
    "live motion path": _live_motion,
}


def check(text: str | None = None) -> dict[str, list[str]]:
    """The failures of every check of the README (`text`, default README.md), by check."""
    text = README.read_text() if text is None else text
    return {name: run(text) for name, run in CHECKS.items()}


def main() -> int:
    failures = check()
    for name, failed in failures.items():
        print(f"{'ok  ' if not failed else 'FAIL'} {name}" + "".join(f"\n     {f}" for f in failed))
    return 1 if any(failures.values()) else 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())

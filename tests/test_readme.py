"""The README stays true for a newcomer: every sweep-spec field and `twin serve` option is
documented, and the example sweep spec it runs is valid."""

from __future__ import annotations

import re
from pathlib import Path

from twin.cli import build_parser, command_parser
from twin.runs.sweep import SweepSpec

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_every_sweep_spec_field_has_a_row() -> None:
    """The README's sweep table has a row for every field of `SweepSpec`."""
    rows = set(re.findall(r"^\| `([a-z_]+)`", README, re.MULTILINE))
    rows |= {name for line in re.findall(r"^\| (`[a-z_]+`(?:, `[a-z_]+`)+) \|", README,
             re.MULTILINE) for name in re.findall(r"`([a-z_]+)`", line)}  # fmt: skip
    assert set(SweepSpec.model_fields) <= rows, set(SweepSpec.model_fields) - rows


def test_every_serve_option_is_in_the_readme() -> None:
    """Every `twin serve` option is named in the README."""
    serve = command_parser(build_parser(), "serve")
    options = {o for action in serve._actions for o in action.option_strings if o.startswith("--")}
    missing = sorted(o for o in options - {"--help"} if f"`{o}" not in README)
    assert not missing, f"README's `twin serve` options lack {missing}"


def test_the_example_sweep_spec_is_valid_and_its_size_as_said() -> None:
    """examples/sweep.json validates, and runs the 72 one-minute scenarios the README says."""
    spec = SweepSpec.model_validate_json((ROOT / "examples" / "sweep.json").read_text())
    assert "examples/sweep.json runs 72 one-minute" in README
    assert (len(spec.scenarios()), spec.duration) == (72, 60.0)


def test_every_figure_the_readme_states_is_checked_and_true() -> None:
    """scripts/check_readme.py finds every figure true (kernel count, health states, the live
    demo, ports, image tag, the example's figures, sweep defaults, planner names), and each of
    its checks fails on a README that states the figure wrong."""
    import importlib.util

    path = ROOT / "scripts" / "check_readme.py"
    spec = importlib.util.spec_from_file_location("check_readme", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.check() == {name: [] for name in module.CHECKS}
    wrong = {
        "kernel count": ("kernels 3 of 7", "kernels 3 of 6"),
        "health states": ('"status": "ok"', '"status": "ready"'),
        "live demo defaults": ("with `qp` at sea state 4", "with `mtmp` at sea state 4"),
        "one image tag": ("docker build -t wave-twin .", "docker build -t twin ."),
        "Python example figures": ("3.2335 m each", "3.2336 m each"),
        "twin serve defaults and ports": ("| `8000` |", "| `8001` |"),
    }
    for name, (right, bad) in wrong.items():
        assert right in README, right
        assert module.CHECKS[name](README.replace(right, bad)), name

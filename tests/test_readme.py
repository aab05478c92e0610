"""The README stays true for a newcomer: every sweep-spec field and `twin serve` option is
documented, and the example sweep spec it runs is valid."""

from __future__ import annotations

import re
from pathlib import Path

from twin.cli import build_parser
from twin.sim.sweep import SweepSpec

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_every_sweep_spec_field_has_a_row() -> None:
    rows = set(re.findall(r"^\| `([a-z_]+)`", README, re.MULTILINE))
    rows |= {name for line in re.findall(r"^\| (`[a-z_]+`(?:, `[a-z_]+`)+) \|", README,
             re.MULTILINE) for name in re.findall(r"`([a-z_]+)`", line)}  # fmt: skip
    assert set(SweepSpec.model_fields) <= rows, set(SweepSpec.model_fields) - rows


def test_every_serve_option_is_in_the_readme() -> None:
    serve = build_parser()._subparsers._group_actions[0].choices["serve"]  # type: ignore[union-attr]
    options = {o for action in serve._actions for o in action.option_strings if o.startswith("--")}
    missing = sorted(o for o in options - {"--help"} if f"`{o}" not in README)
    assert not missing, f"README's `twin serve` options lack {missing}"


def test_the_example_sweep_spec_is_valid_and_its_size_as_said() -> None:
    spec = SweepSpec.model_validate_json((ROOT / "examples" / "sweep.json").read_text())
    assert "examples/sweep.json runs 72 one-minute" in README
    assert (len(spec.scenarios()), spec.duration) == (72, 60.0)

"""Every ```python block of README.md and docs/*.md runs as a saved script (issue 38 item 10):
each is written to a file of its own and run with this interpreter in a fresh folder, so a
snippet that starts worker processes needs its `if __name__ == "__main__":` guard, and one that
uses a name it does not define fails.

A block whose fence reads ```python no-run is skipped; those are fragments that cannot run on
their own by design: docs/adding-a-planner.md's registry entry (a line of the `PLANNERS` tuple
that names the build function of the step before) and its `simulate` call on the planner those
two steps add to the package (tests/planners/test_adding_a_planner.py runs it with the entry
registered)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
#: the documents whose snippets are checked
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: a fenced block: its info string and its body
FENCE = re.compile(r"^```(?P<info>[^\n`]*)\n(?P<body>.*?)^```\s*$", re.MULTILINE | re.DOTALL)
#: [s] longest a snippet may take (they are kept cheap; this only stops a hung one)
TIMEOUT = 600.0


def snippets() -> list[tuple[str, str, str]]:
    """(document, first line number, info, code) of every ```python block."""
    found = []
    for document in DOCUMENTS:
        text = document.read_text(encoding="utf-8")
        for match in FENCE.finditer(text):
            info = match["info"].strip().split()
            if info[:1] != ["python"]:
                continue
            line = text.count("\n", 0, match.start()) + 1
            found.append((f"{document.relative_to(ROOT)}:{line}", " ".join(info), match["body"]))
    return found


SNIPPETS = snippets()


def test_the_documents_have_python_snippets() -> None:
    """The extraction finds the snippets the documents are known to hold (README's two among
    them), so an empty parametrisation cannot pass silently."""
    assert len(SNIPPETS) >= 8
    assert sum(name.startswith("README.md") for name, _, _ in SNIPPETS) >= 2


@pytest.mark.parametrize(
    ("name", "info", "code"), SNIPPETS, ids=[name for name, _, _ in SNIPPETS]
)
def test_snippet_runs_as_a_saved_script(
    name: str, info: str, code: str, tmp_path: Path
) -> None:
    """The snippet, saved as a .py file and run in an empty folder, exits 0."""
    if "no-run" in info.split():
        pytest.skip(f"{name}: marked no-run (a fragment; module docstring)")
    script = tmp_path / "snippet.py"
    script.write_text(code, encoding="utf-8")
    environment = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    done = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, env=environment, capture_output=True,
        text=True, timeout=TIMEOUT, check=False,
    )  # fmt: skip
    assert done.returncode == 0, f"{name} failed:\n{done.stderr[-3000:]}"

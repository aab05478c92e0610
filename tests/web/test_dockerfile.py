"""The Dockerfile's install steps, replayed without a Docker engine (none runs on our machines).

The COPY and RUN lines are read from the Dockerfile itself and replayed in a fresh virtual
environment: the same files, the same locked `pip install` (from pip's cache where CI has just
downloaded the wheels; without the bytecode the image's build writes). Then the installed
package — not the source tree — must run the CLI and find its packaged URDFs, RAO tables and
landing page. The instructions themselves are linted in tests/web/test_cli.py.
"""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOCKERFILE = (ROOT / "Dockerfile").read_text()


def instructions(name: str) -> list[str]:
    """Arguments of every `name` instruction (continuation lines joined)."""
    text = DOCKERFILE.replace("\\\n", " ")
    return [m.group(1).strip() for m in re.finditer(rf"^{name}\s+(.*)$", text, re.MULTILINE)]


def test_install_steps_replay_in_a_fresh_environment(tmp_path: Path) -> None:
    """The image installs exactly the locked set with hashes, then the package without its
    dependencies (nothing unpinned), from the files its COPY lines bring."""
    src = tmp_path / "src"
    src.mkdir()
    for copy in instructions("COPY"):
        *sources, destination = copy.split()
        target = src / destination.removeprefix("./") if destination not in (".", "./") else src
        for source in sources:
            path = ROOT / source
            if path.is_dir():
                shutil.copytree(path, target, ignore=shutil.ignore_patterns("__pycache__"))
            elif destination.endswith("/"):
                target.mkdir(parents=True, exist_ok=True)
                shutil.copy(path, target / path.name)
            else:
                shutil.copy(path, src / path.name)
    runs = [r for r in instructions("RUN") if "pip install" in r]
    assert len(runs) == 1 and runs[0].endswith("&& rm -rf /src"), runs
    steps = [shlex.split(step) for step in runs[0].split("&&")[:-1]]
    # the locked set with its hashes first, then the package alone: nothing unpinned
    assert steps == [
        ["pip", "install", "--require-hashes", "-r", "requirements/serve.txt"],
        ["pip", "install", "--no-deps", "."],
    ]
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    python = venv / "bin" / "python"
    for step in steps:
        # --no-compile: the same files installed without their bytecode, which pip would
        # otherwise write for every dependency (half the replay's time, measured 72 s against
        # 34 s); Python compiles what the probes below import as they import it
        subprocess.run(
            [str(python), "-m", "pip", "install", "--quiet", "--no-compile", *step[2:]],
            cwd=src, check=True, timeout=1200,
        )  # fmt: skip
    shutil.rmtree(src)  # as the image does: nothing may depend on the source tree
    help_text = subprocess.run(
        [str(venv / "bin" / "twin"), "serve", "--help"], capture_output=True, text=True, check=True
    ).stdout
    assert "--viser-port" in help_text
    probe = (
        "from twin.assets import asset_path; import twin, twin.web.api, twin.web.viewer; "
        "from pathlib import Path; pkg = Path(twin.__file__).parent; "
        "assert '_assets' in str(asset_path('urdf')), asset_path('urdf'); "
        "assert asset_path('urdf', 'hybrid.urdf').is_file(); "
        "assert asset_path('vessels', 'sov.nc').is_file(); "
        "assert (pkg / '_static' / 'index.html').is_file(); print('ok')"
    )
    out = subprocess.run(
        [str(python), "-c", probe], capture_output=True, text=True, cwd=tmp_path, check=True
    )
    assert out.stdout.strip() == "ok"

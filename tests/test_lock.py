"""The lock files: every dependency pinned with hashes, the serve set a subset of the test set,
and the environment the tests run in installed from them (unless `make test-latest` asked for
the newest releases). The Dockerfile's replay (tests/web/test_dockerfile.py) installs
requirements/serve.txt into a fresh environment with pip's hash checking."""

from __future__ import annotations

import os
import re
import tomllib
from importlib import metadata
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[1]
PIN = re.compile(r"^([A-Za-z0-9._-]+)(?:\[[^\]]*\])?==([^\s\\;]+)")


def pins(name: str) -> dict[str, str]:
    """{canonical name: version} of a lock file; each pin must carry at least one hash."""
    text = (ROOT / "requirements" / name).read_text()
    found: dict[str, str] = {}
    for block in re.split(r"\n(?=[A-Za-z0-9])", text):
        match = PIN.match(block)
        if match is None:
            continue
        assert "--hash=sha256:" in block, f"{name}: {match[1]} has no hash"
        found[canonicalize_name(match[1])] = match[2]
    return found


def declared(*extras: str) -> set[str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    lines = list(project["dependencies"])
    for extra in extras:
        lines += project["optional-dependencies"][extra]
    return {canonicalize_name(Requirement(line).name) for line in lines}


def test_every_declared_dependency_is_pinned_in_range() -> None:
    """Every dependency pyproject.toml declares is locked at a version inside its declared range."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    locked = pins("test.txt")
    lines = [*project["dependencies"]]
    for extra in ("test", "hydro"):
        lines += project["optional-dependencies"][extra]
    for line in lines:
        requirement = Requirement(line)
        name = canonicalize_name(requirement.name)
        assert name in locked, f"{name} is declared in pyproject.toml but not locked"
        assert requirement.specifier.contains(locked[name], prereleases=True), (
            f"{name}=={locked[name]} is outside pyproject.toml's {requirement.specifier}: "
            "run `make lock`"
        )


def test_the_serve_set_is_the_test_sets_versions() -> None:
    """The serve lock holds every declared dependency at the test lock's versions."""
    serve, test = pins("serve.txt"), pins("test.txt")
    assert declared() <= set(serve)
    assert {name: test.get(name) for name in serve} == serve


def test_uv_and_netsse_are_pinned() -> None:
    """The bootstrap lock pins uv alone and the netsse lock netsse alone."""
    assert set(pins("bootstrap.txt")) == {"uv"}
    assert set(pins("netsse.txt")) == {"netsse"}


@pytest.mark.skipif(
    os.environ.get("TWIN_REQUIREMENTS") == "latest", reason="make test-latest: newest releases"
)
def test_this_environment_was_installed_from_the_lock() -> None:
    """What the suite runs on is what the lock says (a fresh `make test` installs it)."""
    locked = pins("test.txt") | pins("netsse.txt")
    installed = {
        canonicalize_name(d.metadata["Name"]): d.version for d in metadata.distributions()
    }
    wrong = {
        name: (installed[name], version)
        for name, version in locked.items()
        if name in installed and installed[name] != version
    }
    missing = sorted(set(locked) - set(installed))
    assert not wrong, f"installed vs locked: {wrong}"
    assert not missing, f"locked but not installed: {missing}"

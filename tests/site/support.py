"""What the site tests share: the build scripts of the shipped records, as modules."""

from __future__ import annotations

import importlib.util
from types import ModuleType

import pytest

from twin.assets import asset_path


def script_module(name: str) -> ModuleType:
    """scripts/`name`.py loaded as a module; the test is skipped where scripts/ is not beside
    the package (an installed wheel)."""
    script = asset_path("..", "scripts", f"{name}.py")
    if not script.is_file():
        pytest.skip("scripts/ is not beside an installed package (a wheel)")
    spec = importlib.util.spec_from_file_location(name, script)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module

"""Where the shipped assets (URDF, meshes, RAO tables) live.

In a source checkout or editable install they are the repository's `assets/`; in a wheel
they are packaged as `twin/_assets` (pyproject `force-include`).
"""

from __future__ import annotations

from pathlib import Path

_HERE = Path(__file__).resolve().parent
ASSETS_DIR: Path = next(
    (p for p in (_HERE.parent / "assets", _HERE / "_assets") if p.is_dir()), _HERE.parent / "assets"
)


def asset_path(*parts: str) -> Path:
    """Path of a shipped asset, e.g. `asset_path("urdf", "hybrid.urdf")`."""
    return ASSETS_DIR.joinpath(*parts)

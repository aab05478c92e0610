"""The REST API's routers, one per resource: registries (and health), runs, sweeps,
site workability, live.

Each takes what it needs as dependencies (`twin.web.deps`); `twin.web.api.create_app`
includes them.
"""

from __future__ import annotations

from twin.web.routers import live, registries, runs, sweeps, workability

__all__ = ["live", "registries", "runs", "sweeps", "workability"]

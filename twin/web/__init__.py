"""Web layer: the REST API, the run store and its jobs, and `serve`, which runs them with the
live session, the 3D viewer (`twin.web.viewer`) and the one executor of runs and sweeps
(`twin.runs.executor`) in one process.

It calls the runs layer (`twin.runs`) and the simulation layer (`twin.sim`), and reads
the registries below them through `twin.sim.registries`.
"""

from __future__ import annotations

from twin.db import StoreUnavailable
from twin.web.access import Access
from twin.web.api import create_app
from twin.web.jobs import SYNC_MAX_STEPS, JobRunner, SweepRunner
from twin.web.server import serve
from twin.web.store import Run, RunNotFound, RunStore, Sweep

__all__ = [
    "SYNC_MAX_STEPS",
    "Access",
    "JobRunner",
    "Run",
    "RunNotFound",
    "RunStore",
    "StoreUnavailable",
    "Sweep",
    "SweepRunner",
    "create_app",
    "serve",
]

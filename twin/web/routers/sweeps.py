"""Operability sweeps: queued on the executor, their table and heatmap served."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException, Request, Response

from twin.sim.sweep import SweepSpec
from twin.web.actions import SweepScenarioError, submit_sweep
from twin.web.deps import GUARDED, AdmissionDep, Store, Sweeps
from twin.web.models import RANGES, body_errors, unprocessable
from twin.web.routers.responses import LIMITED, STORE
from twin.web.store import Sweep

router = APIRouter(prefix="/api/sweeps", tags=["sweeps"])


@router.post("", status_code=202, response_model=Sweep, dependencies=GUARDED, responses=LIMITED)
def create_sweep(
    spec: SweepSpec,
    request: Request,
    response: Response,
    store: Store,
    sweeps: Sweeps,
    admission: AdmissionDep,
) -> Any:
    """Queue an operability sweep (the `SweepSpec` fields; omitted ones take defaults).

    Answers 202 at once; poll `GET /api/sweeps/{id}` (the Location header) for status and
    progress (runs done of total) and, once done, the operability table. It runs on the
    server's executor, its chunks behind single runs. An empty axis or a grid over the caps
    (`twin.sim.sweep.MAX_CELLS`, `MAX_RUNS`, `MAX_TOTAL_STEPS`) is a 422 naming the field.
    Sweeps share the runs' rate limit; at most `MAX_PENDING_SWEEPS` wait at a time.
    """
    ranges = RANGES[("POST", "/api/sweeps")]
    admission.admit(request, "sweeps", store.pending("sweeps"))
    try:
        sweep = submit_sweep(store, sweeps, spec)
    except SweepScenarioError as exc:
        errors = body_errors(exc.cause)
        for e in errors:
            e["loc"] = ("body", "scenario", *e["loc"][1:])
        return unprocessable(errors, ranges)
    response.headers["Location"] = f"/api/sweeps/{sweep.id}"
    return sweep


@router.get("/{sweep_id}", responses={404: {"description": "no sweep"}, **STORE})
def get_sweep(sweep_id: str, store: Store) -> Sweep:
    """A sweep's status, progress and (once done) operability table with its criterion."""
    return store.get_sweep(sweep_id)


@router.get(
    "/{sweep_id}/heatmap.png",
    response_class=Response,
    responses={
        200: {"content": {"image/png": {}}, "description": "operability heatmaps"},
        404: {"description": "no sweep"},
        409: {"description": "the sweep is not done"},
        **STORE,
    },
)
def get_sweep_heatmap(sweep_id: str, store: Store) -> Response:
    """A done sweep's heatmap: Hs × Tp per planner, heading and (β, k_e, k_c)."""
    sweep = store.get_sweep(sweep_id)
    if sweep.status != "done":
        raise HTTPException(409, f"sweep {sweep_id} is {sweep.status}; heatmap once done")
    return Response(store.sweep_heatmap(sweep_id), media_type="image/png")

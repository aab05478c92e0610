"""Operability sweeps: queued on the executor, their table and heatmap served."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException, Request, Response

from twin.runs.sweep import SweepSpec
from twin.web.actions import SweepScenarioError, submit_sweep
from twin.web.deps import GUARDED, AdmissionDep, Store, Sweeps
from twin.web.limits import sweep_over_limits
from twin.web.models import RANGES, body_errors, unprocessable
from twin.web.routers.responses import LIMITED, REFUSED, STORE
from twin.web.store import QueueFull, StoreFull, Sweep

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
    (`twin.runs.sweep.MAX_CELLS`, `MAX_RUNS`, `MAX_TOTAL_STEPS`) is a 422 naming the field.
    Sweeps share the runs' rate limit; at most `MAX_PENDING_SWEEPS` wait at a time.
    """
    ranges = RANGES[("POST", "/api/sweeps")]
    over = sweep_over_limits(spec)  # priced before anything is stored or run
    if over:
        return unprocessable(over, ranges)
    admission.admit(request, "sweeps", store.pending("sweeps"))
    try:
        sweep = submit_sweep(store, sweeps, spec, max_pending=admission.caps["sweeps"])
    except SweepScenarioError as exc:
        errors = body_errors(exc.cause)
        for e in errors:
            e["loc"] = ("body", "scenario", *e["loc"][1:])
        return unprocessable(errors, ranges)
    except QueueFull as exc:  # another request took the last place meanwhile
        raise HTTPException(429, str(exc), headers={"Retry-After": "5"}) from None
    except StoreFull as exc:  # the quota (--max-store): nothing stored
        raise HTTPException(507, str(exc)) from None
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


#: what cancelling and deleting answer
_CANCEL = {404: {"description": "no sweep"}, **REFUSED, **STORE}


@router.post("/{sweep_id}/cancel", dependencies=GUARDED, responses=_CANCEL)
def cancel_sweep(sweep_id: str, sweeps: Sweeps) -> Sweep:
    """Cancel a queued or running sweep: it becomes `failed` with `error` "cancelled by
    request"; one running stops after the chunk in hand. A finished sweep stays as it is."""
    sweeps.cancel(sweep_id)
    return sweeps.store.get_sweep(sweep_id)


@router.post("/{sweep_id}/pin", dependencies=GUARDED, responses=_CANCEL)
def pin_sweep(sweep_id: str, sweeps: Sweeps, pinned: bool = True) -> Sweep:
    """Keep a sweep from retention (`twin serve --retain`); `?pinned=false` lets it go."""
    sweeps.store.pin("sweeps", sweep_id, pinned)
    return sweeps.store.get_sweep(sweep_id)


@router.delete("/{sweep_id}", status_code=204, dependencies=GUARDED, responses=_CANCEL)
def delete_sweep(sweep_id: str, sweeps: Sweeps) -> Response:
    """Cancel the sweep if it is queued or running, then delete it with its table and heatmap."""
    sweeps.cancel(sweep_id)  # SweepNotFound: 404
    sweeps.store.delete_sweep(sweep_id)
    return Response(status_code=204)

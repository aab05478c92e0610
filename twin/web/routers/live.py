"""The live session: read it, patch it, and play, pause, step or reset it."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Query, Response

from twin.web.actions import start_replay
from twin.web.deps import GUARDED, Session, Store
from twin.web.models import (
    RANGES,
    LivePatch,
    LiveState,
    ReplayRequest,
    body_errors,
    unprocessable,
)
from twin.web.routers.responses import BAD_INPUT, REFUSED, STORE

router = APIRouter(prefix="/api/live", tags=["live"])


@router.get("", response_model=LiveState)
def get_live(session: Session) -> dict[str, Any]:
    """The live session: scenario fields, `t` [s], `speed`, `playing` and metrics; `compare`
    (planner, metrics) when a second planner runs beside the first; `replay` (run id, time)
    while a stored run is shown."""
    return session.snapshot()


@router.patch("", response_model=LiveState, dependencies=GUARDED, responses=BAD_INPUT)
def patch_live(changes: LivePatch, session: Session) -> Any:
    """Change any scenario field and/or `speed`, `playing`; effective on the next step.

    The body's fields are parsed here, then the new scenario is validated once, as a whole,
    before any of it applies: one bad value, an empty or unknown name included, is a 422 and
    changes nothing. `mechanism`, `vessel`, `dt` or `initial_state` restart the session at
    t = 0. `playing` is true or false, nothing else.

    `compare_planner` adds a second lane: the same scenario and vessel motion under another
    planner of the mechanism (the viewer draws it as a translucent ghost, `GET` answers its
    metrics under `compare`); every later change applies to both lanes but that planner;
    null stops it. Setting, changing or stopping it restarts at t = 0. The answer's `restarted`
    says whether this change restarted live time (and `restart_reason` why). While a stored run is
    replayed, `speed` and `playing` act on the replay and any other field returns to live.
    """
    ranges = RANGES[("PATCH", "/api/live")]
    before = session.restarts
    try:
        session.patch(changes.model_dump(exclude_unset=True))
    except ValueError as exc:
        return unprocessable(body_errors(exc, ranges), ranges)
    return {**session.snapshot(), "restarted": session.restarts != before}


@router.post("/reset", response_model=LiveState, dependencies=GUARDED, responses=BAD_INPUT)
def reset_live(session: Session) -> Any:
    """Start the current scenario again from t = 0 (a replay shown returns to live)."""
    try:
        session.reset()
    except ValueError as exc:  # the scenario in force cannot start (nothing changed)
        return unprocessable(body_errors(exc), {})
    return session.snapshot()


@router.post("/pause", response_model=LiveState, dependencies=GUARDED, responses=REFUSED)
def pause_live(session: Session) -> dict[str, Any]:
    session.pause()
    return session.snapshot()


@router.post("/play", response_model=LiveState, dependencies=GUARDED, responses=REFUSED)
def play_live(session: Session) -> dict[str, Any]:
    session.play()
    return session.snapshot()


@router.post(
    "/step",
    response_model=LiveState,
    dependencies=GUARDED,
    responses={
        200: {"headers": {"X-Steps-Taken": {"description": "steps taken (fewer than n when "
              "the wall-clock cap was reached)", "schema": {"type": "integer"}}}},
        **BAD_INPUT,
    },
)  # fmt: skip
def step_live(
    session: Session, response: Response, n: Annotated[int, Query(ge=1, le=1000)] = 1
) -> dict[str, Any]:
    """Advance n steps now, also while paused.

    The session's lock is taken a few steps at a time, so readers are served between them,
    and stepping stops after `twin.sim.live.STEP_WALL` (2 s) of wall time: `X-Steps-Taken`
    says how many were taken.
    """
    response.headers["X-Steps-Taken"] = str(session.step(n))
    return session.snapshot()


@router.post(
    "/replay",
    response_model=LiveState,
    dependencies=GUARDED,
    responses={
        404: {"description": "no run"},
        409: {"description": "the run is not done"},
        **BAD_INPUT,
        **STORE,
    },
)
def replay_live(body: ReplayRequest, session: Session, store: Store) -> Any:
    """Play a stored run in the 3D viewer from `t` [s] instead of the live simulation.

    Nothing is simulated: the viewer shows the run's recorded samples. `GET /api/live`
    answers the run's scenario and metrics with `replay` (run id, `t`, duration); `speed`,
    `playing`, `/play`, `/pause` and `/step` act on the replay, which pauses at its end.
    Posting the same run id again seeks to `t`. `POST /api/live/reset`, or a change of any
    scenario field, returns to the live simulation.
    """
    ranges = RANGES[("POST", "/api/live/replay")]
    shown = session.replaying
    if shown is None or shown["run_id"] != body.run_id:
        run = store.get(body.run_id)
        if run.status != "done":
            raise HTTPException(409, f"run {body.run_id} is {run.status}; it replays once done")
    try:
        start_replay(session, store, body.run_id, body.t, body.playing)
    except ValueError as exc:
        return unprocessable(body_errors(exc, ranges), ranges)
    return session.snapshot()

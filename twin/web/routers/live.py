"""The live session: read it, patch it, and play, pause, step or reset it."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Query, Response

from twin.web.deps import GUARDED, Session
from twin.web.models import RANGES, LivePatch, LiveState, body_errors, unprocessable
from twin.web.routers.responses import BAD_INPUT, REFUSED

router = APIRouter(prefix="/api/live", tags=["live"])


@router.get("")
def get_live(session: Session) -> LiveState:
    """The live session: scenario fields, `t` [s], `speed`, `playing` and metrics."""
    return session.snapshot()


@router.patch("", response_model=LiveState, dependencies=GUARDED, responses=BAD_INPUT)
def patch_live(changes: LivePatch, session: Session) -> Any:
    """Change any scenario field and/or `speed`, `playing`; effective on the next step.

    The body's fields are parsed here, then the new scenario is validated once, as a whole,
    before any of it applies: one bad value, an empty or unknown name included, is a 422 and
    changes nothing. `mechanism`, `vessel`, `dt` or `initial_state` restart the session at
    t = 0. `playing` is true or false, nothing else.
    """
    ranges = RANGES[("PATCH", "/api/live")]
    try:
        session.patch(changes.model_dump(exclude_unset=True))
    except ValueError as exc:
        return unprocessable(body_errors(exc, ranges), ranges)
    return session.snapshot()


@router.post("/reset", response_model=LiveState, dependencies=GUARDED, responses=BAD_INPUT)
def reset_live(session: Session) -> Any:
    """Start the current scenario again from t = 0."""
    try:
        session.reset()
    except ValueError as exc:  # the scenario in force cannot start (nothing changed)
        return unprocessable(body_errors(exc), {})
    return session.snapshot()


@router.post("/pause", dependencies=GUARDED, responses=REFUSED)
def pause_live(session: Session) -> LiveState:
    session.pause()
    return session.snapshot()


@router.post("/play", dependencies=GUARDED, responses=REFUSED)
def play_live(session: Session) -> LiveState:
    session.play()
    return session.snapshot()


@router.post(
    "/step",
    dependencies=GUARDED,
    responses={
        200: {"headers": {"X-Steps-Taken": {"description": "steps taken (fewer than n when "
              "the wall-clock cap was reached)", "schema": {"type": "integer"}}}},
        **BAD_INPUT,
    },
)  # fmt: skip
def step_live(
    session: Session, response: Response, n: Annotated[int, Query(ge=1, le=1000)] = 1
) -> LiveState:
    """Advance n steps now, also while paused.

    The session's lock is taken a few steps at a time, so readers are served between them,
    and stepping stops after `twin.sim.live.STEP_WALL` (2 s) of wall time: `X-Steps-Taken`
    says how many were taken.
    """
    response.headers["X-Steps-Taken"] = str(session.step(n))
    return session.snapshot()

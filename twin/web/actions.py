"""What the REST routes and the viewer's panel both do: replay a stored run, submit a sweep.

One function each, so a browser's panel acts exactly as a REST client does (the same
validation, the same store rows, the same runner); the callers check who may act.
"""

from __future__ import annotations

import math

from twin.errors import TwinError
from twin.runs.sweep import AXES, SweepSpec
from twin.sim.live import LiveSession
from twin.web.jobs import SweepRunner
from twin.web.models import RunRequest
from twin.web.store import RunStore, Sweep


def start_replay(
    session: LiveSession, store: RunStore, run_id: str, t: float = 0.0, playing: bool = True
) -> None:
    """Show a stored run in the live view from time t [s]; the run already shown seeks.

    Raises:
        RunNotFound: no run has this id.
        ValueError: the run is not done, or t is outside it (nothing changes).
    """
    shown = session.replaying
    if shown is not None and shown["run_id"] == run_id:
        session.seek(t, playing)
        return
    run = store.get(run_id)
    if run.status != "done":
        raise TwinError(f"run_id: run {run_id} is {run.status}; a run replays once done")
    session.replay(store.result(run_id), run_id, t, playing)


def submit_sweep(
    store: RunStore, sweeps: SweepRunner, spec: SweepSpec, max_pending: int | None = None
) -> Sweep:
    """Store a sweep (queued) and hand it to the runner, as `POST /api/sweeps` does.

    Args:
        max_pending: most sweeps queued or running, checked atomically with the insert
            (default `deps.MAX_PENDING_SWEEPS`), so no surface can queue more.

    Raises:
        ValueError: a `scenario` a run's body would refuse (a vessel path, say), located at
            `scenario.<field>` in its message.
        QueueFull: `max_pending` sweeps are queued or running (a ValueError too).
    """
    from twin.web.deps import MAX_PENDING_SWEEPS
    try:
        RunRequest(**spec.scenario)  # the same rules as a run's body: no vessel paths
    except ValueError as exc:
        raise SweepScenarioError(exc) from None
    total = math.prod(len(getattr(spec, axis)) for axis in AXES) * spec.seeds
    cap = MAX_PENDING_SWEEPS if max_pending is None else max_pending
    sweep = store.create_sweep(spec.model_dump(), total, max_pending=cap)
    sweeps.submit(sweep.id)
    return sweep


class SweepScenarioError(TwinError):
    """A sweep's `scenario` refused by the rules of a run's body; `cause` has the details."""

    def __init__(self, cause: ValueError) -> None:
        super().__init__(f"scenario: {cause}")
        self.cause = cause

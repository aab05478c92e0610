"""What the routers are given: the app's services as FastAPI dependencies.

`create_app` puts one `Services` on `app.state`; each router asks for what it uses
(`Session`, `Store`, `Jobs`, `Sweeps`, `ExecutorDep`, `AccessDep`, `Admission`), as FastAPI's
"bigger applications" guide does, so a router never reaches into a closure or a global. The
mutating routes also depend on `require_access`: the `Guard` middleware has checked Host,
Origin and token before the body was read, and this dependency refuses a request that did not
pass through it (an app mounted without the middleware stays closed) while declaring the
bearer token in the OpenAPI schema.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field
from typing import Annotated

from fastapi import Depends, HTTPException, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from twin.runs.executor import Executor
from twin.sim.live import LiveSession
from twin.web.access import GRANTED, Access
from twin.web.jobs import JobRunner, SweepRunner
from twin.web.limits import RateLimit
from twin.web.models import Registries
from twin.web.store import RunStore
from twin.web.warmup import Warmup
from twin.web.workability_jobs import WorkabilityRunner

#: [1/s] sustained run (and sweep) submissions per client, and how many at once
RUN_RATE = 5.0
RUN_BURST = 20
#: most runs, and sweeps, queued or running at a time; more are refused until some finish
MAX_PENDING_RUNS = 200
MAX_PENDING_SWEEPS = 4
#: most site-workability jobs queued or running at a time (`twin.web.routers.workability`)
MAX_PENDING_WORKABILITY = 4


class Admission:
    """Per-client submission rate (a token bucket) and caps on what may wait (429s).

    Args:
        rate: [1/s] sustained submissions per client address.
        burst: submissions a client may make at once.
        max_pending_runs: runs queued or running at most.
        max_pending_sweeps: sweeps queued or running at most.
    """

    def __init__(
        self,
        rate: float = RUN_RATE,
        burst: int = RUN_BURST,
        max_pending_runs: int = MAX_PENDING_RUNS,
        max_pending_sweeps: int = MAX_PENDING_SWEEPS,
    ) -> None:
        self.limit = RateLimit(rate, burst)
        self.rate, self.burst = rate, burst
        self.caps = {"runs": max_pending_runs, "sweeps": max_pending_sweeps,
                     "workability": MAX_PENDING_WORKABILITY}  # fmt: skip

    def admit(self, request: Request, what: str, pending: int) -> None:
        """Raise a 429 unless this client may submit now and the queue of `what` has room."""
        client = request.client.host if request.client else "unknown"
        wait = self.limit.acquire(client)
        if wait > 0:
            raise HTTPException(
                429,
                f"too many submissions from {client}: at most {self.burst} at once, then "
                f"{self.rate:g} per second; retry in {wait:.1f} s",
                headers={"Retry-After": str(math.ceil(wait))},
            )
        cap = self.caps[what]
        if pending >= cap:
            raise HTTPException(
                429,
                f"{pending} {what} queued or running (at most {cap}); retry once some finish",
                headers={"Retry-After": "5"},
            )


@dataclass
class Services:
    """Everything the routers use, built once per app.

    Attributes:
        session: the live session; None while the server warms up (`warmup`).
        store: the run store.
        jobs: scripted runs on the executor.
        sweeps: operability sweeps on the executor.
        access: the access policy (also enforced by the `Guard` middleware).
        admission: the submission limits.
        registries: mechanisms, planners and sea states, as answered.
        viewer_port: the 3D viewer's port, if any.
        executor: the executor, once the app has started.
        stopping: set when the server starts to shut down (open requests answer at once).
        warmup: a server's start-up progress (`twin.web.warmup`), None for an app built ready.
    """

    session: LiveSession | None
    store: RunStore
    jobs: JobRunner
    sweeps: SweepRunner
    access: Access
    admission: Admission
    registries: Registries
    viewer_port: int | None = None
    executor: Executor | None = None
    stopping: threading.Event = field(default_factory=threading.Event)
    warmup: Warmup | None = None
    #: site-workability jobs on the executor (`twin.web.workability_jobs`); None: no such routes
    workability: WorkabilityRunner | None = None

    @property
    def warming(self) -> bool:
        """Still starting up: no live session or executor yet."""
        return self.warmup is not None and self.warmup.status != "ok"

    def attach(self, session: LiveSession, executor: Executor) -> None:
        """The start-up is done: serve `session`, and run the queued runs and sweeps (those
        stored while warming among them) on `executor`."""
        self.session, self.executor = session, executor
        self.jobs.start(executor)
        self.sweeps.start(executor)
        if self.workability is not None:
            self.workability.start(executor)


async def get_services(request: Request) -> Services:
    """The app's services. These getters are `async def`: FastAPI runs a plain `def`
    dependency in its thread pool, and a request with five of them waited for five thread
    hops (under load each hop waits for the GIL): issue 30's health p99 and POST p50."""
    return request.app.state.services


ServicesDep = Annotated[Services, Depends(get_services)]


async def get_session(services: ServicesDep) -> LiveSession:
    if services.session is None:
        message = services.warmup.message() if services.warmup else "no live session"
        raise HTTPException(503, message, headers={"Retry-After": "2"})
    return services.session


async def get_store(services: ServicesDep) -> RunStore:
    return services.store


async def get_jobs(services: ServicesDep) -> JobRunner:
    return services.jobs


async def get_sweeps(services: ServicesDep) -> SweepRunner:
    return services.sweeps


async def get_executor(services: ServicesDep) -> Executor | None:
    return services.executor


async def get_access(services: ServicesDep) -> Access:
    return services.access


async def get_admission(services: ServicesDep) -> Admission:
    return services.admission


Session = Annotated[LiveSession, Depends(get_session)]
Store = Annotated[RunStore, Depends(get_store)]
Jobs = Annotated[JobRunner, Depends(get_jobs)]
Sweeps = Annotated[SweepRunner, Depends(get_sweeps)]
ExecutorDep = Annotated[Executor | None, Depends(get_executor)]
AccessDep = Annotated[Access, Depends(get_access)]
AdmissionDep = Annotated[Admission, Depends(get_admission)]

#: declares the token in the OpenAPI schema; the `Guard` middleware checks it before a body is
#: read
BEARER = HTTPBearer(
    auto_error=False,
    description="required on POST and PATCH when the server runs with a token (TWIN_TOKEN)",
)


async def require_access(
    request: Request,
    access: AccessDep,
    _: Annotated[HTTPAuthorizationCredentials | None, Depends(BEARER)],
) -> None:
    """Refuse a mutating request the `Guard` middleware did not let through."""
    if not request.scope.get(GRANTED):
        raise HTTPException(403, "request refused: it did not pass the access check")


#: the dependencies of every route that changes something
GUARDED = [Depends(require_access)]

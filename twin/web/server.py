"""`twin serve`: the live session, the 3D viewer, the REST app and the one executor of runs and
sweeps, in one process that holds its data directory for as long as it runs.

Start-up, in order: the data directory's lock (`twin.web.lock`: a second server on it exits
2, naming the first's pid); the REST port, bound at once (`listen`: one in use exits 2 naming
it, before seconds of start-up; and the executor's workers, which bind ports of their own,
cannot take it meanwhile); the compiled kernels; the executor (a Dask LocalCluster of one
worker per core, kernels warmed on each, then niced to `WORKER_NICE` so batch work yields the
CPU to this process; or `--scheduler tcp://HOST:PORT`), started once; the
run store, the live session, the viewer and the REST app. Stop (Ctrl-C, SIGTERM, `docker
stop`): requests still waiting for a run answer 503 at once, the runs' futures are cancelled
and their runs left queued for the next start, and the process exits within seconds
(`GRACEFUL` for open connections, `executor.CLOSE_TIMEOUT` for the workers). SIGTERM also starts
a deadline the moment it arrives (`twin.web.stop_watchdog`, `STOP_DEADLINE`): whatever is still
in flight then (a thread holding the GIL, a stuck close), a watchdog process ends this one. The
data directory's lock is held until the process is gone (`DataDirLock.hold_until_exit`).
"""

from __future__ import annotations

import dataclasses
import logging
import os
import signal
import socket
import threading
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import Any

import uvicorn
from fastapi import FastAPI

from twin.errors import TwinError
from twin.runs.executor import RUN_BUDGET, Executor
from twin.runs.heap import freeze_startup
from twin.sim.engine import warm_in_processes
from twin.sim.live import LiveSession, live_demo
from twin.sim.measured import LOG_DIR_ENV
from twin.sim.motion_live import LiveMotion
from twin.web.access import Access, is_loopback
from twin.web.api import create_app
from twin.web.connections import (
    KEEP_ALIVE,
    MAX_PER_CLIENT,
    REQUEST_TIMEOUT,
    connection_cap,
    guarded_protocol,
    quiet_malformed_messages,
    throttled_exceptions,
)
from twin.web.deps import Services
from twin.web.jobs import JobRunner, SweepRunner
from twin.web.lock import DataDirLock
from twin.web.stop_watchdog import StopWatchdog
from twin.web.store import Quota, RunStore
from twin.web.warmup import WarmingPage, Warmup

#: the run store's file inside the data directory
DATABASE = "runs.sqlite"

log = logging.getLogger("twin.web.server")
#: [s] how long open requests may take to finish once the server is told to stop
GRACEFUL = 3

__all__ = ["DATABASE", "GRACEFUL", "Terminated", "is_loopback", "serve", "url", "uvicorn_config"]


class Terminated(BaseException):
    """SIGTERM (`docker stop`): raised once the REST server has shut down, so every resource
    is released on the way out (not an `Exception`: nothing may swallow it)."""


def url(host: str, port: int) -> str:
    """The address to open for a server bound to `host` (a wildcard bind is local too)."""
    if host in ("0.0.0.0", "::", ""):
        host = "127.0.0.1"
    return f"http://[{host}]:{port}/" if ":" in host else f"http://{host}:{port}/"


class _Uvicorn(uvicorn.Server):
    """uvicorn that tells the app (`services.stopping`) the moment it is asked to stop, so a
    request waiting for its run answers at once instead of holding the shutdown."""

    def __init__(
        self, config: uvicorn.Config, stopping: threading.Event, watchdog: StopWatchdog | None
    ) -> None:
        super().__init__(config)
        self._stopping = stopping
        self._watchdog = watchdog

    def handle_exit(self, sig: int, frame: FrameType | None) -> None:
        self._stopping.set()
        super().handle_exit(sig, frame)

    async def startup(self, sockets: list[socket.socket] | None = None) -> None:
        import asyncio

        if self._watchdog is not None:  # uvicorn has just installed its SIGTERM handler
            self._watchdog.arm()
        throttled_exceptions(asyncio.get_running_loop())  # accept errors: once per interval
        await super().startup(sockets)


def uvicorn_config(
    app: Any,
    host: str,
    port: int,
    *,
    forwarded_allow_ips: tuple[str, ...] = (),
    request_timeout: float = REQUEST_TIMEOUT,
    max_connections: int | None = None,
    max_per_client: int = MAX_PER_CLIENT,
    **options: Any,
) -> uvicorn.Config:
    """How `twin serve` runs uvicorn (issue 30): the client address is the socket's unless
    `forwarded_allow_ips` names trusted proxies (uvicorn's own default trusts X-Forwarded-For
    from loopback, so any local client could pick its address); requests must arrive within
    `request_timeout` s; idle keep-alives close after `KEEP_ALIVE` s; at most
    `max_connections` (default `connection_cap()`: below the fd limit) are open at once,
    `max_per_client` from one address, and as many requests run (503 beyond).
    """
    cap = connection_cap() if max_connections is None else max_connections
    return uvicorn.Config(
        app,
        host=host,
        port=port,
        access_log=False,
        timeout_graceful_shutdown=GRACEFUL,
        proxy_headers=bool(forwarded_allow_ips),
        forwarded_allow_ips=list(forwarded_allow_ips) or None,
        http=guarded_protocol(request_timeout, cap, max_per_client),
        timeout_keep_alive=KEEP_ALIVE,
        # uvicorn's 503 past as many connections or tasks: one above the cap, so it only
        # ever counts tasks (the protocol keeps connections within the cap itself)
        limit_concurrency=cap + 1,
        **options,
    )


def listen(host: str, port: int) -> socket.socket:
    """A TCP socket bound to host:port for uvicorn to serve on (as uvicorn binds its own:
    SO_REUSEADDR, inheritable), bound before the rest of the server starts.

    Raises:
        TwinError: the port is in use or the address cannot be bound, naming it.
    """
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    # IPPROTO_TCP, not 0: asyncio sets TCP_NODELAY on an accepted socket only when its `proto`
    # says TCP (`asyncio.base_events._set_nodelay`), and an accepted socket inherits the
    # listener's. With protocol 0 every keep-alive answer waited on Nagle and the client's
    # delayed ACK: ~45 ms per request (issue 30, benchmarks/server.py `nodelay_rows`).
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise TwinError(
            f"cannot listen on {host}:{port} ({exc.strerror}); choose another port with --port"
        ) from exc
    sock.set_inheritable(True)
    return sock


class _StartUp(threading.Thread):
    """What a server starts while it already answers REST (`twin.web.warmup`): the kernels,
    compiled on every core, then the executor, the live session and the viewer; then it
    attaches them to the app. `stop` closes what it built, also halfway through."""

    def __init__(
        self,
        services: Services,
        warmup: Warmup,
        page: WarmingPage | None,
        *,
        executor: Callable[[], Executor],
        viewer: Callable[[LiveSession], Any] | None,
        motion: LiveMotion | None = None,
    ) -> None:
        super().__init__(name="twin-start-up", daemon=True)
        self.services, self.warmup, self.page = services, warmup, page
        self.motion = motion  # the live motion input the session may follow (--motion-udp)
        self._start_executor, self._start_viewer = executor, viewer
        self._lock = threading.Lock()
        self._built: list[Any] = []  # closed in reverse order by `stop`
        self._stopped = False

    def _keep(self, thing: Any) -> Any:
        """Hand `thing` to `stop`; if it has already run, close it now and end the thread."""
        with self._lock:
            if not self._stopped:
                self._built.append(thing)
                return thing
        _close(thing)
        raise _Cancelled

    def run(self) -> None:
        warmup = self.warmup
        try:
            warmup.begin(f"compiling kernels on {os.cpu_count() or 1} cores")
            warm_in_processes(progress=warmup.kernel_done)
            warmup.begin("starting the executor")
            executor = self._keep(self._start_executor())
            warmup.say(f"executor {executor.where}, {executor.workers} workers")
            if executor.dashboard_link:
                warmup.say(f"Dask dashboard {executor.dashboard_link}")
            warmup.begin("starting the live session")
            session = self._keep(LiveSession(live_demo(), motion=self.motion))
            session.start()
            if self._start_viewer is not None and self.page is not None:
                self.page.close()
                handle = self._keep(self._start_viewer(session))
                if handle.port != self.page.port:  # taken in between: say where it went
                    warmup.say(f"3D twin moved to port {handle.port}")
            with self._lock:
                if self._stopped:
                    raise _Cancelled
                self.services.attach(session, executor)
            freeze_startup()  # no full collection walks the start-up objects while serving
            warmup.ready()
        except _Cancelled:
            return
        except Exception as exc:  # the server answers on, saying why (health: failed)
            log.exception("start-up failed")
            warmup.fail(f"{type(exc).__name__}: {exc}")

    def stop(self) -> None:
        """Close what was started, newest first; a start-up still compiling stops after its
        current step (its worker processes end with this one)."""
        with self._lock:
            self._stopped = True
            built, self._built = self._built[::-1], []
        if self.page is not None:
            self.page.close()
        for thing in built:
            _close(thing)


class _Cancelled(Exception):
    """The server stopped while it was starting up."""


def _close(thing: Any) -> None:
    """Stop a viewer handle or live session, close an executor."""
    (thing.close if isinstance(thing, Executor) else thing.stop)()


#: the warning `quiet_resource_tracker` silences, as a PYTHONWARNINGS entry
TRACKER_WARNING = "ignore::UserWarning:multiprocessing.resource_tracker"


def quiet_resource_tracker() -> None:
    """Keep multiprocessing's resource tracker from warning of "leaked semaphore objects" when
    the server stops: a worker stopped mid-run (SIGTERM while busy) leaves numba's process lock
    registered, and the tracker, a process of its own started later with this environment,
    removes it either way; the warning says nothing a user can act on."""
    current = os.environ.get("PYTHONWARNINGS", "")
    if TRACKER_WARNING not in current.split(","):
        os.environ["PYTHONWARNINGS"] = ",".join(filter(None, (current, TRACKER_WARNING)))


def _terminate(sig: int, frame: FrameType | None) -> None:
    raise Terminated(f"signal {sig}")


def serve(
    host: str = "127.0.0.1",
    port: int = 8000,
    viser_port: int = 8080,
    data_dir: str | Path = "data",
    *,
    token: str | None = None,
    viewer: bool = True,
    scheduler: str | None = None,
    workers: int | None = None,
    allow_hosts: tuple[str, ...] = (),
    allow_origins: tuple[str, ...] = (),
    run_budget: float = RUN_BUDGET,
    graphics: str = "full",
    forwarded_allow_ips: tuple[str, ...] = (),
    private: bool = False,
    dashboard: bool = False,
    max_store: int | None = None,
    max_runs: int | None = None,
    retain: bool = False,
    worker_nice: int = 0,
    motion: LiveMotion | None = None,
) -> None:
    """Run the twin until interrupted (Ctrl-C: KeyboardInterrupt; SIGTERM: `Terminated`, each
    raised once all is stopped).

    Starts the executor, the live session's real-time loop, the 3D viewer on `viser_port` and
    the REST app with the landing page on `port`, storing runs in `data_dir/runs.sqlite`.

    Args:
        host: interface to bind both servers to; 127.0.0.1 keeps them local, 0.0.0.0 (as in
            the Docker image) exposes them.
        port: REST API and landing page; viser_port: 3D viewer.
        data_dir: folder of the run store (created if missing); one server at a time.
        token: if set (≥ 16 characters), POST and PATCH need `Authorization: Bearer <token>`,
            and the 3D viewer's controls stay read-only until a browser enters it. Required
            when `host` is not a loopback address.
        viewer: False serves REST only (no viser).
        scheduler: None starts a Dask LocalCluster (one worker per core, or `workers`);
            "tcp://HOST:PORT" uses an existing scheduler; "in-process" one worker thread.
        workers: workers of the LocalCluster.
        allow_hosts: more Host names the server answers to, on the REST and the viewer port
            (e.g. the machine's DNS name).
        allow_origins: more browser origins trusted as the server's own
            (scheme://host:port, e.g. a TLS proxy's).
        run_budget: [s] wall-clock budget of one run.
        graphics: what the viewer's browsers render (`twin.web.viewer.GRAPHICS`): "light"
            without environment map and shadows, for browsers without a GPU.
        forwarded_allow_ips: proxies (addresses, or "*") whose X-Forwarded-For names the
            client; default none: the client is the socket's peer.
        private: with a token, reading stored runs and sweeps needs it too (default: open).
        dashboard: serve the Dask dashboard (on 127.0.0.1, a free port, printed); default off.
        max_store: [bytes] the store's quota (`twin.web.store.Quota`); None: none.
        max_runs: runs the store may hold; None: no limit.
        retain: when full, delete the oldest finished unpinned results instead of refusing.
        worker_nice: niceness 0-19 of the LocalCluster's workers once warm (`WORKER_NICE`).
        motion: the live motion input (`--motion-udp`) the live session may follow.

    Raises:
        TwinError: `host` is not loopback and there is no token, a short token, a bad
            allowed host or origin, unknown `graphics`, the data directory is held by another
            server (`DataDirBusy`, naming its pid), or the REST port cannot be bound
            (`listen`); nothing is started.
    """
    quiet_resource_tracker()
    access = _checked_access(
        host, (port, viser_port), token, viewer=viewer, graphics=graphics,
        allow_hosts=allow_hosts, allow_origins=allow_origins, private=private,
    )  # fmt: skip
    with _Held(data_dir, host, port) as held:
        # the store first: a bad file is one line before seconds of start-up (issue 30)
        held.store = RunStore(Path(data_dir) / DATABASE, Quota(max_store, max_runs, retain))
        app, held.startup = _assemble(
            held.store, access, host, port, viser_port, viewer=viewer, scheduler=scheduler,
            workers=workers, dashboard=dashboard, run_budget=run_budget, graphics=graphics,
            worker_nice=worker_nice, motion=motion,
        )  # fmt: skip
        held.startup.start()
        config = uvicorn_config(app, host, port, forwarded_allow_ips=forwarded_allow_ips)
        _Uvicorn(config, app.state.services.stopping, held.watchdog).run(sockets=[held.rest])


def _checked_access(
    host: str,
    ports: tuple[int, int],
    token: str | None,
    *,
    viewer: bool,
    graphics: str,
    allow_hosts: tuple[str, ...],
    allow_origins: tuple[str, ...],
    private: bool,
) -> Access:
    """`serve`'s option checks, before anything starts: a known `graphics` (with the viewer),
    a token unless `host` is loopback, then the access policy of `host` on `ports` (which
    checks the allowed hosts and origins).

    Raises:
        TwinError: saying which option is wrong and what is allowed.
    """
    if viewer:
        # Imported here: the scene pulls in viser and the meshes, which REST-only needs not.
        from twin.web.viewer import check_graphics

        check_graphics(graphics)
    if not is_loopback(host) and not token:
        raise TwinError(
            f"refusing to bind {host} without a token: anyone who can reach it could drive the "
            "live session and submit runs. Set TWIN_TOKEN (e.g. TWIN_TOKEN=$(openssl rand -hex "
            "16)) or bind 127.0.0.1"
        )
    return Access.for_server(
        host, ports, token=token, allow_hosts=allow_hosts,
        allow_origins=allow_origins, private=private,
    )  # fmt: skip


class _Held:
    """What `serve` holds from before start-up until after shutdown: the data directory's lock,
    the REST port's socket and, on the main thread, SIGTERM (raising `Terminated`, its
    deadline armed at delivery by a `StopWatchdog`); then the run store and the start-up, once
    `serve` has made them. Leaving the `with` block closes them in this order: the socket, the
    start-up (viewer, session, executor: newest first), the store, and SIGTERM goes back to
    its previous handler; the lock stays held until the process ends."""

    def __init__(self, data_dir: str | Path, host: str, port: int) -> None:
        self.data_dir, self.host, self.port = data_dir, host, port
        self.store: RunStore | None = None
        self.startup: _StartUp | None = None

    def __enter__(self) -> _Held:
        """Lock the data directory, bind the port, handle SIGTERM.

        Raises:
            TwinError: the data directory is held by another server (`DataDirBusy`) or the
                port cannot be bound (`listen`); nothing is left held.
        """
        # before anything starts: a second server stops here
        self.lock = DataDirLock(self.data_dir).acquire()
        # stored motion logs live in the data dir; set before the cluster's workers start, so
        # every process resolves a scenario's log ID to the same file (`twin.sim.measured`)
        os.environ[LOG_DIR_ENV] = str(Path(self.data_dir) / "motion_logs")
        try:
            self.rest = listen(self.host, self.port)
        except TwinError:
            self.lock.release()
            raise
        self.previous = signal.getsignal(signal.SIGTERM)
        main = threading.current_thread() is threading.main_thread()
        self.watchdog = StopWatchdog() if main else None
        if self.watchdog is not None:  # PID 1 in a container ignores SIGTERM unless handled
            signal.signal(signal.SIGTERM, _terminate)
            self.watchdog.arm()
        return self

    def __exit__(self, *exc_info: object) -> None:
        """Close all that is held (an exception on the way in goes on)."""
        self.rest.close()
        if self.startup is not None:
            self.startup.stop()
        if self.store is not None:
            self.store.close()
        self.lock.hold_until_exit()  # the kernel lets it go with the process
        if self.watchdog is not None:
            self.watchdog.close()
            signal.signal(signal.SIGTERM, self.previous)


def _assemble(
    store: RunStore,
    access: Access,
    host: str,
    port: int,
    viser_port: int,
    *,
    viewer: bool,
    scheduler: str | None,
    workers: int | None,
    dashboard: bool,
    run_budget: float,
    graphics: str,
    worker_nice: int = 0,
    motion: LiveMotion | None = None,
) -> tuple[FastAPI, _StartUp]:
    """`serve`'s start-up once the store is open: the warming page (with the viewer, on its
    port, which the viewer takes when the page closes), the REST app (answering at once), the
    addresses printed, and the start-up thread, not yet started, that builds the executor,
    the live session and the viewer (`_StartUp`)."""
    if viewer:
        from twin.web.viewer import start_viewer
    warmup = Warmup()
    page = WarmingPage(warmup, host, viser_port) if viewer else None
    if page is not None:
        viser_port = page.port  # the viewer takes it when the page closes
        access = dataclasses.replace(access, ports=frozenset({port, viser_port}))
    sweeps = SweepRunner(store)  # the REST app's, and the viewer's Operability folder's
    app = create_app(
        None,
        store,
        access=access,
        jobs=JobRunner(store, budget=run_budget),
        sweeps=sweeps,
        viewer_port=viser_port if viewer else None,
        warmup=warmup,
    )
    print(f"twin: landing page and REST API {url(host, port)}  (docs: {url(host, port)}docs)")
    if viewer:
        print(f"twin: 3D twin {url(host, viser_port)}")
    print(f"twin: runs stored in {store.path}", flush=True)
    startup = _StartUp(
        app.state.services, warmup, page,
        executor=lambda: Executor.start(scheduler, n_workers=workers, dashboard=dashboard,
                                        nice=worker_nice),
        viewer=None if page is None else lambda session: start_viewer(
            session, host, viser_port, access=dataclasses.replace(
                access, ports=frozenset({port})),  # and its own actual port's
            store=store, sweeps=sweeps, api_url=url(host, port), graphics=graphics,
            quiet_logs=quiet_malformed_messages,
        ),
        motion=motion,
    )  # fmt: skip
    return app, startup

"""`twin serve`: the live session, the 3D viewer, the REST app and the one executor of runs and
sweeps, in one process that holds its data directory for as long as it runs.

Start-up, in order: the data directory's lock (`twin.web.lock`: a second server on it exits
2, naming the first's pid); the REST port, bound at once (`listen`: one in use exits 2 naming
it, before seconds of start-up; and the executor's workers, which bind ports of their own,
cannot take it meanwhile); the compiled kernels; the executor (a Dask LocalCluster of one
worker per core, kernels warmed on each, or `--scheduler tcp://HOST:PORT`), started once; the
run store, the live session, the viewer and the REST app. Stop (Ctrl-C, SIGTERM, `docker
stop`): requests still waiting for a run answer 503 at once, the runs' futures are cancelled
and their runs left queued for the next start, and the process exits within seconds
(`GRACEFUL` for open connections, `executor.CLOSE_TIMEOUT` for the workers).
"""

from __future__ import annotations

import dataclasses
import signal
import socket
import threading
from pathlib import Path
from types import FrameType
from typing import Any

import uvicorn

from twin.errors import TwinError
from twin.sim.engine import warm
from twin.sim.executor import RUN_BUDGET, Executor
from twin.sim.heap import freeze_startup
from twin.sim.live import LiveSession
from twin.web.access import Access, is_loopback
from twin.web.api import create_app
from twin.web.jobs import JobRunner, SweepRunner
from twin.web.lock import DataDirLock
from twin.web.store import RunStore

#: the run store's file inside the data directory
DATABASE = "runs.sqlite"
#: [s] how long open requests may take to finish once the server is told to stop
GRACEFUL = 3

__all__ = ["DATABASE", "GRACEFUL", "Terminated", "is_loopback", "serve", "url"]


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

    def __init__(self, config: uvicorn.Config, stopping: threading.Event) -> None:
        super().__init__(config)
        self._stopping = stopping

    def handle_exit(self, sig: int, frame: FrameType | None) -> None:
        self._stopping.set()
        super().handle_exit(sig, frame)


def listen(host: str, port: int) -> socket.socket:
    """A TCP socket bound to host:port for uvicorn to serve on (as uvicorn binds its own:
    SO_REUSEADDR, inheritable), bound before the rest of the server starts.

    Raises:
        TwinError: the port is in use or the address cannot be bound, naming it.
    """
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise TwinError(
            f"cannot listen on {host}:{port} ({exc.strerror}); choose another port with --port"
        ) from exc
    sock.set_inheritable(True)
    return sock


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
) -> None:
    """Run the twin until interrupted (Ctrl-C: KeyboardInterrupt; SIGTERM: `Terminated`, each
    raised once all is stopped).

    Starts the executor, the live session's real-time loop, the 3D viewer on `viser_port` and
    the REST app with the landing page on `port`, storing runs in `data_dir/runs.sqlite`.

    Args:
        host: interface to bind both servers to; 127.0.0.1 keeps them local, 0.0.0.0 (as in
            the Docker image) exposes them.
        port: REST API and landing page.
        viser_port: 3D viewer.
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
        graphics: what the viewer's browsers render (`twin.web.scene.GRAPHICS`): "light"
            without environment map and shadows, for browsers without a GPU.

    Raises:
        TwinError: `host` is not loopback and there is no token, a short token, a bad
            allowed host or origin, unknown `graphics`, the data directory is held by another
            server (`DataDirBusy`, naming its pid), or the REST port cannot be bound
            (`listen`); nothing is started.
    """
    if viewer:
        # Imported here: the scene pulls in viser and the meshes, which REST-only needs not.
        from twin.web.scene import check_graphics, start_viewer

        check_graphics(graphics)
    if not is_loopback(host) and not token:
        raise TwinError(
            f"refusing to bind {host} without a token: anyone who can reach it could drive the "
            "live session and submit runs. Set TWIN_TOKEN (e.g. TWIN_TOKEN=$(openssl rand -hex "
            "16)) or bind 127.0.0.1"
        )
    access = Access.for_server(
        host, (port, viser_port), token=token, allow_hosts=allow_hosts,
        allow_origins=allow_origins,
    )  # fmt: skip
    lock = DataDirLock(data_dir).acquire()  # before anything starts: a second server stops here
    try:
        rest = listen(host, port)
    except TwinError:
        lock.release()
        raise
    previous = signal.getsignal(signal.SIGTERM)
    main = threading.current_thread() is threading.main_thread()
    if main:  # PID 1 in a container ignores SIGTERM unless something handles it
        signal.signal(signal.SIGTERM, _terminate)
    executor: Executor | None = None
    store: RunStore | None = None
    session: LiveSession | None = None
    handle: Any = None
    try:
        print(f"twin: compiled kernels ready in {warm():.1f} s", flush=True)
        executor = Executor.start(scheduler, n_workers=workers)
        print(f"twin: executor {executor.where}, {executor.workers} workers", flush=True)
        store = RunStore(Path(data_dir) / DATABASE)
        session = LiveSession()
        session.start()
        sweeps = SweepRunner(store)  # the REST app's, and the viewer's Operability folder's
        if viewer:
            handle = start_viewer(
                session, host, viser_port, access=access, store=store, sweeps=sweeps,
                api_url=url(host, port), graphics=graphics,
            )  # fmt: skip
            viser_port = handle.port  # viser moves to the next free port if this one is taken
            access = dataclasses.replace(access, ports=frozenset({port, viser_port}))
        app = create_app(
            session,
            store,
            access=access,
            executor=executor,
            jobs=JobRunner(store, budget=run_budget),
            sweeps=sweeps,
            viewer_port=viser_port if viewer else None,
        )
        print(f"twin: landing page and REST API {url(host, port)}  (docs: {url(host, port)}docs)")
        if viewer:
            print(f"twin: 3D twin {url(host, viser_port)}")
        print(f"twin: runs stored in {store.path}", flush=True)
        freeze_startup()  # no full collection walks the start-up objects while serving
        config = uvicorn.Config(
            app, host=host, port=port, access_log=False, timeout_graceful_shutdown=GRACEFUL
        )
        _Uvicorn(config, app.state.services.stopping).run(sockets=[rest])
    finally:
        rest.close()
        if handle is not None:
            handle.stop()
        if session is not None:
            session.stop()
        if executor is not None:
            executor.close()
        if store is not None:
            store.close()
        lock.release()
        if main:
            signal.signal(signal.SIGTERM, previous)

"""`twin serve`: the live session, the 3D viewer and the REST app in one process."""

from __future__ import annotations

import ipaddress
from pathlib import Path

import uvicorn

from twin.errors import TwinError
from twin.sim.engine import warm
from twin.sim.live import LiveSession
from twin.web.api import create_app
from twin.web.store import RunStore

#: the run store's file inside the data directory
DATABASE = "runs.sqlite"


def is_loopback(host: str) -> bool:
    """Whether binding `host` keeps the server reachable from this machine only."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def url(host: str, port: int) -> str:
    """The address to open for a server bound to `host` (a wildcard bind is local too)."""
    if host in ("0.0.0.0", "::", ""):
        host = "127.0.0.1"
    return f"http://[{host}]:{port}/" if ":" in host else f"http://{host}:{port}/"


def serve(
    host: str = "127.0.0.1",
    port: int = 8000,
    viser_port: int = 8080,
    data_dir: str | Path = "data",
    *,
    token: str | None = None,
    viewer: bool = True,
) -> None:
    """Run the twin until interrupted (Ctrl-C: KeyboardInterrupt once all is stopped; SIGTERM).

    Starts the live session's real-time loop, the 3D viewer on `viser_port` and the REST
    app with the landing page on `port`, storing runs in `data_dir/runs.sqlite`.

    Args:
        host: interface to bind both servers to; 127.0.0.1 keeps them local, 0.0.0.0 (as in
            the Docker image) exposes them.
        port: REST API and landing page.
        viser_port: 3D viewer.
        data_dir: folder of the run store (created if missing).
        token: if set, POST and PATCH need `Authorization: Bearer <token>`, and the 3D
            viewer's controls stay locked until a browser enters it. Required when `host` is
            not a loopback address.
        viewer: False serves REST only (no viser).

    Raises:
        TwinError: `host` is not loopback and there is no token (nothing is started).
    """
    if not is_loopback(host) and not token:
        raise TwinError(
            f"refusing to bind {host} without a token: anyone who can reach it could drive the "
            "live session and submit runs. Set TWIN_TOKEN (e.g. TWIN_TOKEN=$(openssl rand -hex "
            "16)) or bind 127.0.0.1"
        )
    print(f"twin: compiled kernels ready in {warm():.1f} s", flush=True)
    store = RunStore(Path(data_dir) / DATABASE)
    session = LiveSession()
    session.start()
    handle = None
    try:
        if viewer:
            # Imported here: the scene pulls in viser and the meshes, which REST-only needs not.
            from twin.web.scene import start_viewer

            handle = start_viewer(session, host, viser_port, token=token)
            viser_port = handle.port  # viser moves to the next free port if this one is taken
        app = create_app(session, store, token=token, viewer_port=viser_port if viewer else None)
        print(f"twin: landing page and REST API {url(host, port)}  (docs: {url(host, port)}docs)")
        if viewer:
            print(f"twin: 3D twin {url(host, viser_port)}")
        print(f"twin: runs stored in {store.path}", flush=True)
        uvicorn.Server(uvicorn.Config(app, host=host, port=port, access_log=False)).run()
    finally:
        if handle is not None:
            handle.stop()
        session.stop()
        store.close()

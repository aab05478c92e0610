"""The one executor of runs, sweeps and scripts: a Dask client, started once, kept for good.

Every simulation that is not the live session runs here, as a Dask future: a REST run (one
`run_scenario` task), an operability sweep (`run_sweep`'s chunk tasks), `twin sweep`, and
scripts that map a function over many jobs (`map_unordered`, e.g. scripts/reproduce.py).

    with Executor.start() as executor:                  # a LocalCluster: one worker per core
        future = executor.run({"sea_state": 5}, name="run-1")
        output = future.result()                        # RunOutput: metrics, packed series
    with Executor.start("tcp://10.0.0.5:8786") as executor: ...   # an existing cluster
    with Executor.start("in-process") as executor: ...  # one worker thread in this process

A LocalCluster has one single-threaded worker process per core (a run never competes with the
web server for the GIL); every worker loads the compiled kernels (`twin.sim.engine.warm`) when
it starts, through a worker plugin, so its first run is as fast as the next. Workers report a
run's progress as Dask events (`Worker.log_event`) on the executor's topic; the client that
submitted the run subscribes to them (`Executor.subscribe`). A run's series come back packed
(`pack_series`: zstd Parquet, no pickles), ready to store.

Each run has a wall-clock budget as well as the scenario's step cap: `run_scenario` checks the
clock between chunks of `PROGRESS_STEPS` steps (milliseconds each on the compiled engine) and
raises `BudgetExceeded` past it.
"""

from __future__ import annotations

import io
import json
import logging
import multiprocessing
import os
import time
import uuid
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from twin.errors import TwinError

#: the scheduler name of an executor in this process (one worker thread, no Dask processes)
IN_PROCESS = "in-process"
#: [s] default wall-clock budget of one run (the longest a scenario may be, 200 000 steps with
#: 2048 wave components, takes 1-2 s on a free core)
RUN_BUDGET = 60.0
#: [s] wall time between two progress reports of a running run
PROGRESS_PERIOD = 0.5
#: steps between two looks at the clock (a few milliseconds on the compiled engine)
PROGRESS_STEPS = 1000
#: Dask priorities: a REST run goes before the queued chunks of a sweep
RUN_PRIORITY = 10
SWEEP_PRIORITY = 0
#: niceness `twin serve --worker-nice` suggests for its LocalCluster's worker processes
#: (`Executor.start(nice=)`, `os.nice`, 0 … 19; the default is 0, as the server, because a
#: niced worker also yields to every other process of a shared machine: with two busy loops
#: beside it a run took several times longer, and the crash test's runs outlived three restarts
#: and failed). On a machine of its own: batch work (runs, sweep chunks, heatmaps) yields the
#: CPU to the process that answers requests, so a busy cluster on a busy machine cannot starve
#: /api/health (issue 30's soak: health p99 1.3 s at load 12, the server's event loop idle
#: 86 % of the time: waiting for a core, not working). Workers still take every idle cycle;
#: only contention is decided for the front end. Scripts and `twin sweep` keep their workers
#: at their own priority (nothing to yield to), and another cluster's workers (`--scheduler`)
#: are left as their owner runs them.
WORKER_NICE = 10
#: [s] how long `Executor.start` waits for a scheduler and its first worker
CONNECT_TIMEOUT = 30.0
#: [s] how long `Executor.close` gives the cluster to stop before its processes are killed
CLOSE_TIMEOUT = 3.0
#: Dask settings of the clusters `Executor.start` starts, for a server that rests when idle
#: (issue 29 item 8): Dask's defaults wake the event loop of the scheduler and of an in-process
#: worker every 10-100 ms (the profiler every 10 ms, the loop-blocked tick every 20 ms, the
#: memory monitor every 100 ms, the system monitor every 500 ms), ~4.8 % of a core at rest.
#: Longer periods cost nothing here: the tick still flags a loop blocked over its 3 s limit,
#: the memory monitor still pauses or restarts a worker within half a second, and the profiler
#: only feeds the Dask dashboard (kept on when the dashboard is asked for).
QUIET_DASK = {
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "500ms",
    "distributed.worker.profile.enabled": False,
}

T = TypeVar("T")
R = TypeVar("R")

log = logging.getLogger(__name__)


class BudgetExceeded(RuntimeError):
    """A run went over its wall-clock budget (a failure of the run, not bad input)."""


# -- what a worker runs -------------------------------------------------------------------------


#: the first bytes of a packed series: Parquet (since issue 30) or, in older stores, an npz
PARQUET_MAGIC = b"PAR1"
#: Parquet's compression of the packed series (zstd at its default level, lossless)
PACK_CODEC = "zstd"
#: samples per Parquet row group of packed series: an export reads one group at a time
PACK_ROWS = 16_384


def _flat_name(key: str, j: int | None) -> str:
    return key if j is None else f"{key}/{j}"


def pack_series(series: dict[str, np.ndarray]) -> bytes:
    """Series as a Parquet table, one column per scalar (`xi` (N, 9) as `xi/0` … `xi/8`),
    zstd with byte-stream-split floats: lossless (float64 bit for bit), no pickles, and each
    column readable alone (`unpack_series(blob, names)`). Measured (issue 30, a 600 s hybrid
    run): 368 bytes per step as an npz, 266 as this (27 % smaller) for 58 ms of writing
    instead of 36; an npz's own compression saved 14 % at 780 ms."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    columns: dict[str, np.ndarray] = {}
    layout = []
    for key, values in series.items():
        values = np.asarray(values)
        tail = list(values.shape[1:])
        layout.append([key, tail, values.dtype.str])
        if not tail:
            columns[_flat_name(key, None)] = values
            continue
        flat = values.reshape(len(values), -1)
        for j in range(flat.shape[1]):
            columns[_flat_name(key, j)] = np.ascontiguousarray(flat[:, j])
    table = pa.table(columns).replace_schema_metadata({"twin.series": json.dumps(layout)})
    floats = [name for name, v in columns.items() if v.dtype.kind == "f"]
    out = pa.BufferOutputStream()
    pq.write_table(
        table, out, compression=PACK_CODEC, use_dictionary=False,
        use_byte_stream_split=floats or False, row_group_size=PACK_ROWS,
    )  # fmt: skip
    return out.getvalue().to_pybytes()


def unpack_series(blob: bytes, names: Iterable[str] | None = None) -> dict[str, np.ndarray]:
    """Inverse of `pack_series` (and of the npz of older stores), keys in their original
    order; with `names`, only those series are read (others' columns are not decoded).

    Raises:
        KeyError: a name that is not one of the series.
    """
    wanted = None if names is None else list(names)
    if bytes(blob[:4]) != PARQUET_MAGIC:
        with np.load(io.BytesIO(blob), allow_pickle=False) as npz:
            keys = npz.files if wanted is None else wanted
            return {k: npz[k] for k in keys}
    import pyarrow.parquet as pq

    source = io.BytesIO(blob)
    layout = json.loads(pq.read_schema(source).metadata[b"twin.series"])
    if wanted is not None:
        unknown = sorted(set(wanted) - {key for key, _, _ in layout})
        if unknown:
            raise KeyError(f"no series {unknown}")
        layout = [entry for entry in layout if entry[0] in wanted]
    flat = [
        _flat_name(key, j if tail else None)
        for key, tail, _ in layout
        for j in range(int(np.prod(tail)) if tail else 1)
    ]
    table = pq.read_table(source, columns=flat)
    out = {}
    for key, tail, dtype in layout:
        if not tail:
            out[key] = table.column(key).to_numpy().astype(dtype, copy=False)
            continue
        parts = [table.column(_flat_name(key, j)).to_numpy() for j in range(int(np.prod(tail)))]
        out[key] = np.stack(parts, axis=1).astype(dtype, copy=False).reshape(-1, *tail)
    return out


@dataclass(frozen=True)
class RunOutput:
    """What a finished run sends back to the client that submitted it.

    Attributes:
        metrics: the run's metrics (JSON-ready).
        series: its series, packed (`pack_series`).
        steps: steps taken.
        seconds: [s] wall time on the worker.
    """

    metrics: dict[str, Any]
    series: bytes
    steps: int
    seconds: float


def report(topic: str | None, message: dict[str, Any]) -> None:
    """Log `message` on the Dask event `topic` from the worker running this task (nothing
    outside a worker, or without a topic)."""
    if topic is None:
        return
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):  # not inside a Dask task
        return
    worker.log_event(topic, {**message, "worker": worker.address})


def run_scenario(
    fields: dict[str, Any],
    *,
    name: str,
    topic: str | None = None,
    budget: float | None = RUN_BUDGET,
) -> RunOutput:
    """One run, as `simulate` steps it, with progress reports and a wall-clock budget.

    Args:
        fields: the scenario's fields (validated here).
        name: the run's name in its progress reports (a run id).
        topic: the Dask event topic of the reports (`Executor.topic`); None: no reports.
        budget: [s] wall time allowed from the start of the run; None: no limit.

    Raises:
        ValueError: a scenario that cannot run (naming the field), zero steps included;
            raised before any step.
        BudgetExceeded: over `budget`, saying how far the run got.
    """
    from twin.sim.engine import Simulation
    from twin.sim.scenario import Scenario

    start = time.monotonic()
    scenario = Scenario(**fields)
    steps = round(scenario.duration / scenario.dt)
    if steps < 1:
        raise TwinError(
            f"duration: {scenario.duration:g} s at dt = {scenario.dt:g} s is zero steps; "
            "allowed: duration ≥ dt"
        )
    simulation = Simulation(scenario)
    report(topic, {"name": name, "status": "running", "progress": 0.0})
    last = time.monotonic()
    while not simulation.done:
        simulation.advance(PROGRESS_STEPS)
        now = time.monotonic()
        if budget is not None and now - start > budget and not simulation.done:
            raise BudgetExceeded(
                f"over the wall-clock budget of {budget:g} s: stopped after {simulation.k} of "
                f"{simulation.n_steps} steps ({now - start:.2f} s); shorten the duration, "
                "raise dt or lower n_components"
            )
        if now - last > PROGRESS_PERIOD:
            report(topic, {"name": name, "status": "running", "progress": simulation.k / steps})
            last = now
    result = simulation.result()
    return RunOutput(
        result.metrics, pack_series(result.series), simulation.k, time.monotonic() - start
    )


def lower_priority(nice: int) -> int:
    """Make this process at least `nice` nice (never less nice than it is: a second call, or a
    process started nicer, stays as it is). Returns its niceness after."""
    current = os.nice(0)
    if nice > current:
        current = os.nice(nice - current)
    return current


def _warm_plugin(freeze: bool, nice: int = 0) -> Any:
    """A Dask worker plugin that loads the compiled kernels when a worker starts and, with
    `freeze`, ignores SIGINT, lowers the worker's priority to `nice` (`lower_priority`) and
    then freezes its start-up objects (`twin.runs.heap.freeze_startup`): for the worker
    processes of our own LocalCluster, not for a worker in the caller's process nor for another
    cluster's workers."""
    from distributed.diagnostics.plugin import WorkerPlugin

    class WarmKernels(WorkerPlugin):
        name = "twin-warm-kernels"
        idempotent = True

        def setup(self, worker: Any) -> None:
            from twin.runs.heap import freeze_startup
            from twin.sim.engine import warm

            if freeze:
                # our own worker processes: a terminal's Ctrl-C reaches the whole process
                # group, and the server closes its cluster itself, so a worker would only
                # print a KeyboardInterrupt traceback (4 of them on 2 workers)
                import signal
                import threading

                if threading.current_thread() is threading.main_thread():
                    signal.signal(signal.SIGINT, signal.SIG_IGN)
            warm()
            if freeze and nice:  # our own process, its kernels loaded (the start-up is not
                lower_priority(nice)  # batch work): from now on it yields to the front end
            if freeze:  # no full collection walks the kernels between two runs
                freeze_startup()

    return WarmKernels()


# -- the client side ----------------------------------------------------------------------------


class Executor:
    """A Dask client with its cluster, if it started one: where runs and sweeps execute.

    Build it with `Executor.start`; close it once (`close`, or a `with` block).

    Attributes:
        client: the Dask client.
        where: "local cluster", "in-process" or the scheduler address.
        numba_threads: numba threads a task may use (1 on a cluster of one worker per core;
            None in process: all of them).
        topic: the Dask event topic this executor's runs report progress on.
        started: [s] `time.time()` when it was started.
    """

    def __init__(self, client: Any, cluster: Any = None, *, where: str) -> None:
        self.client = client
        self.cluster = cluster
        self.where = where
        self.numba_threads: int | None = None if where == IN_PROCESS else 1
        self.topic = f"twin-progress-{uuid.uuid4().hex[:12]}"
        self.started = time.time()
        self.closed = False
        self.dashboard = False  # whether its LocalCluster serves the Dask dashboard

    @classmethod
    def start(
        cls,
        scheduler: str | None = None,
        *,
        n_workers: int | None = None,
        warm: bool = True,
        timeout: float = CONNECT_TIMEOUT,
        dashboard: bool = False,
        nice: int = 0,
    ) -> Executor:
        """Start a LocalCluster (or join a scheduler) and load the kernels on every worker.

        Args:
            scheduler: None starts a `LocalCluster` of `n_workers` single-threaded worker
                processes (default: one per core); "tcp://HOST:PORT" (or tls://, ucx://,
                inproc://) joins an existing scheduler, whose workers need `twin` installed;
                "in-process" starts one worker thread in this process (tests, small jobs).
            n_workers: workers of a LocalCluster.
            warm: load the compiled kernels on every worker, now and on any worker that joins.
            timeout: [s] to reach the scheduler and its first worker.
            dashboard: a LocalCluster's scheduler serves its Dask dashboard, on 127.0.0.1 at a
                free port (`dashboard_link`); default off: a dashboard answers any Host, so
                a page elsewhere could read it through DNS rebinding (issue 30).
            nice: a LocalCluster's worker processes lower their priority to this niceness
                once their kernels are loaded (`twin serve`: `WORKER_NICE`); not the workers
                of a scheduler joined, nor an in-process worker (the caller's process).

        Raises:
            ValueError: an address that is not a Dask scheduler's, or a bad `n_workers`.
            OSError, TimeoutError: the scheduler cannot be reached.
        """
        if n_workers is not None and not 1 <= n_workers <= 256:
            raise TwinError(f"n_workers: got {n_workers}; allowed 1 … 256")
        if not 0 <= nice <= 19:
            raise TwinError(f"nice: got {nice}; allowed 0 … 19")
        if scheduler is None or scheduler == IN_PROCESS:
            executor = cls._start_local(
                in_process=scheduler == IN_PROCESS, n_workers=n_workers, timeout=timeout,
                dashboard=dashboard,
            )  # fmt: skip
        else:
            executor = cls._join(scheduler, timeout=timeout)
        client = executor.client
        try:
            if not client.scheduler_info(n_workers=-1)["workers"]:
                client.wait_for_workers(1, timeout=timeout)
            if warm:
                own = scheduler is None  # our own worker processes
                client.register_plugin(_warm_plugin(freeze=own, nice=nice))
        except BaseException:
            executor.close()
            raise
        return executor

    @classmethod
    def _start_local(
        cls, *, in_process: bool, n_workers: int | None, timeout: float, dashboard: bool
    ) -> Executor:
        """`start`'s LocalCluster (`n_workers` processes, or one worker thread `in_process`)
        with Dask's `QUIET_DASK` settings, and its client; the cluster is closed if the client
        cannot connect."""
        import dask
        from distributed import Client, LocalCluster

        quiet = dict(QUIET_DASK)
        if dashboard:  # the dashboard's profile plots need the profiler
            del quiet["distributed.worker.profile.enabled"]
        with dask.config.set(quiet):  # read as the scheduler and workers are made
            cluster = LocalCluster(
                n_workers=1 if in_process else n_workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=not in_process,
                # no dashboard unless asked for (the scheduler's HTTP routes of health and
                # metrics stay); on loopback (an in-process worker would listen on every
                # interface) and on a free port (not 8787, which another cluster may hold)
                dashboard_address="127.0.0.1:0",
                scheduler_kwargs={"dashboard": dashboard},
                worker_dashboard_address=None,
                # the scheduler takes pickled functions from whoever connects: over TLS with a
                # key made for this cluster and held only in memory (`Security.temporary`),
                # another local user cannot submit one (an in-process cluster has no port)
                security=None if in_process else True,
                # workers log connection errors while a cluster shuts down; a task's own error
                # still reaches its future
                silence_logs=logging.CRITICAL,
            )
        try:
            client = Client(cluster, timeout=timeout, set_as_default=False)
        except BaseException:
            cluster.close()
            raise
        executor = cls(client, cluster, where=IN_PROCESS if in_process else "local cluster")
        executor.dashboard = dashboard
        return executor

    @classmethod
    def _join(cls, scheduler: str, *, timeout: float) -> Executor:
        """`start`'s client of an existing scheduler at a Dask address.

        Raises:
            TwinError: `scheduler` is not a Dask address (tcp://, tls://, inproc://, ucx://).
        """
        from distributed import Client

        if not scheduler.startswith(("tcp://", "tls://", "inproc://", "ucx://")):
            raise TwinError(
                f"scheduler: got {scheduler!r}; allowed None (a local cluster), "
                f"{IN_PROCESS!r} or a Dask address such as 'tcp://HOST:PORT'"
            )
        client = Client(scheduler, timeout=timeout, set_as_default=False)
        return cls(client, where=scheduler)

    # -- readers -----------------------------------------------------------------------------
    @property
    def dashboard_link(self) -> str | None:
        """The Dask dashboard's address, if the cluster serves one."""
        return self.cluster.dashboard_link if self.dashboard else None

    @property
    def workers(self) -> int:
        """Worker threads the scheduler has now."""
        info = self.client.scheduler_info(n_workers=-1)["workers"]
        return sum(w.get("nthreads", 1) for w in info.values())

    def info(self) -> dict[str, Any]:
        """Where it runs, how many workers, since when (for `GET /api/health`), without asking
        the scheduler: the worker threads are the client's copy of the scheduler's identity,
        which the client refreshes every `distributed.client.scheduler-info-interval` (2 s).
        `workers` asks the scheduler, and health waited on that round trip to a scheduler busy
        with a sweep (issue 30's soak: health p99 over 1 s); this never blocks."""
        workers: int | None
        if self.closed:
            workers = 0
        else:
            identity = getattr(self.client, "_scheduler_identity", None) or {}
            workers = identity.get("total_threads")
            if workers is None:  # a client that keeps no copy: ask
                workers = self.workers
        return {"scheduler": self.where, "workers": int(workers), "started": self.started}

    # -- work ----------------------------------------------------------------------------------
    def submit(
        self, fn: Callable[..., R], *args: Any, priority: int = 0, key: str | None = None,
        **kwargs: Any,
    ) -> Any:  # fmt: skip
        """Submit `fn(*args, **kwargs)`: a Dask future (never run twice as a cached result)."""
        if self.closed:
            raise RuntimeError("the executor is closed")
        options = {"key": key} if key is not None else {}
        return self.client.submit(fn, *args, priority=priority, pure=False, **options, **kwargs)

    def run(
        self, fields: dict[str, Any], *, name: str, budget: float | None = RUN_BUDGET
    ) -> Any:
        """A run as a future of its `RunOutput`, reporting progress on `topic` as `name`."""
        return self.submit(
            run_scenario, fields, name=name, topic=self.topic, budget=budget,
            priority=RUN_PRIORITY, key=f"twin-run-{name}-{uuid.uuid4().hex[:8]}",
        )  # fmt: skip

    def map_unordered(
        self, fn: Callable[[T], R], items: Iterable[T], *, priority: int = 0
    ) -> Iterator[R]:
        """`fn(item)` for every item on the workers; results as they finish (unordered).

        Stopping early (or an error) cancels what has not finished.
        """
        futures = [self.submit(fn, item, priority=priority) for item in items]
        try:
            for future in self.as_completed(futures):
                yield future.result()
        finally:
            self.cancel(futures)

    def as_completed(self, futures: Iterable[Any]) -> Iterator[Any]:
        """The futures as they finish, on this executor's client (which is never made the
        process's default Dask client: that would leak into unrelated code, e.g. xarray)."""
        from distributed import as_completed

        return as_completed(futures, loop=self.client.loop)

    def cancel(self, futures: Iterable[Any]) -> None:
        """Cancel futures that have not finished (no-op for the others, or once closed)."""
        pending = [f for f in futures if not f.done()]
        if pending and not self.closed:
            try:
                self.client.cancel(pending)
            except Exception:  # the client is going away: nothing left to cancel
                log.debug("cancel failed", exc_info=True)

    def subscribe(self, handler: Callable[[dict[str, Any]], None]) -> None:
        """Call `handler(message)` for every progress report of this executor's runs (in the
        client's event-loop thread: keep it short)."""
        self.client.subscribe_topic(self.topic, lambda event: handler(event[1]))

    def restart_worker(self, address: str) -> None:
        """Restart one worker (a run stuck past its budget), without waiting for it."""
        try:
            self.client.restart_workers([address], timeout=CLOSE_TIMEOUT, raise_for_error=False)
        except Exception:
            log.warning("could not restart worker %s", address, exc_info=True)

    # -- lifetime ------------------------------------------------------------------------------
    def close(self, timeout: float = CLOSE_TIMEOUT) -> None:
        """Stop at once: close the client and the cluster it started, if any. Worker processes
        still busy with a task are killed first (what they were running is abandoned: a server
        requeues its unfinished runs), so a worker deep in a kernel cannot hold the close up."""
        if self.closed:
            return
        self.closed = True
        try:
            self._close(timeout)
        finally:
            _drop_stale_scheduler()

    def _close(self, timeout: float) -> None:
        busy = True
        if self.cluster is not None:
            try:
                busy = any(self.client.processing().values())
            except Exception:
                log.debug("could not ask the scheduler what runs", exc_info=True)
        workers = [p for p in multiprocessing.active_children() if "Dask Worker" in p.name]
        try:
            self.client.close(timeout=timeout)
        except Exception:
            log.debug("client close failed", exc_info=True)
        if self.cluster is None:
            return
        if busy:
            for process in workers:
                process.kill()
            for process in workers:
                process.join(timeout)
        try:
            self.cluster.close(timeout=timeout)
        except Exception:
            log.debug("cluster close failed", exc_info=True)
        finally:
            # a close that timed out leaves the cluster registered, and distributed closes it
            # again at interpreter exit, waiting its full default timeout
            from distributed.deploy.spec import SpecCluster

            SpecCluster._instances.discard(self.cluster)

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _drop_stale_scheduler() -> None:
    """Clear Dask's process-wide `scheduler` setting when it names distributed and no client
    is left.

    An in-process cluster's workers make their `worker_client`s the default, which sets that
    key for the whole process; distributed restores it as each client closes, so two in-process
    clusters whose lives overlap (closed in the order they started) leave "dask.distributed"
    behind with no client. Dask, and xarray's netCDF writer with it (`twin.vessel.rao`), then
    raise "no Client active" anywhere in the process."""
    import dask
    from distributed import default_client

    if dask.config.get("scheduler", None) not in ("dask.distributed", "distributed"):
        return
    try:
        default_client()
    except ValueError:  # none left
        dask.config.config.pop("scheduler", None)


def map_unordered(
    fn: Callable[[T], R],
    items: Iterable[T],
    *,
    scheduler: str | None = None,
    n_workers: int | None = None,
) -> Iterator[R]:
    """`fn(item)` for every item on a fresh executor (`Executor.start(scheduler, n_workers)`),
    results as they finish; the executor is closed once the iterator is exhausted or closed.

    What scripts use instead of a process pool, e.g. scripts/reproduce.py:

        for job, result in tqdm(map_unordered(run_job, todo, n_workers=2), total=len(todo)):
            ...

    `fn` and the items are pickled to the workers (a function of a script's `__main__` by
    value); each worker has the kernels loaded before its first item.
    """
    with Executor.start(scheduler, n_workers=n_workers) as executor:
        yield from executor.map_unordered(fn, items)

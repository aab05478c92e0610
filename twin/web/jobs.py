"""Scripted runs in worker processes: short ones awaited by the request, long ones as jobs;
operability sweeps from a thread (`SweepRunner`).

Every run is first a row in the `RunStore` (queued), then executes in a small process pool,
so a simulation never competes for the GIL with the live loop, the 3D viewer and the web
server. Workers write progress and the result straight to the store, so status survives the
web process: on start, `JobRunner.start` queues again whatever a stopped server left unfinished.

Synchronous cap: a `POST /api/runs` of at most `SYNC_MAX_STEPS` steps (duration / dt) answers
when the run is done; a longer one answers 202 at once and runs in the background.

Workers are spawned processes, which import the parent's main module: a script that serves the
app must keep its entry point under `if __name__ == "__main__":` (`twin serve` does).
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import tempfile
import threading
import time
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from twin.sim import Scenario, Simulation
from twin.sim.engine import warm
from twin.web.store import RunStore

#: most steps a synchronous run may take: 600 s at the default dt = 0.05 s, 20-30 s of compute
#: for the hybrid system on a free core (2-3 s per simulated minute)
SYNC_MAX_STEPS = 12_000
#: worker processes; one run per worker at a time, the rest wait queued
WORKERS = 2
#: [s] wall time between two progress writes of a running job
PROGRESS_PERIOD = 0.5
#: steps between two looks at the clock (a few milliseconds on the compiled engine)
PROGRESS_STEPS = 1000


def steps(scenario: Scenario) -> int:
    """Steps a run of `scenario` takes (as `Simulation.n_steps`)."""
    return round(scenario.duration / scenario.dt)


def execute(db_path: str, run_id: str) -> None:
    """Worker: run a stored scenario to the end, writing progress and the result to the store.

    Steps exactly as `simulate` does (the same engine in chunks), so a stored run's metrics
    equal `simulate(scenario)`'s.

    Raises:
        Exception: whatever the simulation raised, after storing it as the run's error.
    """
    with RunStore(db_path) as store:
        try:
            simulation = Simulation(store.scenario(run_id))
            store.mark_running(run_id)
            last = time.monotonic()
            while not simulation.done:
                simulation.advance(PROGRESS_STEPS)
                if time.monotonic() - last > PROGRESS_PERIOD:
                    store.set_progress(run_id, simulation.k / simulation.n_steps)
                    last = time.monotonic()
            store.finish(run_id, simulation.result())
        except Exception as exc:
            store.fail(run_id, f"{type(exc).__name__}: {exc}")
            raise


#: [s] how often a worker checks that the server that spawned it is still alive
PARENT_CHECK = 0.5


def _exit_with_parent(parent: int) -> None:
    """Worker initializer: exit as soon as the server that spawned the worker is gone.

    A server killed with SIGKILL cannot stop its pool; its workers would finish the run in hand
    beside the next server (which runs it again) and then idle for ever. Polling the parent id
    (it changes when the worker is re-parented) works whatever thread started the worker,
    which the kernel's parent-death signal would not.
    """

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_CHECK)
        os._exit(1)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def _warm() -> None:
    """Spawn a worker, import the simulation and load the compiled kernels (`warm`), so the
    first run a worker takes is as fast as the next."""
    warm()


class JobRunner:
    """A process pool executing stored runs.

    Args:
        store: where runs are read from and written to (workers open the same file).
        workers: processes in the pool.
        sync_max_steps: runs up to this many steps are answered synchronously.
    """

    def __init__(
        self, store: RunStore, *, workers: int = WORKERS, sync_max_steps: int = SYNC_MAX_STEPS
    ) -> None:
        self.store = store
        self.workers = workers
        self.sync_max_steps = sync_max_steps
        self._pool: ProcessPoolExecutor | None = None
        self._closing = False

    def is_sync(self, scenario: Scenario) -> bool:
        """Whether a run of `scenario` is awaited by its request."""
        return steps(scenario) <= self.sync_max_steps

    def start(self) -> list[str]:
        """Spawn the workers and queue runs a previous server left unfinished.

        Returns:
            The ids queued again.
        """
        self._closing = False
        for _ in range(self.workers):
            self._executor().submit(_warm)  # the first run then skips process start and JIT
        recovered = self.store.requeue_unfinished()
        for run_id in recovered:
            self.submit(run_id)
        return recovered

    def submit(self, run_id: str) -> Future[None]:
        """Execute a stored run in a worker; the future resolves when it is stored."""
        pool = self._executor()
        future = pool.submit(execute, str(self.store.path), run_id)
        future.add_done_callback(lambda f: self._settle(run_id, pool, f))
        return future

    def _executor(self) -> ProcessPoolExecutor:
        # spawn, not fork: the parent runs threads (live loop, viewer, uvicorn) that a forked
        # child would inherit mid-lock.
        if self._pool is None:
            self._pool = ProcessPoolExecutor(
                self.workers,
                mp_context=multiprocessing.get_context("spawn"),
                initializer=_exit_with_parent,
                initargs=(os.getpid(),),
            )
        return self._pool

    def _settle(self, run_id: str, pool: ProcessPoolExecutor, future: Future[None]) -> None:
        """Record a run whose worker died before it could record anything itself."""
        if self._closing or future.cancelled() or future.exception() is None:
            return  # on shutdown the run stays unfinished and `start` requeues it
        exc = future.exception()
        if isinstance(exc, BrokenProcessPool) and self._pool is pool:
            self._pool = None  # a dead worker breaks its whole pool: the next submit starts one
            pool.shutdown(wait=False, cancel_futures=True)
        if self.store.get(run_id).status in ("queued", "running"):
            self.store.fail(run_id, f"worker failed: {exc!r}")

    def shutdown(self) -> None:
        """Stop the workers now; unfinished runs stay queued/running in the store."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        self._closing = True
        # ProcessPoolExecutor has no public way to stop running tasks before Python 3.14; a
        # killed worker loses nothing stored (every write is a transaction) and its run is
        # requeued on the next start.
        processes = list(getattr(pool, "_processes", {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            process.terminate()
        for process in processes:
            process.join(timeout=5)


class SweepRunner:
    """Operability sweeps, one at a time, from a daemon thread of the web process.

    The thread only drives `run_sweep`: by default that starts a Dask `LocalCluster` whose
    worker processes do the simulating, so the web process stays responsive. Progress and the
    result go to the store, so status survives a restart; `start` queues again whatever a
    stopped server left unfinished.

    Args:
        store: where sweeps are read from and written to.
        scheduler: `run_sweep`'s scheduler: None (a LocalCluster per sweep), "tcp://HOST:PORT"
            or "in-process" (tests, small machines).
    """

    def __init__(self, store: RunStore, *, scheduler: str | None = None) -> None:
        self.store = store
        self.scheduler = scheduler
        self._queue: queue.Queue[str | None] = queue.Queue()
        self._thread: threading.Thread | None = None

    def start(self) -> list[str]:
        """Start the thread and queue sweeps a previous server left unfinished.

        Returns:
            The ids queued again.
        """
        if self._thread is None or not self._thread.is_alive():
            # daemon: a sweep cannot be interrupted mid-chunk, and must not hold up the exit;
            # it stays unfinished in the store and is rerun on the next start
            self._thread = threading.Thread(target=self._loop, name="sweeps", daemon=True)
            self._thread.start()
        recovered = self.store.requeue_unfinished_sweeps()
        for sweep_id in recovered:
            self.submit(sweep_id)
        return recovered

    def submit(self, sweep_id: str) -> None:
        """Run a stored sweep after the ones already queued."""
        self._queue.put(sweep_id)

    def shutdown(self) -> None:
        """Stop after the current sweep; queued sweeps stay queued in the store."""
        self._queue.put(None)
        self._thread = None

    def _loop(self) -> None:
        while (sweep_id := self._queue.get()) is not None:
            self.execute(sweep_id)

    def execute(self, sweep_id: str) -> None:
        """Run one stored sweep to the end, storing progress, table and heatmap (or the error)."""
        from twin.sim.sweep import SweepSpec, heatmap_png, run_sweep

        try:
            spec = SweepSpec(**self.store.get_sweep(sweep_id).spec)
            self.store.sweep_running(sweep_id)
            result = run_sweep(
                spec,
                scheduler=self.scheduler,
                progress=False,
                on_progress=lambda done, _total: self.store.sweep_progress(sweep_id, done),
            )
            with tempfile.TemporaryDirectory() as folder:
                png = heatmap_png(result, Path(folder) / "heatmap.png").read_bytes()
            self.store.finish_sweep(sweep_id, result.to_dict(), png)
        except Exception as exc:  # a thread has no caller to raise to: the store is its report
            self.store.fail_sweep(sweep_id, f"{type(exc).__name__}: {exc}")

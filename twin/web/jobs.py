"""Runs and sweeps of the REST API as futures on the server's one executor.

Every run is first a row in the `RunStore` (queued), then a future on the executor
(`twin.runs.executor.Executor.run`): a worker process of the server's Dask cluster steps it,
reports progress as Dask events, and sends the result back packed. The server process is the
store's only writer: one thread stores, in order, what the workers report (running, progress,
the result or the failure). Status survives the server: on start, `JobRunner.start` queues
again whatever a stopped server left unfinished, and on shutdown it cancels the futures and
leaves their runs queued.

Synchronous cap: a `POST /api/runs` of at most `SYNC_MAX_STEPS` steps (duration / dt) answers
when the run is done; a longer one answers 202 at once and runs in the background.

Short runs in process: a run of at most `INLINE_MAX_STEPS` steps (a few milliseconds of
compute) runs on one thread of the server process (`run_scenario`, the same engine a worker
calls; its compiled kernels release the GIL) when that thread is free, instead of a round trip
through the Dask scheduler and a worker (issue 30: a 60 s run's POST waited 26 ms for the
hand-off and 17 ms for the result, 16 ms for the run). One such run at a time: the next short
run while one is in hand goes to the executor, so the front end never holds more than one
run's Python work. Such a run reports no progress (it is over in milliseconds); its budget is
`run_scenario`'s, as on a worker. A request that waits for its run (`run_here`) runs it on its
own worker thread, the one that stored it, instead of handing it to another thread and back
(each hand-off a wake-up and a wait for the GIL); a run queued again at start runs on the
runner's own thread.

Budget: a run has a wall-clock budget (`budget`) beside the step cap; past it the worker stops
it (`BudgetExceeded`) and it is stored as failed with a message. A worker that does not answer
`WATCHDOG_GRACE` s after the budget has its run failed and is restarted.

Sweeps (`SweepRunner`) run one at a time from a thread that drives `run_sweep` on the same
executor: their chunks queue behind single runs (a lower Dask priority). A sweep's heatmap is
drawn by a task on the executor too (`twin.runs.sweep.heatmap_bytes`), never in the server
process, so a figure cannot take the process that answers requests.

Cancel (issue 30): `JobRunner.cancel` and `SweepRunner.cancel` mark a queued or running job
failed ("cancelled …") and cancel its futures; a sweep in hand stops after the chunk that is
running. A run already on a worker cannot be interrupted mid-chunk: it ends within its budget
and its outcome is dropped. Restarts: a job started `twin.db.MAX_ATTEMPTS` times without
finishing (each stopped by a shutdown or a crash) is failed on the next start, with the
reason, instead of being queued again.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

from twin.db import StoreUnavailable
from twin.runs.executor import RUN_BUDGET, BudgetExceeded, Executor, RunOutput, run_scenario
from twin.sim import Scenario
from twin.web.store import Run, RunNotFound, RunStore

log = logging.getLogger(__name__)

#: most steps a synchronous run may take: 600 s at the default dt = 0.05 s (well under a second
#: of compute on the compiled engine)
SYNC_MAX_STEPS = 12_000
#: most steps a run may take to run on the server's own thread instead of the executor: 120 s at
#: the default dt (about 20 ms of compute, mostly in the GIL-free kernels); 0: never
INLINE_MAX_STEPS = 2_400
#: [s] a synchronous request waits for its run at most this long beyond the budget (queued
#: behind others, say), then answers 202 with the run as it is
SYNC_GRACE = 30.0
#: [s] past its budget, a run whose worker has not answered is failed and the worker restarted
WATCHDOG_GRACE = 10.0
#: [s] how often the watchdog looks
WATCHDOG_PERIOD = 1.0
#: [s] how often a sweep thread waiting on the executor looks whether to stop
POLL = 0.2
#: tries, and [s] between them, at requeueing the unfinished runs at shutdown (a store busy
#: under load answers a moment later)
REQUEUE_ATTEMPTS, REQUEUE_PAUSE = 3, 0.5


def steps(scenario: Scenario) -> int:
    """Steps a run of `scenario` takes (as `Simulation.n_steps`)."""
    return round(scenario.duration / scenario.dt)


def _is_dask(future: Any) -> bool:
    """Whether a run's future is the executor's (a Dask future), not a short run's thread."""
    return future is not None and not isinstance(future, Future)


class JobRunner:
    """Stored runs as futures on an executor, their outcome written back to the store.

    Args:
        store: where runs are read from and written to.
        sync_max_steps: runs up to this many steps are answered synchronously.
        budget: [s] wall-clock budget of one run on its worker.
        inline_max_steps: runs up to this many steps run on the server's own thread when it
            is free (`INLINE_MAX_STEPS`; 0: every run goes to the executor).
    """

    def __init__(
        self,
        store: RunStore,
        *,
        sync_max_steps: int = SYNC_MAX_STEPS,
        budget: float = RUN_BUDGET,
        inline_max_steps: int = INLINE_MAX_STEPS,
    ) -> None:
        self.store = store
        self.sync_max_steps = sync_max_steps
        self.budget = budget
        self.inline_max_steps = inline_max_steps
        self._inline: ThreadPoolExecutor | None = None
        self._inline_free = threading.Semaphore(1)  # one short run in process at a time
        self.executor: Executor | None = None
        self._lock = threading.Lock()
        self._futures: dict[str, tuple[Any, Future[Run]]] = {}  # id → (Dask or thread, outcome)
        self._running: dict[str, tuple[float, str]] = {}  # run id → (start, worker address)
        self._writer: ThreadPoolExecutor | None = None
        self._stopping = threading.Event()
        # held while a run is marked running, and while stopping is set: a mark that began
        # before the stop lands before the requeue, one after sees the stop (no run is left
        # `running` by a mark racing the shutdown)
        self._marking = threading.Lock()
        self._watchdog: threading.Thread | None = None

    @property
    def sync_wait(self) -> float:
        """[s] the longest a synchronous request waits before it answers 202."""
        return self.budget + SYNC_GRACE

    def is_sync(self, scenario: Scenario) -> bool:
        """Whether a run of `scenario` is awaited by its request."""
        return steps(scenario) <= self.sync_max_steps

    def pending(self) -> int:
        """Runs submitted here and not settled yet."""
        with self._lock:
            return len(self._futures)

    # -- lifetime ------------------------------------------------------------------------------
    def start(self, executor: Executor) -> list[str]:
        """Take runs to `executor`, and queue again those a previous server left unfinished.

        Returns:
            The ids queued again.
        """
        self.executor = executor
        self._stopping.clear()
        self._writer = ThreadPoolExecutor(1, thread_name_prefix="twin-store")
        self._inline = ThreadPoolExecutor(1, thread_name_prefix="twin-inline-run")
        self._inline_free = threading.Semaphore(1)  # a run a stop cancelled keeps no slot
        executor.subscribe(self._on_report)
        self._watchdog = threading.Thread(target=self._watch, name="twin-watchdog", daemon=True)
        self._watchdog.start()
        recovered = self.store.requeue_unfinished()
        for run_id in recovered:
            self.submit(run_id)
        return recovered

    def shutdown(self) -> None:
        """Stop: cancel the runs' futures, finish the store write in hand, and leave every
        unfinished run queued (the next start runs it)."""
        with self._marking:
            self._stopping.set()
        with self._lock:
            futures = list(self._futures.values())
            self._futures.clear()
            self._running.clear()
        if self.executor is not None:
            self.executor.cancel([dask for dask, _ in futures if _is_dask(dask)])
        for _, done in futures:
            done.cancel()
        if self._inline is not None:  # a run in hand ends in milliseconds; `_settle` drops it
            self._inline.shutdown(wait=False, cancel_futures=True)
        if self._writer is not None:
            self._writer.shutdown(wait=True, cancel_futures=True)
        for attempt in range(REQUEUE_ATTEMPTS):
            try:
                self.store.requeue_unfinished()
                return
            except StoreUnavailable as exc:  # a busy store under load: once more, shortly
                log.warning("run store unavailable at shutdown (attempt %d of %d): %s",
                            attempt + 1, REQUEUE_ATTEMPTS, exc)  # fmt: skip
                if attempt + 1 < REQUEUE_ATTEMPTS:
                    time.sleep(REQUEUE_PAUSE)
        log.error("unfinished runs not requeued at shutdown: the next start requeues them")

    # -- runs ----------------------------------------------------------------------------------
    def cancel(self, run_id: str, reason: str = "by request") -> bool:
        """Cancel a queued or running run: stored failed ("cancelled …"), its future cancelled
        (a run in a worker's hands ends within its budget; its outcome is dropped). Whether it
        was queued or running.

        Raises:
            RunNotFound: no run has this id.
        """
        cancelled = self.store.cancel(run_id, reason)
        with self._lock:
            entry = self._futures.pop(run_id, None)
            self._running.pop(run_id, None)
        if entry is not None:
            dask, done = entry
            if self.executor is not None and _is_dask(dask):
                self.executor.cancel([dask])
            done.cancel()
        return cancelled

    def submit(self, run_id: str) -> Future[Run]:
        """Run a stored run on the executor.

        Returns:
            A future of the stored run once it is done or failed; its exception is the
            `ValueError` of a scenario the worker refused before any step, or
            `StoreUnavailable`; it is cancelled if the server stops first.
        """
        if self.executor is None or self._writer is None:
            raise RuntimeError("JobRunner.start(executor) first")
        scenario = self.store.scenario(run_id)
        fields = scenario.model_dump(mode="json")
        done: Future[Run] = Future()
        with self._lock:  # before the run exists: a fast one may settle at once
            self._futures[run_id] = (None, done)
        if self._inline is not None and self._short(scenario):
            if self._inline_free.acquire(blocking=False):
                try:
                    inline = self._inline.submit(self._run_inline, run_id, fields, done)
                except RuntimeError:  # shutting down: the run stays queued
                    self._inline_free.release()
                    done.cancel()
                    return done
                with self._lock:
                    if run_id in self._futures:
                        self._futures[run_id] = (inline, done)
                return done
        return self._to_executor(run_id, fields, done)

    def run_here(self, run_id: str) -> Future[Run]:
        """`submit`, except that a short run (at most `inline_max_steps` steps) runs on the
        calling thread when the in-process slot is free: a request's worker thread that waits
        for the answer anyway (issue 30: no hand-off to the runner's thread and back). Blocks
        for such a run (a few milliseconds; within its budget, as on a worker).

        Returns:
            The run's future as `submit`'s, already resolved when the run ran here (the stored
            run, the refusal's `ValueError`, or cancelled if the server stopped or the run
            was cancelled meanwhile).
        """
        if self._inline is None or self._writer is None or self._stopping.is_set():
            return self.submit(run_id)  # not started (it says so), or stopping
        scenario = self.store.scenario(run_id)
        if not self._short(scenario) or not self._inline_free.acquire(blocking=False):
            return self.submit(run_id)  # the slot is taken: to the executor
        done: Future[Run] = Future()
        with self._lock:
            self._futures[run_id] = (done, done)  # a `Future`: not a Dask one to cancel
        self._run_inline(run_id, scenario.model_dump(mode="json"), done)
        return done

    def _short(self, scenario: Scenario) -> bool:
        """Whether a run of `scenario` may run in process (`inline_max_steps`)."""
        return steps(scenario) <= self.inline_max_steps

    def _to_executor(self, run_id: str, fields: dict[str, Any], done: Future[Run]) -> Future[Run]:
        """The run as a task on the executor, settled by the store writer thread."""
        if self.executor is None or self._writer is None:
            raise RuntimeError("JobRunner.start(executor) first")
        dask = self.executor.run(fields, name=run_id, budget=self.budget)
        with self._lock:
            if run_id in self._futures:
                self._futures[run_id] = (dask, done)
        writer = self._writer
        dask.add_done_callback(lambda f: self._hand(writer, self._settle, run_id, f, done))
        return done

    def _run_inline(self, run_id: str, fields: dict[str, Any], done: Future[Run]) -> None:
        """A short run on a thread of the server (the runner's, or a request's: `run_here`),
        which holds the in-process slot and gives it back: marked running, run
        (`run_scenario`, as a worker runs it), its outcome stored (`_settle`, on this thread: no
        progress report can come after it)."""
        outcome: Future[RunOutput] = Future()
        try:
            with self._lock:
                ours = run_id in self._futures
            if ours and self._mark_running(run_id):
                try:
                    outcome.set_result(run_scenario(fields, name=run_id, budget=self.budget))
                except Exception as exc:  # as the Dask future would carry it
                    outcome.set_exception(exc)
            else:
                outcome.cancel()
        finally:
            self._inline_free.release()
        self._settle(run_id, outcome, done)

    def _hand(self, writer: ThreadPoolExecutor, fn: Any, *args: Any) -> None:
        """Queue a store write (in order, off the Dask client's event loop)."""
        try:
            writer.submit(fn, *args)
        except RuntimeError:  # the writer has shut down: the server is stopping
            pass

    def _on_report(self, message: dict[str, Any]) -> None:
        """A worker's progress report (on the Dask client's event loop: only hand it on)."""
        run_id = message.get("name")
        with self._lock:
            ours = run_id in self._futures
        if ours and self._writer is not None:
            self._hand(self._writer, self._progress, run_id, message)

    def _progress(self, run_id: str, message: dict[str, Any]) -> None:
        if self._stopping.is_set():
            return
        try:
            if message.get("progress", 0.0) == 0.0:
                if self._mark_running(run_id):
                    with self._lock:
                        if run_id in self._futures:
                            self._running[run_id] = (time.monotonic(), message.get("worker", ""))
            else:
                self.store.set_progress(run_id, float(message["progress"]))
        except (RunNotFound, StoreUnavailable):
            pass  # a refused run deleted, or a store gone: nothing to report into

    def _mark_running(self, run_id: str) -> bool:
        """Mark a queued run running unless the server is stopping; whether it runs (a store
        that cannot say is `_settle`'s to report: the run goes ahead)."""
        with self._marking:
            if self._stopping.is_set():
                return False
            try:
                return self.store.mark_running(run_id)
            except RunNotFound:  # deleted meanwhile: nothing to run
                return False
            except StoreUnavailable:
                return True

    def _settle(self, run_id: str, future: Any, done: Future[Run]) -> None:
        """Store a run's outcome; resolve `done`."""
        with self._lock:
            ours = self._futures.pop(run_id, None) is not None
            self._running.pop(run_id, None)
        if self._stopping.is_set() or future.cancelled() or not ours:
            done.cancel()  # stopping: the run stays unfinished and is requeued
            return
        try:
            try:
                output = future.result()
            except BudgetExceeded as exc:
                self.store.fail(run_id, f"BudgetExceeded: {exc}")
            except ValueError as exc:  # refused before its first step
                self.store.fail(run_id, f"{type(exc).__name__}: {exc}")
                done.set_exception(exc)
                return
            except Exception as exc:  # the worker died, or the run raised
                self.store.fail(run_id, f"worker failed: {type(exc).__name__}: {exc}")
            else:
                try:  # the run as stored, read back once (`finish_packed` returns it)
                    stored = self.store.finish_packed(run_id, output.metrics, output.series)
                    done.set_result(stored)
                    return
                except ValueError as exc:  # metrics that are not finite JSON
                    self.store.fail(run_id, f"result not storable: {exc}")
            done.set_result(self.store.get(run_id))
        except Exception as exc:  # the store is gone, or the run was deleted meanwhile
            done.set_exception(exc)

    def _watch(self) -> None:
        """Fail runs whose worker stays silent past the budget, and restart that worker."""
        while not self._stopping.wait(WATCHDOG_PERIOD):
            now = time.monotonic()
            with self._lock:
                late = [
                    (run_id, worker) for run_id, (start, worker) in self._running.items()
                    if now - start > self.budget + WATCHDOG_GRACE
                ]  # fmt: skip
                entries = {run_id: self._futures.pop(run_id, None) for run_id, _ in late}
                for run_id, _ in late:
                    self._running.pop(run_id, None)
            for run_id, worker in late:
                entry = entries[run_id]
                if entry is None:
                    continue
                dask, done = entry
                if self.executor is not None and _is_dask(dask):
                    self.executor.cancel([dask])
                    if worker:
                        self.executor.restart_worker(worker)
                try:
                    self.store.fail(
                        run_id,
                        f"BudgetExceeded: over the wall-clock budget of {self.budget:g} s and "
                        f"no answer from its worker {WATCHDOG_GRACE:g} s later; worker restarted",
                    )
                    done.set_result(self.store.get(run_id))
                except Exception as exc:
                    done.set_exception(exc)


def wait_polling(executor: Executor, draw: Any, result: Any, stop: Any, what: str) -> Any:
    """`draw(result)` as a task on `executor` (a worker process draws the figure), waited for in
    steps of `POLL` seconds so a stop or a cancel does not wait for it; the task is cancelled
    however the wait ends.

    Args:
        executor: where the task runs.
        draw: a picklable function of `result`.
        result: its argument.
        stop: () -> bool, true when the job was stopped or cancelled.
        what: what is drawn, for the error a stop raises ("the heatmap").

    Raises:
        RuntimeError: `stop()` became true before the task ended.
    """
    future = executor.submit(draw, result)
    try:
        while True:
            if stop():
                raise RuntimeError(f"stopped while {what} was drawn")
            try:
                return future.result(timeout=POLL)
            except TimeoutError:
                continue
    finally:
        executor.cancel([future])


class QueuedJobs:
    """Stored jobs one at a time from a daemon thread on the server's executor: the queue,
    submit, cancel, shutdown and the error handling shared by `SweepRunner` and
    `twin.web.workability_jobs.WorkabilityRunner`. A subclass names its thread and jobs and
    says how its store requeues, cancels and fails a job (`_requeue`, `_store_cancel`,
    `_store_fail`) and what running one does (`_work`).

    Args:
        store: where jobs are read from and written to.
    """

    #: name of the daemon thread
    thread_name = "twin-jobs"
    #: what a job is called in log messages, one and many
    kind = "job"
    kinds = "jobs"

    def __init__(self, store: Any) -> None:
        self.store = store
        self.executor: Executor | None = None
        self._queue: queue.Queue[str | None] = queue.Queue()
        self._thread: threading.Thread | None = None
        self._stopping = threading.Event()
        self._cancelled: set[str] = set()
        self._lock = threading.Lock()

    def _requeue(self) -> list[str]:
        """Ids of the stored jobs a stopped server left unfinished, queued again in the store."""
        raise NotImplementedError

    def _store_cancel(self, job_id: str, reason: str) -> bool:
        """Store a job as cancelled; whether it was queued or running."""
        raise NotImplementedError

    def _store_fail(self, job_id: str, error: str) -> None:
        """Store a job as failed with `error`."""
        raise NotImplementedError

    def _work(self, job_id: str, stop: Any) -> None:
        """Run one stored job to the end (`stop()` true: stop early by raising)."""
        raise NotImplementedError

    def start(self, executor: Executor) -> list[str]:
        """Start the thread on `executor`; queue jobs a previous server left unfinished.

        Returns:
            The ids queued again.
        """
        self.executor = executor
        self._stopping.clear()
        if self._thread is None or not self._thread.is_alive():
            self._thread = threading.Thread(target=self._loop, name=self.thread_name,
                                            daemon=True)  # fmt: skip
            self._thread.start()
        recovered = self._requeue()
        for job_id in recovered:
            self.submit(job_id)
        return recovered

    def submit(self, job_id: str) -> None:
        """Run a stored job after the ones already queued (not started yet, as while a server
        warms up: `start` takes it from the store with the others)."""
        if self.executor is not None:
            self._queue.put(job_id)

    def cancel(self, job_id: str, reason: str = "by request") -> bool:
        """Cancel a queued or running job: stored failed ("cancelled …"); the one in hand stops
        after its running chunk, its other chunks and its plots cancelled. Whether it was queued
        or running.

        Raises:
            SweepNotFound / WorkabilityNotFound: no job has this id (the store's error).
        """
        cancelled = self._store_cancel(job_id, reason)
        if cancelled:
            with self._lock:
                self._cancelled.add(job_id)
        return cancelled

    def _stopped(self, job_id: str) -> bool:
        with self._lock:
            return self._stopping.is_set() or job_id in self._cancelled

    def shutdown(self, timeout: float = 2.0) -> None:
        """Cancel the job in hand; it and the queued ones stay queued in the store."""
        self._stopping.set()
        self._queue.put(None)
        if self._thread is not None:
            self._thread.join(timeout)
            self._thread = None
        try:
            self._requeue()
        except StoreUnavailable:
            log.warning("run store unavailable at shutdown: unfinished %s not requeued", self.kinds)

    def _loop(self) -> None:
        while (job_id := self._queue.get()) is not None:
            if self._stopping.is_set():
                return
            if self._stopped(job_id):  # cancelled while queued: nothing to run
                with self._lock:
                    self._cancelled.discard(job_id)
                continue
            self.execute(job_id)

    def execute(self, job_id: str) -> None:
        """Run one stored job to the end (`_work`), storing its error if it fails."""
        stop = lambda: self._stopped(job_id)  # noqa: E731
        try:
            self._work(job_id, stop)
        except Exception as exc:  # a thread has no caller to raise to: the store is its report
            if stop():
                # a shutdown leaves it queued (run again on the next start); a cancel has
                # stored it as cancelled already
                return
            try:
                self._store_fail(job_id, f"{type(exc).__name__}: {exc}")
            except Exception:
                log.exception("%s %s failed and could not be stored as failed", self.kind, job_id)
        finally:
            with self._lock:
                self._cancelled.discard(job_id)


class SweepRunner(QueuedJobs):
    """Operability sweeps, one at a time, from a daemon thread that drives `run_sweep` on the
    server's executor (the workers simulate; the thread only collects). Progress and the result
    go to the store, so status survives a restart; `start` queues again whatever a stopped
    server left unfinished, and `shutdown` cancels the sweep in hand and leaves it queued.

    Args:
        store: where sweeps are read from and written to.
    """

    thread_name = "twin-sweeps"
    kind = "sweep"
    kinds = "sweeps"
    store: RunStore

    def __init__(self, store: RunStore) -> None:
        super().__init__(store)

    def _requeue(self) -> list[str]:
        return self.store.requeue_unfinished_sweeps()

    def _store_cancel(self, job_id: str, reason: str) -> bool:
        return self.store.cancel_sweep(job_id, reason)

    def _store_fail(self, job_id: str, error: str) -> None:
        self.store.fail_sweep(job_id, error)

    def _work(self, job_id: str, stop: Any) -> None:
        """Run one stored sweep to the end, storing progress, table and heatmap."""
        from twin.runs.sweep import SweepSpec, heatmap_bytes, run_sweep

        spec = SweepSpec(**self.store.get_sweep(job_id).spec)
        if not self.store.sweep_running(job_id):
            return  # cancelled before it started
        result = run_sweep(
            spec,
            executor=self.executor,
            progress=False,
            on_progress=lambda done, _total: self.store.sweep_progress(job_id, done),
            stop=stop,
        )
        png = self._render(heatmap_bytes, result, stop)
        self.store.finish_sweep(job_id, result.to_dict(), png)

    def _render(self, draw: Any, result: Any, stop: Any) -> bytes:
        """`draw(result)` as a task on the executor, waited for in short steps."""
        if self.executor is None:
            raise RuntimeError("SweepRunner.start(executor) first")
        return wait_polling(self.executor, draw, result, stop, "the heatmap")

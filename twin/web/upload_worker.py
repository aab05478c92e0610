"""Untrusted work in child processes bounded in CPU time, memory and wall time (issue 43).

An upload is parsed by pandas, whose cost a body can make quadratic (a scatter table of 50,000
Tp columns took 158 s of one core; 400,000 never finished) and whose C code holds the GIL, so
a parse in the server process freezes every request and even the shutdown. `BoundedWorker` runs
such work in child processes instead: each child limits its address space (`RLIMIT_AS`) once at
start and its CPU time (`RLIMIT_CPU`, reset before every call to the time used so far plus the
call's budget), and the parent waits at most the call's wall-clock budget. A child over any of
them is killed (the kernel sends SIGXCPU past the CPU limit; an allocation past the memory
limit fails, a `MemoryError`; the parent sends SIGKILL past the wall budget) and the call raises
`OverBudget`, naming the limit; another child takes its place in the background.

The children are long-lived (importing pandas takes 1-2 s, more than a request may wait): `size`
of them start when the worker is made and are reused, one call at a time each. A call waits for
a free child at most `wait` s (its wall budget unless given), then raises `WorkerBusy` (a 503).
A child imports only the module of its functions (`module`), with `twin.web`'s package
initialiser skipped, so it never loads the REST app.

Reusable by any upload (workability records, motion logs): `BoundedWorker(module).call("fn",
*args, budget=Budget(...), wait=...)` runs `module.fn(*args)` in a child and returns its result; a
`TwinError` raised there comes back as a `TwinError` with the same message. `submit` is the same
call as a future, so a request can answer by its own deadline and let a longer reading finish
within its budget behind it.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import pickle
import queue
import subprocess
import sys
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from multiprocessing.connection import Connection, Pipe
from pathlib import Path
from time import monotonic
from typing import Any

from twin.errors import TwinError

log = logging.getLogger(__name__)

#: [bytes] a child's address space: the interpreter with pandas takes about 380 MB of it
MEMORY = 1536 * 1024 * 1024
#: [s] how often a starting child is looked at: it is waited for as long as it lives (a
#: loaded machine may take a minute to import pandas), and replaced if it exits first
START_POLL = 1.0
#: children started in a row that exit before they are ready, before the pool stops trying
#: (a child that cannot import its module will not do better the next time)
START_ATTEMPTS = 3

#: the child's program: limits first, then its module (without twin.web's initialiser, which
#: loads the whole REST app), then calls until its pipe closes
_CHILD = """
import os, pickle, resource, sys, time, types
fd, memory, module, paths = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4:]
sys.path[:0] = paths
resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
from multiprocessing.connection import Connection
conn = Connection(fd)
import twin
web = types.ModuleType("twin.web")
web.__path__ = [os.path.join(os.path.dirname(twin.__file__), "web")]
sys.modules.setdefault("twin.web", web)
import importlib
target = importlib.import_module(module)
from twin.errors import TwinError
conn.send_bytes(b"ready")
while True:
    try:
        name, args, cpu = pickle.loads(conn.recv_bytes())
    except EOFError:
        break
    used = resource.getrusage(resource.RUSAGE_SELF)
    soft = int(used.ru_utime + used.ru_stime + cpu) + 1
    resource.setrlimit(resource.RLIMIT_CPU, (soft, resource.RLIM_INFINITY))
    try:
        answer = ("ok", getattr(target, name)(*args))
    except TwinError as exc:
        answer = ("twin", str(exc))
    except MemoryError:
        answer = ("memory", "")
    except Exception as exc:
        answer = ("error", f"{type(exc).__name__}: {exc}")
    conn.send_bytes(pickle.dumps(answer, protocol=pickle.HIGHEST_PROTOCOL))
"""


class OverBudget(TwinError):
    """A call went over its CPU time, memory or wall-clock budget (its child was killed).

    Attributes:
        limit: "cpu", "memory" or "wall".
    """

    def __init__(self, message: str, limit: str) -> None:
        super().__init__(message)
        self.limit = limit


class WorkerBusy(TwinError):
    """No child was free within the call's wall budget (every one busy or starting)."""


@dataclass(frozen=True)
class Budget:
    """What one call may take.

    Attributes:
        cpu: [s] CPU time of the child (rounded up to whole seconds by the kernel's limit).
        wall: [s] wall-clock time, waiting for a free child included.
    """

    cpu: float = 1.0
    wall: float = 0.9


class _Child:
    """One child process and the parent's end of its pipe."""

    def __init__(self, module: str, memory: int) -> None:
        parent, child = Pipe()
        fd = child.fileno()
        env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
               "MKL_NUM_THREADS": "1", "PYTHONWARNINGS": "ignore"}  # fmt: skip
        paths = [p for p in sys.path if p and Path(p).is_dir()]
        self.process = subprocess.Popen(
            [sys.executable, "-c", _CHILD, str(fd), str(memory), module, *paths],
            pass_fds=(fd,), env=env, stdin=subprocess.DEVNULL, start_new_session=True,
        )  # fmt: skip
        child.close()
        self.conn: Connection = parent

    def ready(self, timeout: float) -> bool | None:
        """Whether it said it is ready within `timeout` s: True; False if it cannot be (it
        exited, or said something else); None if it is still starting."""
        try:
            if self.conn.poll(timeout):
                return self.conn.recv_bytes() == b"ready"
        except (EOFError, OSError):
            return False
        return None if self.process.poll() is None else False

    def kill(self) -> None:
        with contextlib.suppress(OSError):
            self.process.kill()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.process.wait(5.0)
        self.conn.close()


class BoundedWorker:
    """`size` child processes that run `module`'s functions within a `Budget` each.

    Args:
        module: the dotted name of the module whose functions are called (imported by each
            child; its imports are what a child holds).
        size: children, so calls in parallel (each its own process, about 120 MB resident).
        memory: [bytes] each child's address space (`RLIMIT_AS`).
    """

    def __init__(self, module: str, size: int = 2, memory: int = MEMORY) -> None:
        if size < 1:
            raise TwinError(f"size: got {size}; allowed ≥ 1")
        self.module, self.memory = module, memory
        self._idle: queue.Queue[_Child] = queue.Queue()
        self._lock = threading.Lock()
        self._closed = False
        self._children: set[_Child] = set()
        self._calls = ThreadPoolExecutor(size, thread_name_prefix="twin-upload-call")
        for _ in range(size):
            self._replace()

    def _replace(self) -> None:
        """Start a child in the background; it joins the idle ones once ready."""

        def start() -> None:
            for attempt in range(1, START_ATTEMPTS + 1):
                child = _Child(self.module, self.memory)
                with self._lock:
                    if self._closed:
                        child.kill()
                        return
                    self._children.add(child)
                while (ready := child.ready(START_POLL)) is None and not self._closed:
                    pass
                if ready:
                    self._idle.put(child)
                    return
                self._forget(child)
                if self._closed:
                    return
                log.warning("an upload worker exited before it was ready (exit %s; attempt %d "
                            "of %d)", child.process.poll(), attempt, START_ATTEMPTS)  # fmt: skip
            log.error("upload workers fail to start: uploads wait, then answer 503")

        threading.Thread(target=start, name="twin-upload-worker-start", daemon=True).start()

    def _forget(self, child: _Child) -> None:
        child.kill()
        with self._lock:
            self._children.discard(child)

    def call(
        self, name: str, *args: Any, budget: Budget = Budget(), wait: float | None = None
    ) -> Any:
        """`module.name(*args)` in a child within `budget`; its return value.

        Args:
            name: the function of `module`.
            args: its arguments (pickled to the child).
            budget: what the call may take once a child has it.
            wait: [s] how long to wait for a free child (busy, or starting: 1-2 s); None:
                `budget.wall`.

        Raises:
            TwinError: the function raised one (its message).
            OverBudget: over the CPU, memory or wall budget (the child is replaced).
            WorkerBusy: no child was free within `wait`.
            RuntimeError: any other exception in the child (its type and message), or the
                worker is closed.
        """
        if self._closed:
            raise RuntimeError("the upload worker is closed")
        wait = budget.wall if wait is None else wait
        try:
            child = self._idle.get(timeout=wait)
        except queue.Empty:
            raise WorkerBusy(
                f"every upload worker is busy; retry in a few seconds (waited {wait:g} s)"
            ) from None
        over_wall = OverBudget(f"over the wall-clock budget of {budget.wall:g} s", "wall")
        try:
            sent = monotonic()
            child.conn.send_bytes(pickle.dumps((name, args, budget.cpu)))
            if not child.conn.poll(budget.wall):
                raise over_wall
            kind, value = pickle.loads(child.conn.recv_bytes())
            late = monotonic() - sent > budget.wall
        except (EOFError, OSError):
            code = child.process.wait(5.0)
            self._forget(child)
            self._replace()
            # the kernel ends a child past RLIMIT_CPU with SIGXCPU (or SIGKILL at the hard one)
            limit = "cpu" if code in (-24, -9) else "memory"
            what = (f"the CPU-time budget of {math.ceil(budget.cpu)} s" if limit == "cpu"
                    else f"the memory budget of {self.memory // 2**20} MiB")  # fmt: skip
            raise OverBudget(f"over {what}", limit) from None
        except OverBudget:
            self._forget(child)
            self._replace()
            raise
        if kind == "memory":
            self._forget(child)  # its heap may be fragmented near the limit: a fresh one
            self._replace()
            raise OverBudget(f"over the memory budget of {self.memory // 2**20} MiB", "memory")
        self._idle.put(child)
        # a parent thread descheduled past the budget finds the answer already there: the
        # budget still counts from the send, so a call is refused the same on a loaded machine
        if late:
            raise over_wall
        if kind == "twin":
            raise TwinError(value)
        if kind == "error":
            raise RuntimeError(value)
        return value

    def submit(
        self, name: str, *args: Any, budget: Budget = Budget(), wait: float | None = None
    ) -> Future[Any]:
        """`call` as a future (on one of `size` threads that only wait on the children)."""
        return self._calls.submit(self.call, name, *args, budget=budget, wait=wait)

    def close(self) -> None:
        """Kill every child (idempotent); calls not started yet are dropped."""
        self._calls.shutdown(wait=False, cancel_futures=True)
        with self._lock:
            self._closed = True
            children, self._children = list(self._children), set()
        for child in children:
            child.kill()
        while not self._idle.empty():
            self._idle.get_nowait()

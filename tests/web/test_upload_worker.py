"""`twin.web.upload_worker.BoundedWorker` (issue 43): work in a child process within a CPU-time,
memory and wall-clock budget; a child over one is killed and replaced, naming the limit."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.web.support import wait_for
from twin.errors import TwinError
from twin.web.upload_worker import BoundedWorker, Budget, OverBudget, WorkerBusy

#: [bytes] the test children's address space
MEMORY = 1024 * 1024 * 1024


@pytest.fixture(scope="module")
def worker() -> Iterator[BoundedWorker]:
    worker = BoundedWorker("tests.web.upload_tasks", size=1, memory=MEMORY)
    yield worker
    worker.close()


#: waiting for the one child, which may be starting (importing its module)
WAIT = 30.0


def test_a_call_within_its_budget_returns_its_value(worker: BoundedWorker) -> None:
    """The function runs in the child and its value comes back."""
    assert worker.call("allocate", 10, budget=Budget(wall=10.0), wait=WAIT) == 10 * 2**20


def test_a_call_over_its_cpu_budget_is_killed_naming_it(worker: BoundedWorker) -> None:
    """A busy loop past its CPU time is ended by the kernel (SIGXCPU): `OverBudget("cpu")`;
    the next call gets a new child."""
    with pytest.raises(OverBudget, match="CPU-time budget of 1 s") as refused:
        worker.call("spin", 30.0, budget=Budget(cpu=1.0, wall=25.0), wait=WAIT)
    assert refused.value.limit == "cpu"
    assert worker.call("spin", 0.01, budget=Budget(wall=10.0), wait=WAIT) > 0


def test_a_call_over_its_memory_is_refused_naming_it(worker: BoundedWorker) -> None:
    """An allocation past the child's address space fails there: `OverBudget("memory")`."""
    with pytest.raises(OverBudget, match="memory budget of 1024 MiB") as refused:
        worker.call("allocate", 2048, budget=Budget(wall=10.0), wait=WAIT)
    assert refused.value.limit == "memory"
    assert worker.call("allocate", 1, budget=Budget(wall=10.0), wait=WAIT) == 2**20


def test_a_call_over_its_wall_budget_is_killed_naming_it(worker: BoundedWorker) -> None:
    """A call that does not answer within its wall budget (sleeping: no CPU) is killed."""
    with pytest.raises(OverBudget, match=r"wall-clock budget of 0\.5 s") as refused:
        worker.call("sleep", 30.0, budget=Budget(wall=0.5), wait=WAIT)
    assert refused.value.limit == "wall"
    assert worker.call("sleep", 0.0, budget=Budget(wall=10.0), wait=WAIT) == 0.0


def test_an_answer_read_after_the_wall_budget_is_over_it(
    worker: BoundedWorker, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A parent thread descheduled past the budget (a loaded machine) finds the child's answer
    already waiting: the call is still over its budget, counted from the send, and the child,
    which answered, serves the next call."""
    from twin.web import upload_worker

    clock = iter([100.0, 100.6])  # the send, then the answer read 0.6 s later
    monkeypatch.setattr(upload_worker, "monotonic", lambda: next(clock))
    with pytest.raises(OverBudget, match=r"wall-clock budget of 0\.5 s") as refused:
        worker.call("sleep", 0.0, budget=Budget(wall=0.5), wait=WAIT)
    assert refused.value.limit == "wall"
    monkeypatch.undo()
    assert worker.call("sleep", 0.0, budget=Budget(wall=10.0), wait=0.1) == 0.0


def test_errors_come_back_by_kind() -> None:
    """A `TwinError` in the child is a `TwinError` here with its message; an unknown
    function a RuntimeError naming it; a closed worker a RuntimeError."""
    worker = BoundedWorker("twin.web.upload_records", size=1, memory=MEMORY)
    try:
        with pytest.raises(TwinError, match="NUL character on line 2"):
            worker.call("prescan", "a\nb\x00", budget=Budget(wall=10.0), wait=WAIT)
        with pytest.raises(RuntimeError, match="AttributeError"):
            worker.call("nope", budget=Budget(wall=10.0), wait=WAIT)
    finally:
        worker.close()
    with pytest.raises(RuntimeError, match="closed"):
        worker.call("prescan", "a", budget=Budget(wall=0.1))


def test_no_free_child_within_the_wait_is_busy(worker: BoundedWorker) -> None:
    """With its one child busy, a call that may wait 0.1 s raises `WorkerBusy` rather than
    queueing behind it."""
    import threading

    assert worker.call("sleep", 0.0, budget=Budget(wall=10.0), wait=WAIT) == 0.0  # one ready
    busy = threading.Thread(target=worker.call, args=("sleep", 2.0),
                            kwargs={"budget": Budget(wall=10.0), "wait": WAIT})  # fmt: skip
    busy.start()
    try:
        assert wait_for(worker._idle.empty, 5.0)
        with pytest.raises(WorkerBusy, match="busy"):
            worker.call("sleep", 0.0, budget=Budget(wall=10.0), wait=0.1)
    finally:
        busy.join(15)


def test_a_child_slow_to_import_is_waited_for_not_given_up(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A child whose import takes many of the start's polls (a loaded machine) is kept until it
    is ready, and then answers: no wall-clock deadline gives up a live child."""
    from twin.web import upload_worker

    monkeypatch.setattr(upload_worker, "START_POLL", 0.1)  # 25 polls of the 2.5 s import
    worker = BoundedWorker("tests.web.upload_slow_tasks", size=1, memory=MEMORY)
    try:
        assert worker.call("echo", 4.0, budget=Budget(wall=10.0), wait=WAIT) == 4.0
    finally:
        worker.close()


def test_a_child_that_cannot_start_is_retried_a_few_times_then_busy(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A child that exits before it is ready (its module fails to import) is replaced, up to
    START_ATTEMPTS times, each logged; then the pool stops trying and a call is `WorkerBusy`."""
    from twin.web.upload_worker import START_ATTEMPTS

    with caplog.at_level("WARNING", logger="twin.web.upload_worker"):
        worker = BoundedWorker("tests.web.no_such_module", size=1, memory=MEMORY)
        try:
            assert wait_for(lambda: "fail to start" in caplog.text, WAIT)
            attempts = [r for r in caplog.records if "exited before it was ready" in r.message]
            assert len(attempts) == START_ATTEMPTS
            with pytest.raises(WorkerBusy):
                worker.call("echo", 1.0, wait=0.5)
        finally:
            worker.close()

"""The executor's own cluster rests when idle (issue 29 item 8): the scheduler's and the
in-process worker's periodic callbacks run at `QUIET_DASK`'s periods, not Dask's 10-100 ms
defaults, and the cluster still runs tasks. (The CPU figure itself is a benchmark:
benchmarks/idle.py.)"""

from __future__ import annotations

import operator
from pathlib import Path

import dask
from dask.utils import parse_timedelta

from twin.runs.executor import IN_PROCESS, QUIET_DASK, Executor
from twin.vessel.rao import available_raos, load_raos, write_raos


def _ms(key: str) -> float:
    """[ms] a `QUIET_DASK` period."""
    return 1000.0 * parse_timedelta(QUIET_DASK[key])


def test_in_process_cluster_runs_its_callbacks_at_the_quiet_periods() -> None:
    """The in-process cluster's scheduler and worker callbacks run at the configured quiet
    intervals, no profiler, and it computes."""
    with Executor.start(IN_PROCESS, warm=False) as executor:
        scheduler = executor.cluster.scheduler
        (worker,) = executor.cluster.workers.values()
        tick = _ms("distributed.admin.tick.interval")
        monitor = _ms("distributed.admin.system-monitor.interval")
        assert scheduler.periodic_callbacks["tick"].callback_time == tick
        assert scheduler.periodic_callbacks["monitor"].callback_time == monitor
        assert worker.periodic_callbacks["tick"].callback_time == tick
        assert worker.periodic_callbacks["memory_monitor"].callback_time == _ms(
            "distributed.worker.memory.monitor-interval"
        )
        assert "profile" not in worker.periodic_callbacks  # no dashboard: no profiler
        assert executor.submit(operator.add, 2, 3).result(timeout=30) == 5


def test_quiet_settings_stay_with_the_cluster_not_the_process() -> None:
    """`dask.config.set` is scoped to making the cluster: other Dask users keep their config."""
    before = dask.config.get("distributed.admin.tick.interval")
    with Executor.start(IN_PROCESS, warm=False):
        assert dask.config.get("distributed.admin.tick.interval") == before


def _asks_for_a_worker_client() -> bool:
    """A task that asks for its worker's client, as a workability job does."""
    from distributed import worker_client

    with worker_client():
        return True


def test_two_overlapping_in_process_clusters_leave_no_scheduler_behind(tmp_path: Path) -> None:
    """Each in-process worker's client sets Dask's process-wide `scheduler`, and distributed
    restores it as each closes: two clusters closed in the order they started left
    "dask.distributed" with no client, and writing an RAO file (xarray) then raised "no Client
    active" (seen in a loaded CI run, after the workability tests)."""
    first = Executor.start(IN_PROCESS, warm=False)
    second = Executor.start(IN_PROCESS, warm=False)
    try:
        assert first.submit(_asks_for_a_worker_client).result(timeout=60)
        assert second.submit(_asks_for_a_worker_client).result(timeout=60)
        assert dask.config.get("scheduler", None) == "dask.distributed"  # what distributed sets
    finally:
        first.close()
        assert dask.config.get("scheduler", None) == "dask.distributed"  # the second still runs
        second.close()
    assert dask.config.get("scheduler", None) is None
    write_raos(load_raos(available_raos()[0]), tmp_path / "raos.nc")
    assert (tmp_path / "raos.nc").stat().st_size > 0


_NICE_CHILD = """
import os, sys
import twin.sim.engine
twin.sim.engine.warm = lambda: None  # the kernels are not what is tested here
from twin.runs.executor import _warm_plugin, lower_priority
start = os.nice(0)
_warm_plugin(freeze=False, nice=7).setup(None)  # a worker not of our own: left as it is
foreign = os.nice(0)
_warm_plugin(freeze=True, nice=7).setup(None)  # our own worker process
own = os.nice(0)
again = lower_priority(3)  # never less nice than it is
print(start, foreign, own, again)
"""


def test_our_own_workers_run_nicer_than_the_server() -> None:
    """The worker plugin of our own LocalCluster lowers the worker's priority to the nice
    asked for (batch work yields the CPU to the front end); a worker of another cluster, or in
    the caller's process, keeps its priority; a second call never raises the priority. In a
    child process: a niceness cannot be taken back."""
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-c", _NICE_CHILD], capture_output=True, text=True, timeout=120,
        check=True,
    ).stdout.split()  # fmt: skip
    start, foreign, own, again = map(int, out)
    assert foreign == start
    assert own == max(start, 7) and again == own


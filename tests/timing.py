"""Time limits that follow the machine's load, measured in the same run.

A test that bounds a duration (a server's shutdown, a lock's wait, a poll's patience) states
the bound for an idle machine and multiplies it by `slowdown()`: how many times longer than its
own CPU time a busy loop takes right now, or the load average per core, whichever is larger.
With two busy loops beside the suite on two cores (`make test-loaded`) both read 2-3, so the
limits stretch with the machine instead of failing; on an idle machine they are the stated
ones. Speed targets themselves live in benchmarks/, never here.
"""

from __future__ import annotations

import os
import statistics
import time

#: [s] CPU time of one probe of the machine: long enough to span a few scheduler slices
PROBE_CPU = 0.02
#: the most a limit is stretched: beyond this the test should fail, not wait
MOST = 10.0


def _probe() -> float:
    """wall / CPU time of a busy loop of about `PROBE_CPU` [s] of CPU."""
    wall0, cpu0 = time.perf_counter(), time.process_time()
    while time.process_time() - cpu0 < PROBE_CPU:
        sum(range(1000))
    return (time.perf_counter() - wall0) / max(time.process_time() - cpu0, 1e-9)


def slowdown() -> float:
    """[-] ≥ 1: how much slower than idle this machine serves a process now."""
    stolen = statistics.median(_probe() for _ in range(3))
    per_core = os.getloadavg()[0] / (os.cpu_count() or 1)
    return min(MOST, max(1.0, stolen, per_core))


def scaled(seconds: float) -> float:
    """[s] an idle machine's time limit, stretched by the load measured now."""
    return seconds * slowdown()

"""Functions a `twin.web.upload_worker.BoundedWorker` child runs in the upload tests: work that
goes over a CPU, memory or wall budget on purpose."""

from __future__ import annotations

import time


def spin(seconds: float) -> int:
    """Busy the CPU for `seconds` of wall time; the loop count."""
    end, count = time.monotonic() + seconds, 0
    while time.monotonic() < end:
        count += 1
    return count


def allocate(megabytes: int) -> int:
    """Touch `megabytes` MiB of memory; its size in bytes."""
    block = bytearray(megabytes * 1024 * 1024)
    return len(block)


def sleep(seconds: float) -> float:
    """Wait `seconds` without using the CPU."""
    time.sleep(seconds)
    return seconds

"""A module a `twin.web.upload_worker.BoundedWorker` child imports slowly on purpose (as pandas
imports on a loaded machine), for the start-up tests."""

from __future__ import annotations

import time

#: [s] the import's delay
DELAY = 2.5
time.sleep(DELAY)


def echo(value: float) -> float:
    """`value` back."""
    return value

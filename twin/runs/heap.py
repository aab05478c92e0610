"""The garbage collector in a long-running twin process: the server and its run workers.

Start-up leaves a few hundred thousand objects that live as long as the process: numba's
compiled kernels and type system, viser, FastAPI and pydantic models, the live session. The
cyclic collector walks every one of them in each full (oldest-generation) collection, about
0.2 s with the GIL held on our machines (benchmarks/run.py, "garbage collection"): the live
loop, the viewer and REST answers stand still meanwhile. Once started, a process moves them
into the collector's permanent generation (`gc.freeze`, as CPython's documentation describes
for long-lived start-up state), so a full collection walks only what came after; objects
made later are collected as before.
"""

from __future__ import annotations

import gc


def freeze_startup() -> int:
    """Collect what start-up left as garbage, then freeze every object alive now.

    Call it once a process is up (every kernel loaded, every server object built); calling it
    again later freezes what has accumulated since. Cycles among frozen objects that become
    garbage are not collected (their memory is held); start-up state lives as long as the
    process, so that costs nothing.

    Returns:
        How many objects the collector now leaves alone (`gc.get_freeze_count()`).
    """
    gc.collect()
    gc.freeze()
    return gc.get_freeze_count()

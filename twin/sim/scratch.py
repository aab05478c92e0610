"""A thread's scratch buffer for arrays that live within one call: a chunk's held targets.

A batch run keeps what it records (about 50 floats a sample and lane, its result), so the
memory of one part's temporaries is not there for the next to reuse: an array of several MB
allocated per chunk comes from fresh pages, which the kernel must fault in and zero — this
made the targets of a 16-lane part cost three times their arithmetic (docs/simulation.md).
An array that dies with its call takes its memory from the thread's buffer instead, grown to
the largest such array the thread has needed and reused from then on.
"""

from __future__ import annotations

import math
import threading

import numpy as np


class _Buffer(threading.local):
    """One float64 buffer per thread (`threading.local`: a thread sees only its own)."""

    def __init__(self) -> None:
        self.data = np.empty(0)


_BUFFER = _Buffer()


def scratch(shape: tuple[int, ...]) -> np.ndarray:
    """An uninitialised float64 array of `shape` in this thread's buffer, valid until this
    thread's next `scratch` call: for an array a function makes and drops before it returns
    (a kernel's input), never one it hands out or keeps.

    The buffer grows to the largest size asked for and is kept: at most a batch chunk's targets
    (`twin.sim.engine.BLOCK` steps × lanes × 18 floats, 38 MB) per thread that ran one.
    """
    size = math.prod(shape)
    if _BUFFER.data.size < size:
        _BUFFER.data = np.empty(size)
    return _BUFFER.data[:size].reshape(shape)

"""A thread's scratch buffers for arrays that live within one call: a chunk's held targets,
the tips its kernel hands to its records.

A batch run keeps what it records (about 50 floats a sample and lane, its result), so the
memory of one part's temporaries is not there for the next to reuse: an array of several MB
allocated per chunk comes from fresh pages, which the kernel must fault in and zero — this
made the targets of a 16-lane part cost three times their arithmetic (docs/simulation.md).
An array that dies with its call takes its memory from one of the thread's buffers instead,
one per use, grown to the largest such array the thread has needed and reused from then on.
"""

from __future__ import annotations

import math
import threading

import numpy as np


class _Buffers(threading.local):
    """float64 buffers by use, per thread (`threading.local`: a thread sees only its own)."""

    def __init__(self) -> None:
        self.data: dict[str, np.ndarray] = {}


_BUFFERS = _Buffers()


def scratch(use: str, shape: tuple[int, ...]) -> np.ndarray:
    """An uninitialised float64 array of `shape` in this thread's buffer for `use`, valid until
    this thread's next `scratch` call for the same use: for an array a function makes and drops
    before it returns (a kernel's input), never one it hands out or keeps.

    A buffer grows to the largest size asked for and is kept: at most a batch chunk's targets
    (`twin.sim.engine.BLOCK` steps × lanes × 18 floats, 38 MB) and its tips (15 floats, 31 MB)
    per thread that ran one.
    """
    size = math.prod(shape)
    buffer = _BUFFERS.data.get(use)
    if buffer is None or buffer.size < size:
        buffer = _BUFFERS.data[use] = np.empty(size)
    return buffer[:size].reshape(shape)

"""`freeze_startup`: a full collection afterwards walks only the objects made since, and still
collects their cycles."""

from __future__ import annotations

import gc
import weakref

from twin.runs.heap import freeze_startup
from twin.sim.engine import warm


class Node:
    """An object that can sit in a reference cycle."""

    other: Node | None = None


def test_a_full_collection_after_the_freeze_walks_only_new_objects_and_frees_their_cycles():
    """After freeze_startup a full collection walks under 1 % of the frozen objects and still frees
    new cycles."""
    warm()  # the kernels' objects are what a process starts with
    already = gc.get_freeze_count()
    try:
        frozen = freeze_startup() - already  # what was alive, earlier tests' garbage collected
        assert frozen > 10_000, frozen
        assert len(gc.get_objects()) < 0.01 * frozen  # what a full collection would walk
        a, b = Node(), Node()
        a.other, b.other = b, a
        gone = weakref.ref(a)
        del a, b
        assert gone() is not None  # only the collector can free a cycle
        gc.collect()
        assert gone() is None
    finally:
        gc.unfreeze()  # the test process goes on with its own objects collectable

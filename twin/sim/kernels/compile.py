"""Compiling the kernels with numba: `register_jitable` for the one-lane functions (plain
Python where numba cannot import) and `compile_runner` for a chunk runner, cached on disk under
a name that changes with its code.

numba's on-disk cache keys a function by its name, its own file's time stamp and its
signature: not by `parallel`, nor by the files of the functions it calls. A runner is
therefore compiled from a copy named `<name>_<parallel|serial>_<stamp>`, the stamp hashing the
sources of every module whose functions it compiles in (and of this one, which sets the
compile options), so the two modes do not overwrite each other's entry and an edit in another
kernel file is never served stale machine code.

Every runner releases the GIL (`nogil`): `simulate_many` runs groups of lanes on threads of
its own, each group's runners serial on its thread (`limit_threads`), so one group's Python
bookkeeping overlaps another's compiled steps.
"""

from __future__ import annotations

import hashlib
import importlib.util
import types
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

try:  # without numba the kernels are plain Python functions, run lane by lane
    from numba import prange
    from numba.extending import register_jitable

    #: `register_jitable` without numba's reference counting, for a one-lane function that
    #: allocates nothing (it only reads and writes arrays its caller owns): numba would
    #: otherwise increment and decrement the count of every array argument at each call, two
    #: atomic operations each, about a third of a hybrid step
    register_borrowing = register_jitable(_nrt=False)
except ImportError:  # pragma: no cover - exercised where numba is not installed
    prange = range

    def register_jitable(function: Callable) -> Callable:
        """Identity: the function runs as plain Python."""
        return function

    register_borrowing = register_jitable


def source_stamp(modules: Sequence[str]) -> str:
    """First 12 hex digits of the SHA-256 of the modules' sources (those found)."""
    digest = hashlib.sha256()
    for name in (*modules, __name__):
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.origin is not None and Path(spec.origin).is_file():
            digest.update(Path(spec.origin).read_bytes())
    return digest.hexdigest()[:12]


def compile_runner(runner: Callable, parallel: bool, modules: Sequence[str]) -> Callable:
    """`runner` compiled by numba (parallel over lanes or serial), cached on disk; the plain
    `runner` when numba cannot be imported (the interpreted engine: the same numbers)."""
    try:
        import numba
    except ImportError:  # pragma: no cover - exercised where numba is not installed
        return runner
    mode = "parallel" if parallel else "serial"
    name = f"{runner.__name__}_{mode}_{source_stamp(modules)}"
    function = types.FunctionType(runner.__code__, runner.__globals__, name)
    function.__qualname__ = name
    function.__doc__ = runner.__doc__
    return numba.njit(parallel=parallel, cache=True, nogil=True, error_model="numpy")(function)


def numba_threads() -> int:
    """numba's threads for parallel work started on this thread (1 without numba): numba keeps
    the count per thread, and `limit_threads` lowers it."""
    try:
        import numba
    except ImportError:  # pragma: no cover - exercised where numba is not installed
        return 1
    return numba.get_num_threads()


@contextmanager
def limit_threads(n: int | None) -> Iterator[None]:
    """Within: at most n numba threads for work started on this thread, so runners picked here
    are serial when n = 1 (`pick_runner`); None or no numba: no change."""
    try:
        import numba
    except ImportError:  # pragma: no cover - exercised where numba is not installed
        yield
        return
    if n is None:
        yield
        return
    before = numba.get_num_threads()
    numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
    try:
        yield
    finally:
        numba.set_num_threads(before)


def pick_runner(
    factory: Callable[[bool], Callable], plain: Callable, compiled: bool, lanes: int
) -> Callable:
    """The runner for `lanes` lanes: `factory(parallel)`, parallel over lanes when there are
    several and numba has several threads on this thread (`numba_threads`), or the `plain`
    function when not `compiled` (the interpreted engine)."""
    if not compiled:
        return plain
    return factory(lanes > 1 and numba_threads() > 1)

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
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

try:  # without numba the kernels are plain Python functions, run lane by lane
    from numba import prange
    from numba.core.errors import NumbaIRAssumptionWarning
    from numba.extending import register_jitable

    # numba's own consistency check of the IR after inlining (`register_inline`) warns that
    # an inlined temporary "is not in scope" and asks for a report; the code it compiles is
    # correct (the tests hold the kernels to the planner objects), so the check stays quiet
    warnings.filterwarnings("ignore", category=NumbaIRAssumptionWarning)

    #: `register_jitable` without numba's reference counting, for a one-lane function that
    #: allocates nothing (it only reads and writes arrays its caller owns): numba would
    #: otherwise increment and decrement the count of every array argument at each call, two
    #: atomic operations each, about a third of a hybrid step
    register_borrowing = register_jitable(_nrt=False)

    def register_inline(function: Callable) -> Callable:
        """`register_borrowing`, and inlined into its callers in numba's IR: a call between
        compiled functions passes each array as its whole struct (7 words and more) and LLVM
        does not inline across them, so the step's small functions paid more for the calls
        than for their arithmetic (measured: the hybrid step 0.78× the time, the record
        0.6×). Compiling costs more with each call site it is inlined at, so it is kept for
        the functions on the step's and the record's path. (A decorator per function: numba's
        `register_jitable(inline=...)` pops the option from its shared keywords on first use.)
        """
        return register_jitable(_nrt=False, inline="always")(function)
except ImportError:  # pragma: no cover - exercised where numba is not installed
    prange = range

    def register_jitable(function: Callable) -> Callable:
        """Identity: the function runs as plain Python."""
        return function

    register_borrowing = register_jitable
    register_inline = register_jitable


def source_stamp(modules: Sequence[str]) -> str:
    """First 12 hex digits of the SHA-256 of the modules' sources (those found), with this
    module's and `twin.spatial`'s (the lane primitives every kernel composes)."""
    digest = hashlib.sha256()
    for name in (*modules, __name__, "twin.spatial"):
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.origin is not None and Path(spec.origin).is_file():
            digest.update(Path(spec.origin).read_bytes())
    return digest.hexdigest()[:12]


def compile_runner(
    runner: Callable,
    parallel: bool,
    modules: Sequence[str],
    calls: Mapping[str, Callable] | None = None,
) -> Callable:
    """`runner` compiled by numba (parallel over lanes or serial), cached on disk; the plain
    `runner` when numba cannot be imported (the interpreted engine: the same numbers).

    Args:
        calls: compiled functions the runner calls by these global names (e.g. a parallel
            runner calling the serial one per lane), added to its module's globals.
    """
    try:
        import numba
    except ImportError:  # pragma: no cover - exercised where numba is not installed
        return runner
    mode = "parallel" if parallel else "serial"
    name = f"{runner.__name__}_{mode}_{source_stamp(modules)}"
    globals_ = {**runner.__globals__, **(calls or {})}
    function = types.FunctionType(runner.__code__, globals_, name)
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

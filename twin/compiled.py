"""How the kernels are built, cached and warmed: the one place to read.

**Built.** A kernel is plain Python over one lane (floats and small arrays) in the layer it
belongs to (`twin.spatial`, `twin.mechanisms`, `twin.planners`), marked

- `register_jitable`: numba compiles it into whatever compiled function calls it;
- `register_borrowing`: the same without numba's reference counting of its array arguments
  (for a function that allocates nothing);
- `register_inline`: borrowing, and inlined into its callers in numba's IR (the step's and the
  record's small functions).

Without numba each decorator is the identity, so the interpreted engine runs the very same
functions. The objects' vectorised API runs them too, over a batch of lanes (`LaneUfunc` below
for scalar lanes, `twin.batch.LaneBatch` for lanes of small arrays).

A chunk runner (`twin.sim.kernels.*_runner`, `run_*`) composes them and is compiled
by `compile_runner(runner, parallel)`: lazily, on its first call, with `nogil` (`simulate_many`
runs groups of lanes on threads of its own, each group's runners serial on its thread,
`limit_threads`, so one group's Python bookkeeping overlaps another's compiled steps). A runner
that calls another compiled runner (a parallel loop calling the serial runner per lane) names
it as an ordinary module global that its module assigns explicitly
(`serial_hybrid = compile_runner(run_hybrid, parallel=False)`): nothing is injected.

**Cached.** numba's on-disk cache keys a function by its qualified name, its own file's time
stamp and its signature: not by `parallel`, nor by the files of the functions it calls. A runner
is therefore compiled from a copy named `<name>_<parallel|serial>_<stamp>` (`compile_runner`,
the one place a function is copied), where the stamp (`source_stamp`) hashes the sources of
every module the runner reaches: the modules of the functions it calls, found by walking their
code's global names (`reachable_modules`), and the `twin` modules those import names from
(constants numba freezes into the machine code). Nothing is listed by hand, so an edit in any
file a kernel compiles in gives a new name and is never served stale machine code.

**Warmed.** `twin.sim.engine.warm` compiles (or loads from the cache) every runner by stepping
one short `Simulation` per planner family; `twin.sim.engine.warm_in_processes` splits that over
processes on a first start (minutes) and `twin.sim.engine.kernel_cache_filled` tells whether
the cache already holds them (a fraction of a second to load).
"""

from __future__ import annotations

import dis
import hashlib
import importlib.util
import threading
import types
import warnings
from collections.abc import Callable, Iterable, Iterator
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
    # the stand-ins have simpler types than numba's overloaded decorators and its prange class
    prange = range  # type: ignore[misc]  # range stands in for numba's prange class

    def register_jitable(function: Callable) -> Callable:  # type: ignore[no-redef]  # stand-in
        """Identity: the function runs as plain Python."""
        return function

    register_borrowing = register_jitable  # type: ignore[assignment]  # identity stand-in
    register_inline = register_jitable  # type: ignore[assignment]  # identity stand-in


#: packages whose modules a stamp may hash (numpy's and numba's own functions are not ours)
PACKAGE = "twin"


def _module_file(name: str) -> Path | None:
    """The source file of module `name`, if it is one of ours and has one."""
    if name != PACKAGE and not name.startswith(PACKAGE + "."):
        return None
    spec = importlib.util.find_spec(name)
    if spec is None or spec.origin is None or not Path(spec.origin).is_file():
        return None
    return Path(spec.origin)


def _codes(code: types.CodeType) -> Iterator[types.CodeType]:
    """A code object and the code nested in it (functions, classes, comprehensions)."""
    yield code
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            yield from _codes(const)


def _imported_modules(name: str) -> set[str]:
    """The `twin` modules module `name` imports names from (`from twin.x import A`, at any
    depth): where the constants it compiles in are defined.

    Read from the module's bytecode, not its syntax tree: CPython 3.11's `ast.parse` keeps one
    recursion counter per interpreter while it builds the tree's Python objects, so a parse here
    and another library's on another thread (e.g. `inspect.signature` of a builtin on an
    in-process Dask worker) raise "AST constructor recursion depth mismatch" (python/cpython
    gh-106905). `compile` to bytecode builds no Python tree.
    """
    path = _module_file(name)
    if path is None:
        return set()
    module = compile(path.read_text(encoding="utf-8"), str(path), "exec", dont_inherit=True)
    found = set()
    for code in _codes(module):
        instructions = list(dis.get_instructions(code))
        # `from m import a` compiles to LOAD_CONST level, LOAD_CONST fromlist, IMPORT_NAME m
        for at in range(2, len(instructions)):
            level, fromlist, instruction = instructions[at - 2 : at + 1]
            if (
                instruction.opname == "IMPORT_NAME"
                and level.argval == 0
                and fromlist.argval is not None
                and _module_file(instruction.argval) is not None
            ):
                found.add(instruction.argval)
    return found


def _code_names(code: types.CodeType) -> Iterator[str]:
    """The global names a code object and the code nested in it (comprehensions) read."""
    for nested in _codes(code):
        yield from nested.co_names


def reachable_modules(functions: Iterable[Callable]) -> list[str]:
    """The `twin` modules a compiled runner is built from, sorted: those of `functions`, of
    every function their code reaches through its globals (numba dispatchers through their
    `py_func`), and the `twin` modules those import names from."""
    seen: set[int] = set()
    modules: set[str] = set()
    stack = list(functions)
    while stack:
        item = stack.pop()
        function = getattr(item, "py_func", item)  # a numba dispatcher: its Python function
        if not isinstance(function, types.FunctionType) or id(function) in seen:
            continue
        seen.add(id(function))
        if _module_file(function.__module__) is None:
            continue
        modules.add(function.__module__)
        for name in _code_names(function.__code__):
            value = function.__globals__.get(name)
            if value is not None:
                stack.append(value)
    for name in list(modules):
        modules |= _imported_modules(name)
    return sorted(modules)


#: a lazy compile is not thread-safe (`simulate_many`'s threads build their first runners at once)
_COMPILING = threading.RLock()


def source_stamp(functions: Iterable[Callable]) -> str:
    """First 12 hex digits of the SHA-256 of the sources of `reachable_modules(functions)` and
    of this module (which sets the compile options)."""
    digest = hashlib.sha256()
    for name in (*reachable_modules(functions), __name__):
        path = _module_file(name)
        if path is not None:
            digest.update(name.encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def compile_runner(runner: Callable, parallel: bool, *_unused: object) -> Callable:
    """`runner` compiled by numba (parallel over lanes or serial), lazily on its first call and
    cached on disk under `<name>_<parallel|serial>_<source_stamp>` (module doc); the plain
    `runner` when numba cannot be imported (the interpreted engine: the same numbers).

    The copy shares `runner`'s module globals, so a parallel runner calls the serial one by
    the module-level name its module gave it.

    Args:
        runner: the chunk runner, a plain function of this package.
        parallel: compile its `prange` loops as parallel loops.
        _unused: accepted and ignored (the hand-kept module lists of earlier versions: the
            stamp now finds the modules itself).
    """
    try:
        import numba
    except ImportError:  # pragma: no cover - exercised where numba is not installed
        return runner
    mode = "parallel" if parallel else "serial"
    name = f"{runner.__name__}_{mode}_{source_stamp([runner])}"
    function = types.FunctionType(runner.__code__, runner.__globals__, name)
    function.__qualname__ = name
    function.__doc__ = runner.__doc__
    return numba.njit(parallel=parallel, cache=True, nogil=True, error_model="numpy")(function)


class LaneUfunc:
    """A one-lane scalar function (floats in, one float out) as a numpy ufunc over broadcast
    arrays, so an object's vectorised API runs the very function the kernels compile in:
    `numba.vectorize`d on the first call (cached on disk: a fraction of a second to load, about
    a second to compile), `np.vectorize` without numba (the same function, interpreted).

    Attributes:
        function: the lane function (`register_inline` / `register_jitable` or plain).
        n_args: its number of float arguments.
    """

    def __init__(self, function: Callable[..., float], n_args: int) -> None:
        self.function, self.n_args = function, n_args
        self._ufunc: Callable | None = None
        self.__doc__ = function.__doc__

    def __call__(self, *args: object) -> object:
        if self._ufunc is None:
            with _COMPILING:
                self._build()
        assert self._ufunc is not None
        return self._ufunc(*args)

    def _build(self) -> None:
        if self._ufunc is None:  # another thread may have built it while this one waited
            try:
                import numba
            except ImportError:  # pragma: no cover - exercised where numba is not installed
                import numpy as np

                self._ufunc = np.vectorize(self.function, otypes=[float])
            else:
                signature = f"float64({', '.join(['float64'] * self.n_args)})"
                self._ufunc = numba.vectorize([signature], cache=True)(self.function)


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
    # numba.config sets its attributes from the environment at import: no static declaration
    limit = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]
    numba.set_num_threads(min(n, limit))
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

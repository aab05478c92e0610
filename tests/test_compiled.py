"""twin.compiled: the on-disk cache key follows every module a runner is built from."""

from __future__ import annotations

import ast
import gc
import importlib
import sys
import textwrap
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from twin import compiled
from twin.compiled import reachable_modules, source_stamp


def test_the_hybrid_runner_reaches_the_layers_it_composes() -> None:
    """The parallel runner reaches, through the serial one, every layer whose lane functions
    the step compiles in, and the layout whose constants it freezes."""
    from twin.sim.kernels.hybrid_runner import run_hybrid_lanes

    modules = set(reachable_modules([run_hybrid_lanes]))
    expected = {
        "twin.compiled", "twin.spatial", "twin.mechanisms.legs", "twin.mechanisms.gangway",
        "twin.mechanisms.hybrid", "twin.planners.linalg", "twin.planners.weights",
        "twin.planners.limits", "twin.planners.tasks", "twin.planners.differential_step",
        "twin.planners.allocation_step", "twin.planners.qp_step", "twin.sim.kernels.hybrid",
        "twin.sim.kernels.records", "twin.sim.kernels.layout",
    }  # fmt: skip
    assert expected <= modules


@pytest.fixture
def package(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A package `h3stamp` of two modules: `a.runner` calls `b.lane` and reads `c.LIMIT`."""
    root = tmp_path / "h3stamp"
    root.mkdir()
    (root / "__init__.py").write_text("")
    (root / "a.py").write_text(textwrap.dedent("""
        from h3stamp.b import lane
        from h3stamp.c import LIMIT

        def runner(x):
            return lane(x) + LIMIT
    """))
    (root / "b.py").write_text("def lane(x):\n    return 2 * x\n")
    (root / "c.py").write_text("LIMIT = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(compiled, "PACKAGE", "h3stamp")
    yield root
    for name in [m for m in sys.modules if m.startswith("h3stamp")]:
        del sys.modules[name]


@pytest.mark.parametrize("edited", ["b.py", "c.py"])
def test_an_edit_in_a_reached_module_changes_the_stamp(package: Path, edited: str) -> None:
    """Editing the module of a function the runner calls (b), or of a constant it imports (c),
    gives another stamp: numba's cache cannot serve the old machine code."""
    runner = importlib.import_module("h3stamp.a").runner
    assert {"h3stamp.a", "h3stamp.b", "h3stamp.c"} <= set(reachable_modules([runner]))
    before = source_stamp([runner])
    path = package / edited
    path.write_text(path.read_text().replace("2", "3").replace("1", "4"))
    assert source_stamp([runner]) != before


def test_the_stamp_is_read_while_another_thread_parses_python() -> None:
    """CPython 3.11's `ast.parse` shares a recursion counter between threads (gh-106905): a
    stamp read by parsing failed, 1 CI run in about 12, while an in-process Dask worker parsed.
    Here other threads parse in a loop, switched as often as the interpreter allows (a
    collection's callback at every few allocations yields the GIL inside the parse), while
    stamps are read: each read succeeds and finds the same modules. (A race, so a chance: the
    stamp read by `ast.parse` failed this test in 2 of 5 runs, and in 0 of 5 with the fix.)"""
    from twin.sim.kernels.hybrid_runner import run_hybrid_lanes

    expected = reachable_modules([run_hybrid_lanes])
    source = Path(compiled.__file__).read_text(encoding="utf-8")
    read: list[list[str]] = []
    errors: list[BaseException] = []
    done = threading.Event()

    def parse() -> None:
        while not done.is_set():
            try:
                ast.parse(source)
            except SystemError:  # the other parsers' race with each other, not the stamp's
                pass

    def stamp() -> None:
        try:
            for _ in range(10):
                read.append(reachable_modules([run_hybrid_lanes]))
        except BaseException as error:  # any failure of the read is the finding
            errors.append(error)

    def yield_gil(_phase: str, _info: dict) -> None:
        time.sleep(0)

    interval, thresholds = sys.getswitchinterval(), gc.get_threshold()
    sys.setswitchinterval(1e-6)
    gc.set_threshold(50)
    gc.callbacks.append(yield_gil)
    parsers = [threading.Thread(target=parse) for _ in range(2)]
    readers = [threading.Thread(target=stamp) for _ in range(2)]
    try:
        for thread in (*parsers, *readers):
            thread.start()
        for thread in readers:
            thread.join()
    finally:
        done.set()
        for thread in parsers:
            thread.join()
        gc.callbacks.remove(yield_gil)
        gc.set_threshold(*thresholds)
        sys.setswitchinterval(interval)
    assert errors == []
    assert read == [expected] * 20

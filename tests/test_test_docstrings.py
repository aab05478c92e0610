"""Every test in tests/ says in a docstring which property it checks (issue 41 item 7).

An ast walk over every Python file under tests/ finds each `def test_*` (nested and async ones
too) and fails on any without a docstring, naming it as `path:line name`.
"""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parent
ROOT = TESTS.parent


def undocumented(source: str) -> list[tuple[int, str]]:
    """(line, name) of every function named `test*` in `source` without a docstring."""
    return [
        (node.lineno, node.name)
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        and node.name.startswith("test")
        and ast.get_docstring(node) is None
    ]


def missing_by_file() -> dict[str, list[tuple[int, str]]]:
    """Each file under tests/ (relative to the repo root) with its undocumented tests."""
    found = {}
    for path in sorted(TESTS.rglob("*.py")):
        missing = undocumented(path.read_text(encoding="utf-8"))
        if missing:
            found[path.relative_to(ROOT).as_posix()] = missing
    return found


def test_the_walk_finds_undocumented_tests_nested_and_async_ones_included() -> None:
    """The walk reports exactly the test functions without a docstring, at any depth, async
    included, and ignores helpers and documented tests."""
    source = '''
def test_bare():
    assert True

def test_documented():
    """A property."""

async def test_async():
    pass

def helper():
    pass

class TestGroup:
    def test_method(self):
        def test_inner():
            pass
'''
    assert sorted(undocumented(source)) == [
        (2, "test_bare"), (8, "test_async"), (15, "test_method"), (16, "test_inner")
    ]  # fmt: skip


def test_every_test_has_a_docstring() -> None:
    """No test function in tests/ lacks a docstring."""
    lines = [f"{f}:{line} {name}" for f, found in missing_by_file().items() for line, name in found]
    assert not lines, "tests without a docstring saying the property they check:\n" + "\n".join(
        lines
    )

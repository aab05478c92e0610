"""No function in twin/ is over `MAX_LINES` lines (issue 29, "Measure and report": the largest
functions, none over 80 lines).

A function's size is counted from its `def` line to its last line, docstring, comments and blank
lines included, decorators not; methods and nested functions count on their own (a nested
function's lines count in its parent's too). Run as a script, `python tests/test_function_size.py
[LINES]`, it lists every function over LINES (default `MAX_LINES`), largest first.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path
from typing import NamedTuple

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "twin"
#: the most lines a function may have
MAX_LINES = 80
#: "path:qualname" of functions allowed over `MAX_LINES`, each with why
ALLOWED: set[str] = set()  # none now; an entry names a function and says why, in a comment


class Function(NamedTuple):
    where: str  # "path:qualname", path relative to the repo root
    line: int  # its `def` line, 1-based
    lines: int  # from `def` to its last line


def functions(source: str, path: str) -> list[Function]:
    """Every function and method in `source` (nested ones too), with its size in lines."""
    found: list[Function] = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = prefix + child.name
                size = (child.end_lineno or child.lineno) - child.lineno + 1
                found.append(Function(f"{path}:{name}", child.lineno, size))
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(source), "")
    return found


def package_functions() -> list[Function]:
    """`functions` of every module in twin/."""
    found: list[Function] = []
    for module in sorted(PACKAGE.rglob("*.py")):
        path = module.relative_to(ROOT).as_posix()
        found += functions(module.read_text(encoding="utf-8"), path)
    return found


def over(limit: int, found: list[Function]) -> list[Function]:
    """The functions of `found` over `limit` lines, largest first."""
    return sorted((f for f in found if f.lines > limit), key=lambda f: (-f.lines, f.where))


def test_the_measure_counts_from_def_to_the_last_line() -> None:
    """Decorators are not counted, the docstring and blank lines are; methods and nested
    functions are named by their qualified name; 80 lines pass and 81 do not."""

    def statements(count: int, indent: str) -> str:
        return "\n".join(f"{indent}x{i} = {i}" for i in range(count))

    source = (
        "@decorator\n"
        "@another(1)\n"
        f'def at_limit():\n    """Doc."""\n\n{statements(MAX_LINES - 3, "    ")}\n\n\n'
        f"class Holder:\n    def method(self):\n{statements(MAX_LINES, 8 * ' ')}\n\n"
        "def outer():\n    def inner():\n        return 1\n    return inner\n"
    )
    sizes = {f.where: (f.line, f.lines) for f in functions(source, "m.py")}
    assert sizes["m.py:at_limit"] == (3, MAX_LINES)
    assert sizes["m.py:Holder.method"][1] == MAX_LINES + 1
    assert sizes["m.py:outer.inner"] == (sizes["m.py:outer"][0] + 1, 2)
    assert [f.where for f in over(MAX_LINES, functions(source, "m.py"))] == ["m.py:Holder.method"]


def test_no_function_in_twin_is_over_the_limit() -> None:
    """Every function in twin/ is at most `MAX_LINES` lines, but those `ALLOWED` with a reason."""
    found = package_functions()
    assert len(found) > 100  # the walk found the package
    large = [f for f in over(MAX_LINES, found) if f.where not in ALLOWED]
    named = ", ".join(f"{f.where} (line {f.line}: {f.lines} lines)" for f in large)
    assert not large, f"functions over {MAX_LINES} lines (split them by what they do): {named}"


def test_every_allowance_is_still_needed() -> None:
    """An `ALLOWED` entry names a function that exists and is still over the limit: once it is
    split, its allowance goes."""
    sizes = {f.where: f.lines for f in package_functions()}
    stale = sorted(
        f"{where} ({sizes[where]} lines)" if where in sizes else f"{where} (not found)"
        for where in ALLOWED
        if sizes.get(where, 0) <= MAX_LINES
    )
    assert not stale, "remove from ALLOWED: " + ", ".join(stale)


if __name__ == "__main__":
    limit = int(sys.argv[1]) if len(sys.argv) > 1 else MAX_LINES
    for function in over(limit, package_functions()):
        print(f"{function.lines:5d}  {function.where}  (line {function.line})")

"""No integer offset constant in twin/: rows and accumulators are read by field name.

Issue 41 item 3: every float row the kernels fill (accumulators, result rows, diagnostics,
targets, scratch blocks) is a structured dtype (`twin.planners.parameters.record_dtype`) read by
name. This test scans twin/ with `ast` for a module-level name bound to an int literal (or to int
arithmetic of such names) that is used inside a subscript — a hand-numbered position in a row.
Counts and sizes (`N_*`, `MAX_*`, `*_SIZE`), enum values (`KIND_*`, `METHOD_*`, `LAW_*`, …) and
fault bits (`FAULT_*`) are not offsets and are left out.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from twin.errors import TwinError
from twin.planners.parameters import as_record, as_records, record_dtype, row_size

TWIN = Path(__file__).resolve().parents[1] / "twin"

#: names that hold a count, a size, an enum value or a bit, never a position in a row
NOT_OFFSETS = ("N_", "MAX_", "KIND_", "FAULT_", "METHOD_", "LAW_", "MECHANISM_")


def _is_count(name: str) -> bool:
    """Whether a constant's name says it is a count, size, enum value or bit."""
    return name.startswith(NOT_OFFSETS) or name.endswith("_SIZE")


def _int_expression(node: ast.expr, known: set[str]) -> bool:
    """Whether node is an int literal, or int arithmetic of int literals and `known` names."""
    if isinstance(node, ast.Constant):
        return type(node.value) is int
    if isinstance(node, ast.Name):
        return node.id in known
    if isinstance(node, ast.UnaryOp):
        return _int_expression(node.operand, known)
    if isinstance(node, ast.BinOp):
        return _int_expression(node.left, known) and _int_expression(node.right, known)
    return False


def _module_name(path: Path) -> str:
    """`twin.x.y` of a file under twin/."""
    parts = path.relative_to(TWIN.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _int_constants(tree: ast.Module) -> set[str]:
    """The module-level names bound to int expressions (`_int_expression`), unpacking too."""
    found: set[str] = set()
    for node in tree.body:
        targets: list[ast.expr] = []
        value: ast.expr | None = None
        if isinstance(node, ast.Assign):
            targets, value = node.targets, node.value
        elif isinstance(node, ast.AnnAssign) and node.value is not None:
            targets, value = [node.target], node.value
        for target in targets:
            if isinstance(target, ast.Name) and value is not None:
                if _int_expression(value, found):
                    found.add(target.id)
            elif isinstance(target, ast.Tuple) and isinstance(value, ast.Tuple):
                for name, item in zip(target.elts, value.elts, strict=False):
                    if isinstance(name, ast.Name) and _int_expression(item, found):
                        found.add(name.id)
    return found


def _positions(node: ast.expr | None) -> list[ast.expr]:
    """The names and attributes of a subscript's index that stand for a position in the row:
    the index itself, a tuple's items, a term of a sum or difference, a slice's start and a
    slice's end unless it is `start + length` (the length is a count: `x[i : i + BLOCK]`).
    A comparison, a call or a negated count (`x[-COUNT:]`) is not a position."""
    if isinstance(node, (ast.Name, ast.Attribute)):
        return [node]
    if isinstance(node, ast.Tuple):
        return [found for item in node.elts for found in _positions(item)]
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
        return _positions(node.left) + _positions(node.right)
    if isinstance(node, ast.Slice):
        upper = node.upper
        if (isinstance(upper, ast.BinOp) and isinstance(upper.op, ast.Add)
                and node.lower is not None and ast.dump(upper.left) == ast.dump(node.lower)):
            upper = upper.left  # start + length: the start is checked, the length is a count
        return _positions(node.lower) + _positions(upper)
    return []


def _offset_uses() -> list[str]:
    """Every use of an offset constant inside a subscript in twin/, as "file:line NAME"."""
    trees = {_module_name(p): (p, ast.parse(p.read_text(encoding="utf-8")))
             for p in sorted(TWIN.rglob("*.py"))}  # fmt: skip
    constants = {module: {n for n in _int_constants(tree) if not _is_count(n)}
                 for module, (_, tree) in trees.items()}  # fmt: skip
    uses = []
    for module, (path, tree) in trees.items():
        names = set(constants[module])  # own constants and those imported by name
        modules: dict[str, str] = {}  # alias → module, for `alias.NAME`
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module in trees:
                for alias in node.names:
                    if alias.name in constants[node.module]:
                        names.add(alias.asname or alias.name)
                    if f"{node.module}.{alias.name}" in trees:
                        modules[alias.asname or alias.name] = f"{node.module}.{alias.name}"
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name in trees and alias.asname:
                        modules[alias.asname] = alias.name
        for node in ast.walk(tree):
            if not isinstance(node, ast.Subscript):
                continue
            for item in _positions(node.slice):
                if isinstance(item, ast.Name) and item.id in names:
                    uses.append(f"{path.relative_to(TWIN.parent)}:{item.lineno} {item.id}")
                elif (isinstance(item, ast.Attribute) and isinstance(item.value, ast.Name)
                      and item.attr in constants.get(modules.get(item.value.id, ""), ())):
                    uses.append(f"{path.relative_to(TWIN.parent)}:{item.lineno} {item.attr}")
    return uses


def test_no_integer_offset_constant() -> None:
    """No module-level int constant of twin/ is used as a position inside a subscript."""
    assert _offset_uses() == []


def test_scan_finds_an_offset() -> None:
    """The scan sees int constants (literals, unpacking, arithmetic) and their positions."""
    tree = ast.parse("A, B = 0, 1\nC = B + 2\nN_ROWS = 4\nD = 1.5\nE = f(1)\n")
    assert _int_constants(tree) == {"A", "B", "C", "N_ROWS"}
    assert _is_count("N_ROWS") and _is_count("ROW_SIZE") and not _is_count("C")
    names = {
        code: [ast.unparse(n) for n in _positions(ast.parse(code, mode="eval").body.slice)]
        for code in ("x[A + j]", "x[..., A : A + 9]", "x[i : i + BLOCK]", "x[-COUNT:]",
                     "x[x > LIMIT]", "x[k, m.B]")
    }  # fmt: skip
    assert names == {"x[A + j]": ["A", "j"], "x[..., A : A + 9]": ["A", "A"],
                     "x[i : i + BLOCK]": ["i", "i"], "x[-COUNT:]": [], "x[x > LIMIT]": [],
                     "x[k, m.B]": ["k", "m.B"]}  # fmt: skip


def test_record_dtype_reads_a_float_row_by_name() -> None:
    """A `record_dtype` row views a float row: fields by name, nested records, padding."""
    inner = record_dtype((("a", 1), ("b", 2)))
    dtype = record_dtype((("x", 1), ("inner", inner), ("y", 3)), size=8)
    assert row_size(inner) == 3 and row_size(dtype) == 8
    row = np.arange(8.0)
    record = as_record(row, dtype)
    assert record.x == 0.0 and record.inner.a == 1.0 and list(record.y) == [4.0, 5.0, 6.0]
    record.inner.b[1] = -1.0
    assert row[3] == -1.0
    assert as_records(np.zeros((2, 3, 8)), dtype)["y"].shape == (2, 3, 3)
    with pytest.raises(TwinError):
        record_dtype((("x", 1), ("x", 1)))
    with pytest.raises(TwinError):
        record_dtype((("x", 5),), size=4)

"""The import graph of twin/: no circles. Every `import` counts, at module level or inside a
function (an import deferred into a function to dodge a circle still closes it); only imports
under `if TYPE_CHECKING:` (annotations, never run) are left out. `from package import name`
is an edge to the submodule `package.name` where that is a module, else to the package."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "twin"


def module_names() -> dict[str, Path]:
    """Dotted name → file of every module of the package."""
    out = {}
    for path in ROOT.rglob("*.py"):
        parts = path.relative_to(ROOT.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


def imports_of(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The package's modules that `name` imports when run (TYPE_CHECKING blocks left out)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()

    def walk(nodes: list[ast.stmt]) -> None:
        for node in nodes:
            if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
                walk(node.orelse)
                continue
            if isinstance(node, ast.Import):
                found.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join([*anchor, base] if base else anchor)
                for alias in node.names:
                    sub = f"{base}.{alias.name}"
                    found.add(sub if sub in modules else base)
            for field in ("body", "orelse", "finalbody", "handlers"):
                inner = getattr(node, field, None)
                if isinstance(inner, list):
                    walk(inner)

    walk(ast.parse(path.read_text(encoding="utf-8")).body)
    return {m for m in found if m in modules and m != name}


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan 1972)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_twin_has_no_import_circles() -> None:
    """No two modules of twin/ import each other, directly or through others."""
    modules = module_names()
    graph = {name: imports_of(name, path, modules) for name, path in modules.items()}
    assert sum(len(v) for v in graph.values()) > 100  # the graph was read
    assert circles(graph) == []


@pytest.mark.parametrize(
    ("graph", "expected"),
    [
        ({"a": {"b"}, "b": {"a"}, "c": set()}, [["a", "b"]]),
        ({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}, [["a", "b", "c"]]),
        ({"a": {"b"}, "b": set()}, []),
    ],
)
def test_the_circle_finder_finds_circles(graph: dict, expected: list) -> None:
    """The component search reports a two-module and a three-module circle, and none in a
    chain (so an empty answer above means something)."""
    assert circles(graph) == expected


def test_a_deferred_import_counts_and_type_checking_does_not(tmp_path: Path) -> None:
    """An import inside a function is an edge; one under `if TYPE_CHECKING:` is not."""
    source = tmp_path / "m.py"
    source.write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from pkg import b\n"
        "def f():\n    from pkg import c\n"
    )
    modules = {"pkg.m": source, "pkg.b": source, "pkg.c": source}
    assert imports_of("pkg.m", source, modules) == {"pkg.c"}


#: the packages below the engine; the web layer reads them through `twin.sim.registries`
BELOW_SIM = ("twin.mechanisms", "twin.planners", "twin.sea", "twin.vessel")


def layer_edges(importer: str, imported: tuple[str, ...]) -> list[tuple[str, str]]:
    """(module, import) pairs where a module of the package `importer` imports a module of one
    of the packages `imported`."""
    modules = module_names()

    def inside(name: str, packages: tuple[str, ...]) -> bool:
        return any(name == p or name.startswith(p + ".") for p in packages)

    return sorted(
        (name, target)
        for name, path in modules.items()
        if inside(name, (importer,))
        for target in imports_of(name, path, modules)
        if inside(target, imported)
    )


def test_web_reads_mechanisms_planners_sea_and_vessel_only_through_sim() -> None:
    """No module of twin.web imports twin.mechanisms, planners, sea or vessel (it reads their
    registries through `twin.sim.registries`), while twin.sim does (so the check can fail)."""
    assert layer_edges("twin.web", BELOW_SIM) == []
    assert layer_edges("twin.sim", BELOW_SIM)


def test_the_viewer_is_handed_access_and_connections_by_the_server() -> None:
    """twin.web.viewer imports neither the access policy nor the connection guards when run."""
    assert layer_edges("twin.web.viewer", ("twin.web.access", "twin.web.connections")) == []
    assert layer_edges("twin.web.viewer", ("twin.web.viewer",))  # the viewer's modules were read


def test_the_engine_layer_never_imports_the_runs_layer() -> None:
    """No module of twin.sim imports twin.runs (executor, sweeps, workability, onboard, claims
    sit above the engine), while twin.runs does import twin.sim (so the check can fail)."""
    assert layer_edges("twin.sim", ("twin.runs",)) == []
    assert layer_edges("twin.runs", ("twin.sim",))

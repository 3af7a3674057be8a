"""No import circle inside the package (STYLE.md, "dependencies one way").

The graph: one node per module of ``envs``, ``baselines`` and ``agents`` (a package is its
``__init__``), an edge from a module to each module of these packages it imports, by any import
statement, those inside functions and under ``TYPE_CHECKING`` too (read with :mod:`ast`, nothing
runs).  ``from package import name`` is an edge to the submodule ``package.name`` where one exists,
else to the package.  The graph must have no cycle; the test names the modules of each one it finds.
Importing ``a.b.c`` runs ``a/__init__.py`` and ``a/b/__init__.py`` as well, but those implicit edges
are Python's, not the design's, and are left out.  The direction between the packages (``envs``
imports neither other; ``baselines`` not ``agents``) is held by ``test_boundaries.py``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PACKAGES = ("envs", "baselines", "agents")


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules(root: Path = REPO) -> dict[str, Path]:
    """Every module of the packages by its dotted name."""
    return {_module_name(path, root): path for package in PACKAGES for path in sorted((root / package).rglob("*.py"))}


def _imported(node: ast.AST, name: str, is_package: bool, known: dict[str, Path]) -> list[str]:
    """The modules of ``known`` that one import statement of module ``name`` imports."""
    if isinstance(node, ast.Import):
        targets = [alias.name for alias in node.names]
    elif isinstance(node, ast.ImportFrom):
        base = node.module or ""
        if node.level:
            parts = name.split(".") if is_package else name.split(".")[:-1]
            parts = parts[: len(parts) - (node.level - 1)]
            base = ".".join([*parts, *([base] if base else [])])
        targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base for alias in node.names]
    else:
        return []
    found = []
    for target in targets:
        while target and target not in known:  # ``import a.b.c`` of a name inside a module: its module
            target = target.rpartition(".")[0]
        if target:
            found.append(target)
    return found


def import_graph(root: Path = REPO) -> dict[str, set[str]]:
    """``{module: modules it imports}`` over the packages' modules."""
    known = modules(root)
    graph: dict[str, set[str]] = {}
    for name, path in known.items():
        tree = ast.parse(path.read_text(), filename=str(path))
        is_package = path.name == "__init__.py"
        graph[name] = {target for node in ast.walk(tree) for target in _imported(node, name, is_package, known)
                       if target != name}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in sorted(graph.get(node, ())):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return sorted(found)


def test_no_import_cycle_in_the_package() -> None:
    found = cycles(import_graph())
    assert not found, "import circles: " + "; ".join(" <-> ".join(component) for component in found)


def test_the_graph_sees_lazy_relative_and_type_checking_imports(tmp_path: Path) -> None:
    package = tmp_path / "agents" / "part"
    package.mkdir(parents=True)
    (tmp_path / "agents" / "__init__.py").write_text("")
    (package / "__init__.py").write_text("from . import one\n")
    (package / "one.py").write_text("def f():\n    from agents.part.two import g\n")
    (package / "two.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .one import f\n")
    graph = import_graph(tmp_path)
    assert graph["agents.part"] == {"agents.part.one"}
    assert graph["agents.part.one"] == {"agents.part.two"}
    assert graph["agents.part.two"] == {"agents.part.one"}
    assert cycles(graph) == [["agents.part.one", "agents.part.two"]]


@pytest.mark.parametrize(("edges", "expected"), [
    ({"a": {"b"}, "b": {"c"}, "c": set()}, []),
    ({"a": {"b"}, "b": {"a"}, "c": {"a"}}, [["a", "b"]]),
    ({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"e"}, "e": {"d"}}, [["a", "b", "c"], ["d", "e"]]),
])
def test_cycles_are_the_components_of_more_than_one_module(edges: dict[str, set[str]], expected: list[list[str]]) -> None:
    assert cycles(edges) == expected

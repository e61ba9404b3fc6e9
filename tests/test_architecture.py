"""The import graph of ``src/noisybolt``: no cycles, and no private name imported from
another module. Imports count wherever they are written (inside functions too), except
under ``if TYPE_CHECKING:``, which never runs."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"


def _modules() -> dict[str, tuple[Path, bool]]:
    modules = {}
    for path in (SRC / "noisybolt").rglob("*.py"):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        package = parts[-1] == "__init__"
        modules[".".join(parts[:-1] if package else parts)] = (path, package)
    return modules


def _runtime_imports(tree: ast.AST) -> list[ast.Import | ast.ImportFrom]:
    """Every import statement except those under ``if TYPE_CHECKING:``."""
    found: list[ast.Import | ast.ImportFrom] = []

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import | ast.ImportFrom):
            found.append(node)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return found


def import_graph() -> tuple[dict[str, set[str]], list[tuple[str, str, str]]]:
    """Module -> the noisybolt modules it imports; and every (importer, module, name)
    that imports a private name (one ``_x``, not a dunder) from another module."""
    modules = _modules()
    edges: dict[str, set[str]] = {name: set() for name in modules}
    private = []
    for name, (path, package) in modules.items():
        for node in _runtime_imports(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                edges[name] |= {a.name for a in node.names if a.name in modules}
                continue
            base = name.split(".") if package else name.split(".")[:-1]
            if node.level:
                base = base[: len(base) - node.level + 1]
                target = ".".join([*base, *([node.module] if node.module else [])])
            else:
                target = node.module or ""
            for alias in node.names:
                if f"{target}.{alias.name}" in modules:  # a submodule
                    edges[name].add(f"{target}.{alias.name}")
                elif target in modules:
                    edges[name].add(target)
                    dunder = alias.name.startswith("__") and alias.name.endswith("__")
                    if alias.name.startswith("_") and not dunder:
                        private.append((name, target, alias.name))
    return edges, private


def find_cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def strong(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(edges[v]):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            strong(v)
    return cycles


def test_the_checks_see_a_cycle_and_a_private_import_when_there_is_one() -> None:
    assert find_cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert find_cycles({"a": {"b"}, "b": set()}) == []
    edges, _ = import_graph()
    assert "noisybolt.experiments.sweeps" in edges["noisybolt.experiments.report"]
    assert "noisybolt.experiments.report" in edges["noisybolt.experiments.table1"]


def test_no_import_cycle_in_src() -> None:
    edges, _ = import_graph()
    assert find_cycles(edges) == []


#: None left: bolt/engine.py made check_fluents and env_flags public.
KNOWN_PRIVATE_IMPORTS: set[tuple[str, str, str]] = set()


def test_no_private_name_is_imported_across_modules() -> None:
    _, private = import_graph()
    new = sorted(set(private) - KNOWN_PRIVATE_IMPORTS)
    assert new == [], "import a public name, or make the name public where it is defined"


@pytest.mark.parametrize("module", ["noisybolt.experiments.report"])
def test_report_imports_no_experiment(module: str) -> None:
    edges, _ = import_graph()
    assert not {"noisybolt.experiments.table1", "noisybolt.experiments.case4"} & edges[module]

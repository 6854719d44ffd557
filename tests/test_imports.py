"""The import graph of lab/ has no cycles (issue 13): each module can be read after the modules it
imports."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAB = ROOT / "lab"
PACKAGE = LAB / "controller"


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path, known: set[str]) -> set[str]:
    """The modules of `known` that `path` imports at module level or inside functions."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        found.update(name for name in names if name in known)
    return found


def import_graph(package: Path) -> dict[str, set[str]]:
    """Module → the modules of the package it imports. Importing `a.b.c` also runs the
    `__init__` of `a.b`, so a module depends on the packages above what it imports."""
    paths = {module_name(p): p for p in package.rglob("*.py")}
    known = set(paths)
    graph = {}
    for name, path in paths.items():
        edges = set()
        for target in imports_of(path, known):
            parts = target.split(".")
            edges.update(
                ".".join(parts[:i])
                for i in range(1, len(parts) + 1)
                if ".".join(parts[:i]) in known
            )
        edges.discard(name)
        # A package's own __init__ runs before its submodules: not a dependency back on it.
        graph[name] = {e for e in edges if not name.startswith(e + ".")}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph as a list of modules, or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return [*path[path.index(nxt) :], nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return None


def test_the_controller_imports_form_no_cycle() -> None:
    graph = import_graph(PACKAGE)
    assert "lab.controller.tasks.base" in graph  # the walk found the package
    cycle = find_cycle(graph)
    assert cycle is None, " → ".join(cycle or [])


def test_the_imports_of_all_of_lab_form_no_cycle() -> None:
    graph = import_graph(LAB)
    assert {"lab.ui.app", "lab.ui.panel", "lab.world.session"} <= set(graph)
    cycle = find_cycle(graph)
    assert cycle is None, " → ".join(cycle or [])


def test_a_cycle_is_found_when_there_is_one() -> None:
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None

"""The package's import graph: the classroom's modules import one another in one direction, with no circle."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "autonomy"


def imports_of(path: Path) -> set[str]:
    """The modules of the package a file imports, at its top or inside a function."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found |= {f"{node.module}.{alias.name}" for alias in node.names}  # `from package import module`
    return {name for name in found if name.startswith("autonomy.")}


def graph(folder: str) -> dict[str, set[str]]:
    """Each module of ``autonomy/FOLDER`` and the modules of that folder it imports."""
    modules = {
        f"autonomy.{folder}.{path.stem}": path for path in (PACKAGE / folder).glob("*.py") if path.stem != "__init__"
    }
    return {name: {m for m in imports_of(path) if m in modules and m != name} for name, path in modules.items()}


def circle(edges: dict[str, set[str]]) -> list[str]:
    """A circle of imports in ``edges`` (empty: none), found by a depth-first walk."""
    state: dict[str, str] = {}
    stack: list[str] = []

    def visit(name: str) -> list[str]:
        state[name] = "open"
        stack.append(name)
        for other in sorted(edges.get(name, ())):
            if state.get(other) == "open":
                return [*stack[stack.index(other) :], other]
            if other not in state and (found := visit(other)):
                return found
        state[name] = "done"
        stack.pop()
        return []

    for name in sorted(edges):
        if name not in state and (found := visit(name)):
            return found
    return []


def test_the_classroom_s_modules_import_one_another_with_no_circle():
    edges = graph("classroom")
    assert circle(edges) == [], " -> ".join(circle(edges))
    # the results are plain data every output reads: they import nothing of the classroom's
    assert edges["autonomy.classroom.results"] == set()
    # the outputs read the results, never an executor (nor the job, which the executors run)
    for output in ("report", "gradebook", "gradescope"):
        for executor in ("pool", "cluster", "child", "job"):
            assert f"autonomy.classroom.{executor}" not in edges[f"autonomy.classroom.{output}"], (output, executor)

    # the request composes the job, the executors and the outputs: nothing of the classroom's imports it
    assert [name for name, imported in edges.items() if "autonomy.classroom.request" in imported] == []


def test_no_module_of_the_classroom_is_over_500_lines():
    long = {path.name: n for path in (PACKAGE / "classroom").glob("*.py") if (n := path.read_text().count("\n")) > 500}
    assert long == {}, long


def test_the_check_finds_a_circle_when_there_is_one():
    assert circle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert circle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) == []

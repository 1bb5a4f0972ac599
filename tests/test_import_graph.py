"""The import graph of ``src/grainflow``: no cycle, and scenarios stay below the io layer.

Layers, bottom to top: models and kernels; the engine (engine/, walls/, insertion/, state.py,
frame.py); scenarios; analyses; io and the command line (config/, io/, runner.py, cli.py,
sweep/, plotting/, studies/, progress.py). Imports run downwards only.

Every ``import``/``from ... import`` of a grainflow module counts, wherever it is: at module
level, inside a function, or under ``if TYPE_CHECKING:`` (a type-only import is still a
dependency a reader has to follow, and the first step towards a real one). ``from a.b import
c`` is an edge to ``a.b.c`` if that is a module, else to ``a.b`` (a package's
``__init__``). Imports done by ``importlib.import_module`` on a computed name (the lazy public
names of ``grainflow/__init__.py``, the scenario plug-ins, builders named by
``"module:function"`` strings) are not edges. Run this file directly to print the graph's
cycles: ``python3 tests/test_import_graph.py``.
"""

from __future__ import annotations

import ast
from collections import deque
from collections.abc import Iterator
from pathlib import Path

import grainflow

ROOT = Path(grainflow.__file__).resolve().parent

#: Modules that no module under ``grainflow.scenarios`` may import (nor their submodules).
ABOVE_SCENARIOS = ("grainflow.runner", "grainflow.io", "grainflow.plotting",
                   "grainflow.studies", "grainflow.sweep", "grainflow.cli")


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def modules() -> dict[str, Path]:
    """Every module of the package by dotted name."""
    return {module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def imports(name: str, source: str, known: set[str], *, is_package: bool = False
            ) -> Iterator[tuple[str, int]]:
    """``(imported module, line)`` of every import in the source of module ``name``."""
    tree = ast.parse(source)
    package = name if is_package else name.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: from . import x, from ..a import b
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            for alias in node.names:
                sub = f"{module}.{alias.name}"
                yield (sub if sub in known else module), node.lineno


def import_graph() -> dict[str, dict[str, int]]:
    """``graph[a][b]``: line of ``a``'s first import of ``b`` (grainflow modules only)."""
    mods = modules()
    known = set(mods)
    graph: dict[str, dict[str, int]] = {}
    for name, path in mods.items():
        edges = graph.setdefault(name, {})
        for target, line in imports(name, path.read_text(), known,
                                    is_package=path.name == "__init__.py"):
            if target == name or not (target == "grainflow" or target.startswith("grainflow.")):
                continue
            if target not in known:
                raise AssertionError(f"{path}:{line}: imports {target}, which is not a module "
                                     "of src/grainflow")
            edges.setdefault(target, line)
    return graph


def strongly_connected(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """Tarjan's strongly connected components (iterative) with more than one module, or one
    module importing itself."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out: list[list[str]] = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1 or node in graph[node]:
                        out.append(sorted(component))
    return sorted(out)


def cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """Cycles ``[a, b, ..., a]`` that together use every import inside every strongly
    connected component (one shortest cycle through each import not yet shown)."""
    found: list[list[str]] = []
    for component in strongly_connected(graph):
        members = set(component)
        covered: set[tuple[str, str]] = set()
        for a in component:
            for b in sorted(graph[a]):
                if b not in members or (a, b) in covered:
                    continue
                path = _shortest_path(graph, b, a, members)
                cycle = [a, *path]
                covered.update(zip(cycle, cycle[1:]))
                k = cycle.index(min(cycle[:-1]))
                found.append(cycle[k:-1] + cycle[:k + 1])
    return found


def _shortest_path(graph: dict[str, dict[str, int]], start: str, goal: str,
                   members: set[str]) -> list[str]:
    previous: dict[str, str | None] = {start: None}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        if node == goal:
            break
        for child in sorted(graph[node]):
            if child in members and child not in previous:
                previous[child] = node
                queue.append(child)
    path, node = [], goal
    while node is not None:
        path.append(node)
        node = previous[node]
    return path[::-1]


def _show(graph: dict[str, dict[str, int]], cycle: list[str]) -> str:
    return " -> ".join(f"{a} (line {graph[a][b]})" for a, b in zip(cycle, cycle[1:])) \
        + f" -> {cycle[-1]}"


# -------------------------------------------------------------------------------- tests
def test_every_kind_of_import_is_an_edge() -> None:
    source = """
from __future__ import annotations
import importlib
from typing import TYPE_CHECKING
import p.m1
from p import m2, CONSTANT
from p.sub import f
from . import m3
from .sub.m4 import g
if TYPE_CHECKING:
    from p.m5 import T
def later():
    from p.m6 import h
    importlib.import_module("p.m7")  # computed at run time: not an edge
"""
    known = {"p", "p.m1", "p.m2", "p.m3", "p.m5", "p.m6", "p.m7", "p.sub", "p.sub.m4"}
    found = {m for m, _ in imports("p.m0", source, known) if m.startswith("p")}
    assert found == {"p", "p.m1", "p.m2", "p.m3", "p.m5", "p.m6", "p.sub", "p.sub.m4"}
    assert {m for m, _ in imports("p.sub", "from . import m4\nfrom .. import m1", known,
                                  is_package=True)} == {"p.sub.m4", "p.m1"}
    graph = import_graph()
    assert "grainflow.walls.force" in graph["grainflow.walls"]


def test_cycle_search_finds_a_planted_cycle() -> None:
    graph = {"a": {"b": 1}, "b": {"c": 1, "d": 1}, "c": {"a": 1}, "d": {}, "e": {"e": 1}}
    assert strongly_connected(graph) == [["a", "b", "c"], ["e"]]
    assert cycles(graph) == [["a", "b", "c", "a"], ["e", "e"]]


def test_no_import_cycle() -> None:
    graph = import_graph()
    found = cycles(graph)
    assert not found, ("import cycles in src/grainflow (line N: where a module imports the "
                       "next one):\n") + "\n".join(
        _show(graph, c) for c in found)


def test_scenarios_do_not_import_the_io_layer() -> None:
    graph = import_graph()
    bad = [f"{a} (line {line}) imports {b}"
           for a, edges in sorted(graph.items())
           if a == "grainflow.scenarios" or a.startswith("grainflow.scenarios.")
           for b, line in sorted(edges.items())
           if any(b == top or b.startswith(top + ".") for top in ABOVE_SCENARIOS)]
    assert not bad, "scenarios must not import the io/CLI layer:\n" + "\n".join(bad)


if __name__ == "__main__":
    g = import_graph()
    for c in cycles(g):
        print(_show(g, c))

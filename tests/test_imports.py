"""Every module of ``planner`` and ``app`` imports on its own, and no module imports itself back
through others.

The import graph is read from the source with ``ast``; an import counts wherever it stands: at the
top, under ``if TYPE_CHECKING:`` or inside a function. ``from package import name`` counts as an
import of the submodule when ``name`` is one, else of the package.

Importing each module alone takes a process of its own. One interpreter per module would load
torch, pybullet and the web stack 130 times over, so one interpreter (``python -m
tests.test_imports``) imports the third-party modules the package names and no module of its
own, then forks a child per module (as many at once as there are CPUs): each child starts with
no ``planner`` or ``app`` module loaded and imports its one module.
"""

from __future__ import annotations

import ast
import contextlib
import importlib
import json
import os
import subprocess
import sys
import tempfile
import traceback
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("planner", "app")
# Modules that are not meant to be imported alone, and why.
NOT_ALONE = {
    "planner.store.migrations.env": "Alembic's script: it runs the migrations as Alembic loads it",
}


@dataclass(frozen=True)
class Edge:
    target: str
    line: int  # where the importing module names it


def modules(root: Path = ROOT) -> dict[str, Path]:
    """Module name -> source file, for every module of the packages."""
    out = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


def _known(name: str, known: Mapping[str, Path]) -> str | None:
    """The deepest module of the packages that ``name`` is or lies in (None: none)."""
    while name and name not in known:
        name = name.rpartition(".")[0]
    return name or None


def _named(node: ast.Import | ast.ImportFrom, module: str, is_package: bool) -> Iterator[str]:
    """The dotted names an import statement of ``module`` loads."""
    if isinstance(node, ast.Import):
        yield from (alias.name for alias in node.names)
        return
    base = node.module or ""
    if node.level:
        package = module if is_package else module.rpartition(".")[0]
        parent = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
        base = f"{parent}.{base}" if base else parent
    for alias in node.names:
        yield f"{base}.{alias.name}"  # a submodule, or a name that _known takes back to base


def import_graph(root: Path = ROOT) -> dict[str, list[Edge]]:
    """Module -> the modules of the packages it imports (itself left out)."""
    known = modules(root)
    graph: dict[str, list[Edge]] = {}
    for module, path in known.items():
        is_package = path.name == "__init__.py"
        edges: dict[str, Edge] = {}
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import | ast.ImportFrom):
                for name in _named(node, module, is_package):
                    target = _known(name, known)
                    if target is not None and target != module and target not in edges:
                        edges[target] = Edge(target, node.lineno)
        graph[module] = sorted(edges.values(), key=lambda e: e.target)
    return graph


def third_party(root: Path = ROOT) -> list[str]:
    """The modules outside the packages that the packages import (by ``from X import``, X)."""
    known = modules(root)
    out = set()
    for path in known.values():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                names = [node.module]
            else:
                continue
            out.update(n for n in names if n.partition(".")[0] not in PACKAGES)
    return sorted(out)


def cycles(graph: Mapping[str, Sequence[Edge]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for edge in graph.get(v, ()):
            w = edge.target
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
    return sorted(out)


def describe(component: Sequence[str], graph: Mapping[str, Sequence[Edge]]) -> str:
    """One cycle through the component's first module, each import with its file and line."""
    files = modules()
    inside = set(component)
    start = component[0]
    ways: dict[str, list[tuple[str, Edge]]] = {start: []}  # module -> imports from start to it
    frontier = [start]
    while frontier:  # breadth first: the shortest way back to start
        later = []
        for module in frontier:
            for edge in graph[module]:
                if edge.target == start:
                    hops = [*ways[module], (module, edge)]
                    return start + "".join(
                        f" -> {e.target} ({files[m].relative_to(ROOT)}:{e.line})" for m, e in hops
                    )
                if edge.target in inside and edge.target not in ways:
                    ways[edge.target] = [*ways[module], (module, edge)]
                    later.append(edge.target)
        frontier = later
    raise AssertionError(f"no cycle through {start}")


def test_no_import_cycles() -> None:
    graph = import_graph()
    assert graph["planner.api"] and graph["app.main"]  # the graph was read
    found = [describe(c, graph) for c in cycles(graph)]
    assert not found, "import cycles:\n" + "\n".join(found)


def test_cycles_finds_a_cycle_and_names_every_module_in_it() -> None:
    graph = {
        "a": [Edge("b", 1)],
        "b": [Edge("c", 2)],
        "c": [Edge("a", 3), Edge("d", 4)],
        "d": [],
    }
    assert cycles(graph) == [["a", "b", "c"]]


def test_every_module_imports_alone(tmp_path: Path) -> None:
    assert set(NOT_ALONE) <= set(modules())
    names = sorted(set(modules()) - set(NOT_ALONE))
    out = tmp_path / "imports.json"
    done = subprocess.run(
        [sys.executable, "-m", "tests.test_imports", str(out), *names],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0 and out.is_file(), done.stderr
    failed = json.loads(out.read_text())
    assert not failed, "\n\n".join(f"import {name} alone:\n{log}" for name, log in failed.items())


# --- the forking importer (python -m tests.test_imports OUT MODULE...) -------------------------


def _import_alone(name: str, log: Path) -> int:
    """Fork a child that imports ``name`` with its output going to ``log``; its pid."""
    pid = os.fork()
    if pid:
        return pid
    code = 1
    try:
        fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        importlib.import_module(name)
        code = 0
    except BaseException:
        traceback.print_exc()
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def _main(out: Path, names: Sequence[str]) -> None:
    for name in third_party():
        with contextlib.suppress(Exception):  # a child that needs it reports the error itself
            importlib.import_module(name)
    own = sorted(m for m in sys.modules if m.partition(".")[0] in PACKAGES)
    if own:
        raise SystemExit(f"third-party imports loaded modules of the packages: {own}")
    jobs = max(2, os.cpu_count() or 1)
    pending = list(reversed(names))
    running: dict[int, str] = {}
    failed: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as logs:
        while pending or running:
            while pending and len(running) < jobs:
                name = pending.pop()
                running[_import_alone(name, Path(logs) / name)] = name
            pid, status = os.wait()
            name = running.pop(pid)
            if os.waitstatus_to_exitcode(status) != 0:
                log = Path(logs) / name
                failed[name] = log.read_text(errors="replace") if log.is_file() else ""
                failed[name] += f"(exit status {os.waitstatus_to_exitcode(status)})"
    out.write_text(json.dumps(failed, indent=1))


if __name__ == "__main__":
    _main(Path(sys.argv[1]), sys.argv[2:])

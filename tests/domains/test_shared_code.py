"""The kitchen and the Panda write what they share once, in planner/domains/manipulation: no run
of six or more lines stands in both packages (issue 55). And what knows a particular domain or
robot stays with it: the generic layers import no domain's or robot's package, the shared
manipulation code is imported by the kitchen and the Panda only, and a domain imports no other
domain but that shared code.

Lines are compared as the ``duplicates`` tool compares them (its identical runs): blank lines,
comments, the lines that start an import and lines of lone brackets are passed over (the names
a long import lists still count), and white space is folded. A run found in both is named by
its places, to be written once in the shared package.
"""

from __future__ import annotations

import ast
import io
import re
import subprocess
import sys
import tokenize
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

import planner.domains
from tests.test_imports import Edge, import_graph

DOMAINS = Path(planner.domains.__file__).resolve().parent
PAIR = ("kitchen", "panda")  # the two domains that share planner/domains/manipulation
SHARED = "planner.domains.manipulation"
# Modules of planner/domains and planner/robots that every domain and robot use: generic.
GENERIC = {"planner.domains.registry", "planner.domains.spec", "planner.robots.base"}
RUN = 6  # lines: a run this long in both is a repeat
_PUNCTUATION = re.compile(r"[()\[\]{},:;]+")

Place = tuple[str, int]  # file (relative to planner/domains), line number


def significant_lines(source: str) -> list[tuple[int, str]]:
    """The lines that count, numbered from 1, comments cut and white space folded."""
    lines = source.splitlines()
    skipped: set[int] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import | ast.ImportFrom):
            skipped.add(node.lineno)
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            row, col = token.start
            lines[row - 1] = lines[row - 1][:col]
    out = []
    for number, line in enumerate(lines, start=1):
        text = " ".join(line.split())
        if number in skipped or not text or _PUNCTUATION.fullmatch(text):
            continue
        out.append((number, text))
    return out


def runs(package: str) -> dict[tuple[str, ...], Place]:
    """Every run of RUN significant lines of the package's modules, with its first place."""
    found: dict[tuple[str, ...], Place] = {}
    for path in sorted((DOMAINS / package).rglob("*.py")):
        lines = significant_lines(path.read_text(encoding="utf-8"))
        name = path.relative_to(DOMAINS).as_posix()
        for i in range(len(lines) - RUN + 1):
            window = tuple(text for _, text in lines[i : i + RUN])
            found.setdefault(window, (name, lines[i][0]))
    return found


def repeats(a: str, b: str) -> Iterator[tuple[Place, Place]]:
    """The places where a run of package ``a`` stands again in package ``b``, the first of each
    stretch of overlapping runs."""
    theirs = runs(b)
    last: Place | None = None
    for window, place in sorted(runs(a).items(), key=lambda item: item[1]):
        if window in theirs:
            if last is None or last[0] != place[0] or place[1] - last[1] > 2 * RUN:
                yield place, theirs[window]
            last = place


def test_the_comparison_finds_a_repeat() -> None:
    """The check can fail: six lines in two sources are found, comments and imports aside."""
    body = "".join(f"    total += {i}  # step {i}\n" for i in range(RUN))
    a = significant_lines(f"from os import (\n    sep,\n)\ndef f():\n    total = 0\n{body}")
    b = significant_lines(f"def g():\n    # the same steps\n{body.replace('  #', '#')}")
    assert [t for _, t in a[3:]] == [t for _, t in b[1:]]
    assert a[:2] == [(2, "sep,"), (4, "def f():")] and len(a) == RUN + 3


def test_the_kitchen_and_the_panda_repeat_no_six_lines() -> None:
    found = [f"{p}:{n} ~ {q}:{m}" for (p, n), (q, m) in repeats(*PAIR)]
    assert not found, (
        f"runs of {RUN} lines stand in both the kitchen and the Panda (write them once, in "
        "planner/domains/manipulation): " + "; ".join(found)
    )


def _particular(module: str) -> str | None:
    """The domain's or robot's package a module belongs to (None: a generic module)."""
    package = ".".join(module.split(".")[:3])
    kind = package.rpartition(".")[0]
    if package.count(".") == 2 and kind in ("planner.domains", "planner.robots"):
        return None if package in GENERIC else package
    return None


def knowledge_errors(graph: Mapping[str, Sequence[Edge]]) -> list[str]:
    """Each import that carries a particular domain's or robot's knowledge out of its package."""
    wrong = []
    for module, edges in graph.items():
        mine = _particular(module)
        for edge in edges:
            theirs = _particular(edge.target)
            if theirs is None or theirs == mine:
                continue
            place = f"{module} imports {edge.target} (line {edge.line})"
            if mine is None:
                wrong.append(f"{place}: generic code knows no particular domain or robot")
            elif theirs == SHARED and mine not in (f"planner.domains.{d}" for d in PAIR):
                wrong.append(f"{place}: only the {' and the '.join(PAIR)} share {SHARED}")
            elif theirs.startswith("planner.domains.") and theirs != SHARED:
                wrong.append(f"{place}: a domain imports no other domain")
            elif mine == SHARED or mine.startswith("planner.robots."):
                wrong.append(f"{place}: reach a robot through the registry (planner.robots)")
    return wrong


def test_the_knowledge_check_finds_what_leaks() -> None:
    graph = {
        "planner.search.queries": [Edge("planner.domains.kitchen.world", 3)],
        "planner.domains.line": [Edge(f"{SHARED}.world", 4)],
        "planner.domains.panda.view": [Edge("planner.domains.kitchen.view", 5)],
        f"{SHARED}.world": [Edge("planner.robots.pr2.model", 6), Edge("planner.robots", 7)],
        "planner.domains.kitchen.world": [Edge(f"{SHARED}.world", 8), Edge("planner.sim", 9)],
    }
    found = knowledge_errors(graph)
    assert [f.split(" (line ")[0] for f in found] == [
        "planner.search.queries imports planner.domains.kitchen.world",
        "planner.domains.line imports planner.domains.manipulation.world",
        "planner.domains.panda.view imports planner.domains.kitchen.view",
        "planner.domains.manipulation.world imports planner.robots.pr2.model",
    ]


def test_particular_domains_and_robots_stay_in_their_packages() -> None:
    graph = import_graph()
    assert any(e.target.startswith(SHARED) for e in graph["planner.domains.kitchen.world"])
    wrong = knowledge_errors(graph)
    assert not wrong, "\n".join(wrong)


def test_loading_the_domains_starts_no_simulator() -> None:
    """The samplers and the validator (pybullet, OMPL) are imported when first used."""
    code = (
        "import sys, planner.domains.kitchen, planner.domains.panda\n"
        "print(sorted(m for m in ('pybullet', 'ompl') if m in sys.modules))"
    )
    root = DOMAINS.parents[1]
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=root, capture_output=True, text=True, check=True
    )
    assert done.stdout.strip() == "[]"

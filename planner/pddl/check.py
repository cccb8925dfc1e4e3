"""``tamp check``: load PDDL(Stream) files as the planner would and list what was inferred.

Files are told apart by their header (``(define (domain ...``, ``(define (stream ...``,
``(define (problem ...``); a folder stands for the ``.pddl`` files in it and in its
``problems/``. A stream or problem file is read against the domain file of its folder (or the
only domain file given), and a problem against that domain with what its folder's stream file
declared, as a domain folder is loaded. Every declaration inferred from a use (PDDLStream's
leniency, :class:`~planner.pddl.structs.Inference`) is listed with its place, so the files can
be tightened until ``--strict`` loads them too.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from planner.pddl.errors import PDDLError
from planner.pddl.parser import (
    load_domain,
    load_problem,
    load_streams,
    with_stream_declarations,
)
from planner.pddl.sexpr import read_file
from planner.pddl.structs import Domain, Inference, StreamSet

_HEADER = re.compile(r"\(\s*define\s*\(\s*([A-Za-z]+)", re.IGNORECASE)
KINDS = ("domain", "stream", "problem")


@dataclass(frozen=True)
class FileCheck:
    """One file: what it is, whether it loads, what it holds and what was inferred from it."""

    path: str
    kind: str  # domain, stream, problem, or "unknown"
    error: str | None  # why it does not load; None when it does
    summary: str = ""  # what it holds, e.g. "domain kitchen: 5 actions, 14 predicates"
    inferred: tuple[Inference, ...] = field(default=())

    @property
    def ok(self) -> bool:
        return self.error is None

    def to_json(self) -> dict[str, Any]:
        return {
            "path": self.path,
            "kind": self.kind,
            "ok": self.ok,
            "error": self.error,
            "summary": self.summary,
            "inferred": [
                {
                    "kind": i.kind,
                    "name": i.name,
                    "arity": i.arity,
                    "file": i.file,
                    "line": i.line,
                    "column": i.column,
                    "message": i.message,
                }
                for i in self.inferred
            ],
        }


def file_kind(path: Path) -> str:
    """``domain``, ``stream`` or ``problem`` by the file's header; ``unknown`` otherwise."""
    try:
        text = read_file(path)
    except (OSError, PDDLError):
        return "unknown"
    body = "\n".join(line.split(";", 1)[0] for line in text.splitlines())
    found = _HEADER.search(body)
    kind = found.group(1).lower() if found else ""
    return kind if kind in KINDS else "unknown"


def expand(paths: Iterable[str | Path]) -> list[Path]:
    """Files as given, a folder as its ``.pddl`` files (and those of its ``problems/``)."""
    out: list[Path] = []
    for raw in paths:
        path = Path(raw).expanduser()
        if path.is_dir():
            found = sorted(path.glob("*.pddl")) + sorted((path / "problems").glob("*.pddl"))
            if not found:
                raise FileNotFoundError(f"{path}: no .pddl files in this folder")
            out += found
        elif path.is_file():
            out.append(path)
        else:
            raise FileNotFoundError(f"{path}: no such file or folder")
    return list(dict.fromkeys(out))


def _domain_summary(domain: Domain) -> str:
    def count(n: int, what: str) -> str:
        return f"{n} {what}{'' if n == 1 else 's'}"

    parts = [count(len(domain.actions), "action"), count(len(domain.predicates), "predicate")]
    if domain.derived:
        parts.append(f"{len(domain.derived)} derived")
    if domain.functions:
        parts.append(count(len(domain.functions), "function"))
    return f"domain {domain.name}: {', '.join(parts)}"


def _stream_summary(streams: StreamSet) -> str:
    kinds: dict[str, int] = {}
    for s in streams.streams:
        label = "test" if s.kind == "stream" and s.is_test else s.kind
        kinds[label] = kinds.get(label, 0) + 1
    if streams.functions:
        kinds["function"] = len(streams.functions)
    held = ", ".join(f"{n} {k}{'' if n == 1 else 's'}" for k, n in kinds.items()) or "nothing"
    return f"stream {streams.name}: {held}"


def check_files(paths: Sequence[str | Path], *, strict: bool = False) -> list[FileCheck]:
    """Load every file of ``paths`` (see the module docstring); never raises for a file that
    does not load: its :class:`FileCheck` says why."""
    files = expand(paths)
    kinds = {f: file_kind(f) for f in files}
    checks: dict[Path, FileCheck] = {}
    domains: dict[Path, Domain] = {}
    for f in files:
        if kinds[f] == "unknown":
            checks[f] = FileCheck(
                str(f), "unknown", "not a PDDL domain, stream or problem file (no '(define (...')"
            )
        elif kinds[f] == "domain":
            try:
                domain = load_domain(f, strict=strict)
            except PDDLError as exc:
                checks[f] = FileCheck(str(f), "domain", str(exc))
                continue
            domains[f] = domain
            checks[f] = FileCheck(str(f), "domain", None, _domain_summary(domain), domain.inferred)
    given_domains = [f for f in files if kinds[f] == "domain"]

    def domain_for(f: Path) -> tuple[Path | None, str | None]:
        here = [d for d in given_domains if d.parent == f.parent]
        if f.parent.name == "problems":
            here = here or [d for d in given_domains if d.parent == f.parent.parent]
        chosen = here if len(here) == 1 else given_domains if len(given_domains) == 1 else []
        if not chosen:
            return None, (
                "no domain file to read it against: give its domain file too"
                if not given_domains
                else "several domain files could be its domain: give one with it"
            )
        return chosen[0], None

    extended: dict[Path, Domain] = dict(domains)
    for f in files:
        if kinds[f] != "stream":
            continue
        home, why = domain_for(f)
        if home is None:
            checks[f] = FileCheck(str(f), "stream", why)
            continue
        if home not in domains:
            checks[f] = FileCheck(str(f), "stream", f"its domain {home} does not load")
            continue
        try:
            streams = load_streams(f, domains[home], strict=strict)
        except PDDLError as exc:
            checks[f] = FileCheck(str(f), "stream", str(exc))
            continue
        extended[home] = with_stream_declarations(extended[home], streams)
        checks[f] = FileCheck(str(f), "stream", None, _stream_summary(streams), streams.inferred)
    for f in files:
        if kinds[f] != "problem":
            continue
        home, why = domain_for(f)
        if home is None:
            checks[f] = FileCheck(str(f), "problem", why)
            continue
        if home not in extended:
            checks[f] = FileCheck(str(f), "problem", f"its domain {home} does not load")
            continue
        try:
            problem = load_problem(f, extended[home], strict=strict)
        except PDDLError as exc:
            checks[f] = FileCheck(str(f), "problem", str(exc))
            continue
        summary = (
            f"problem {problem.name}: {len(problem.objects)} objects, {len(problem.init)} "
            f"initial facts"
        )
        checks[f] = FileCheck(str(f), "problem", None, summary, problem.inferred)
    return [checks[f] for f in files]

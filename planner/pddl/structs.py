"""Core types of the problem language: frozen dataclasses with checked invariants.

Terms are plain strings: a variable starts with ``?``, anything else is an object name.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

OBJECT_TYPE = "object"  # the root of every type hierarchy
EQUALITY = "="  # the built-in equality predicate


def is_variable(term: str) -> bool:
    """True for ``?x``-style variables."""
    return term.startswith("?")


@dataclass(frozen=True, order=True)
class Atom:
    """A predicate applied to terms, e.g. ``(on ?b table)``."""

    predicate: str
    args: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.predicate:
            raise ValueError("an atom needs a predicate name")

    def substitute(self, mapping: Mapping[str, str]) -> Atom:
        """Replace every term found in ``mapping``; others stay."""
        return Atom(self.predicate, tuple(mapping.get(a, a) for a in self.args))

    @property
    def variables(self) -> tuple[str, ...]:
        return tuple(a for a in self.args if is_variable(a))

    def __str__(self) -> str:
        return f"({' '.join((self.predicate, *self.args))})"


@dataclass(frozen=True, order=True)
class Literal:
    """An atom or its negation; ``(= ?a ?b)`` is an atom with predicate ``=``."""

    atom: Atom
    positive: bool = True

    @property
    def is_equality(self) -> bool:
        return self.atom.predicate == EQUALITY

    def substitute(self, mapping: Mapping[str, str]) -> Literal:
        return Literal(self.atom.substitute(mapping), self.positive)

    def __str__(self) -> str:
        return str(self.atom) if self.positive else f"(not {self.atom})"


@dataclass(frozen=True)
class TypedName:
    """A parameter, object or type name with its (parent) type."""

    name: str
    type: str = OBJECT_TYPE

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("empty name")


@dataclass(frozen=True)
class Predicate:
    name: str
    params: tuple[TypedName, ...] = ()

    @property
    def arity(self) -> int:
        return len(self.params)


def _check_unique(names: list[str], message: str) -> None:
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ValueError(f"{message} {dupes}")


def _check_variables(owner: str, known: set[str], atoms: Iterable[Atom]) -> None:
    for atom in atoms:
        for term in atom.variables:
            if term not in known:
                raise ValueError(f"{owner}: variable {term} in {atom} is not a parameter")


@dataclass(frozen=True)
class Action:
    """A STRIPS action schema with negative preconditions, equality and an optional cost."""

    name: str
    params: tuple[TypedName, ...]
    preconditions: tuple[Literal, ...]
    add_effects: tuple[Atom, ...]
    del_effects: tuple[Atom, ...]
    cost: int | None = None  # (increase (total-cost) N), if the domain uses action costs

    def __post_init__(self) -> None:
        names = [p.name for p in self.params]
        if len(set(names)) != len(names):
            raise ValueError(f"action {self.name}: repeated parameter")
        known = set(names)
        _check_variables(f"action {self.name}", known, (lit.atom for lit in self.preconditions))
        _check_variables(f"action {self.name}", known, self.add_effects + self.del_effects)
        if self.cost is not None and self.cost < 0:
            raise ValueError(f"action {self.name}: negative cost {self.cost}")

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params)


@dataclass(frozen=True)
class Domain:
    """A parsed PDDL domain."""

    name: str
    requirements: tuple[str, ...]
    types: tuple[TypedName, ...]  # each type with its parent
    constants: tuple[TypedName, ...]
    predicates: tuple[Predicate, ...]
    actions: tuple[Action, ...]
    uses_action_costs: bool = False
    source: str = "<string>"

    def __post_init__(self) -> None:
        for kind, names in (
            ("action", [a.name for a in self.actions]),
            ("predicate", [p.name for p in self.predicates]),
        ):
            _check_unique(names, f"domain {self.name}: repeated {kind}")

    @property
    def typed(self) -> bool:
        return bool(self.types)

    def predicate(self, name: str) -> Predicate:
        for p in self.predicates:
            if p.name == name:
                return p
        raise KeyError(f"domain {self.name} has no predicate {name!r}")

    def action(self, name: str) -> Action:
        for a in self.actions:
            if a.name == name:
                return a
        known = ", ".join(a.name for a in self.actions)
        raise KeyError(f"domain {self.name} has no action {name!r} (known: {known})")

    def supertypes(self, type_name: str) -> tuple[str, ...]:
        """``type_name`` and all its ancestors, up to ``object``."""
        parents = {t.name: t.type for t in self.types}
        chain = [type_name]
        while chain[-1] in parents and chain[-1] != OBJECT_TYPE:
            nxt = parents[chain[-1]]
            if nxt in chain:
                break
            chain.append(nxt)
        if OBJECT_TYPE not in chain:
            chain.append(OBJECT_TYPE)
        return tuple(chain)


@dataclass(frozen=True)
class Stream:
    """A PDDLStream conditional generator: ``:inputs :domain :outputs :certified``.

    A stream with no outputs is a test: it certifies facts about its inputs.
    """

    name: str
    inputs: tuple[str, ...]
    domain: tuple[Atom, ...]
    outputs: tuple[TypedName, ...]
    certified: tuple[Atom, ...]
    source: str = "<string>"
    line: int = 0

    def __post_init__(self) -> None:
        outs = tuple(o.name for o in self.outputs)
        names = self.inputs + outs
        if len(set(names)) != len(names):
            raise ValueError(f"stream {self.name}: an input or output is repeated")
        if not self.certified:
            raise ValueError(f"stream {self.name}: certifies nothing")
        in_domain = {v for atom in self.domain for v in atom.variables}
        for var in self.inputs:
            if var not in in_domain:
                raise ValueError(f"stream {self.name}: input {var} appears in no :domain fact")
        for var in outs:
            if var in in_domain:
                raise ValueError(f"stream {self.name}: output {var} appears in a :domain fact")
        _check_variables(f"stream {self.name} :domain", set(self.inputs), self.domain)
        _check_variables(f"stream {self.name} :certified", set(names), self.certified)

    @property
    def is_test(self) -> bool:
        return not self.outputs

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.outputs)


@dataclass(frozen=True)
class StreamSet:
    """All streams of one ``stream.pddl`` file."""

    name: str
    streams: tuple[Stream, ...]
    source: str = "<string>"

    def __post_init__(self) -> None:
        names = [s.name for s in self.streams]
        _check_unique(names, f"{self.source}: repeated stream")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.streams)

    def stream(self, name: str) -> Stream:
        for s in self.streams:
            if s.name == name:
                return s
        raise KeyError(
            f"{self.source} declares no stream {name!r} (known: {', '.join(self.names)})"
        )

    def certified_predicates(self) -> frozenset[str]:
        return frozenset(a.predicate for s in self.streams for a in s.certified)


@dataclass(frozen=True)
class Problem:
    """Objects, initial facts (closed world) and goal literals over a domain."""

    name: str
    domain_name: str
    objects: tuple[TypedName, ...]
    init: frozenset[Atom]
    goal: tuple[Literal, ...]
    source: str = "<string>"
    values: Mapping[str, object] = field(default_factory=dict, compare=False, hash=False)
    # ``values`` maps object names to the Python values the samplers work on (poses, ...).

    def __post_init__(self) -> None:
        names = [o.name for o in self.objects]
        _check_unique(names, f"problem {self.name}: repeated object")
        for atom in self.init:
            if atom.variables:
                raise ValueError(f"problem {self.name}: initial fact {atom} has a variable")
        if not self.goal:
            raise ValueError(f"problem {self.name}: empty goal")

    @property
    def object_names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.objects)

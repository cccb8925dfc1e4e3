"""Optimistic instantiation: assume every stream succeeds and name its outputs.

Level by level, every stream whose ``:domain`` holds on the facts known so far gets one instance
per input binding, and each output becomes a fresh optimistic object (``opt-q3``). Its certified
facts join the fact set for the next level. Levels and instances are bounded.

Rules are instantiated like tests. A lazily evaluated predicate (``(:predicate (P ?x) ...)``)
gets an instance per binding of its domain too, but certifies nothing: planning assumes ``P``
false, and the instance is the test a plan needs when it relies on ``(not (P ...))``.
"""

from __future__ import annotations

import logging
from collections import defaultdict
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field

from planner.abstract.errors import InstantiationLimitError
from planner.pddl.structs import (
    OBJECT_TYPE,
    Atom,
    Problem,
    Stream,
    StreamKind,
    StreamSet,
    TypedName,
)

log = logging.getLogger(__name__)

OPTIMISTIC_PREFIX = "opt-"  # reserved prefix of optimistic object names


@dataclass(frozen=True)
class StreamInstance:
    """One stream applied to one input binding, with optimistic outputs."""

    stream: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    domain: tuple[Atom, ...]  # grounded :domain facts
    certified: tuple[Atom, ...]  # grounded :certified facts
    level: int  # 1 = needs only initial facts
    kind: StreamKind = "stream"  # a rule, or the test of a lazily evaluated predicate
    output_types: tuple[str, ...] = ()  # declared type of each output (object if none)

    def __post_init__(self) -> None:
        if self.output_types and len(self.output_types) != len(self.outputs):
            raise ValueError(f"{self.stream}: one type per output is needed")

    @property
    def typed_outputs(self) -> tuple[TypedName, ...]:
        types = self.output_types or (OBJECT_TYPE,) * len(self.outputs)
        return tuple(TypedName(o, t) for o, t in zip(self.outputs, types, strict=True))

    def __str__(self) -> str:
        outs = f" -> {' '.join(self.outputs)}" if self.outputs else ""
        return f"{self.stream}({' '.join(self.inputs)}){outs}"


@dataclass(frozen=True)
class OptimisticInstantiation:
    """All stream instances, their optimistic objects and which instance certifies each fact."""

    instances: tuple[StreamInstance, ...]
    objects: tuple[TypedName, ...]  # optimistic objects with their declared types
    certifier: Mapping[Atom, int] = field(repr=False)  # fact -> index of its first instance
    levels: int  # levels actually used
    producer: Mapping[str, int] = field(repr=False)  # optimistic object -> instance index
    # (P args) of a lazily evaluated predicate -> index of the instance that tests it
    tests: Mapping[Atom, int] = field(default_factory=dict, repr=False)

    @property
    def facts(self) -> frozenset[Atom]:
        return frozenset(self.certifier)


def fact_bindings(
    atoms: Sequence[Atom], facts: Mapping[str, set[tuple[str, ...]]]
) -> Iterator[dict[str, str]]:
    """Every assignment of the atoms' variables under which all atoms are facts."""
    order = sorted(atoms, key=lambda a: len(facts.get(a.predicate, ())))

    def extend(i: int, binding: dict[str, str]) -> Iterator[dict[str, str]]:
        if i == len(order):
            yield dict(binding)
            return
        atom = order[i]
        for args in sorted(facts.get(atom.predicate, ())):  # sorted: runs are reproducible
            if len(args) != len(atom.args):
                continue
            added: list[str] = []
            ok = True
            for term, value in zip(atom.args, args, strict=True):
                if term.startswith("?"):
                    bound = binding.get(term)
                    if bound is None:
                        binding[term] = value
                        added.append(term)
                    elif bound != value:
                        ok = False
                        break
                elif term != value:
                    ok = False
                    break
            if ok:
                yield from extend(i + 1, binding)
            for term in added:
                del binding[term]

    yield from extend(0, {})


def instantiate(
    streams: StreamSet,
    problem: Problem,
    *,
    max_levels: int,
    max_instances: int,
) -> OptimisticInstantiation:
    """Instantiate streams optimistically from ``problem.init``, level by level."""
    for obj in problem.objects:
        if obj.name.startswith(OPTIMISTIC_PREFIX):
            raise ValueError(
                f"object name {obj.name!r} uses the reserved prefix {OPTIMISTIC_PREFIX!r}"
            )
    facts: dict[str, set[tuple[str, ...]]] = defaultdict(set)
    init = problem.init
    for atom in init:
        facts[atom.predicate].add(atom.args)
    instances: list[StreamInstance] = []
    seen: set[tuple[str, tuple[str, ...]]] = set()
    certifier: dict[Atom, int] = {}
    producer: dict[str, int] = {}
    tests: dict[Atom, int] = {}
    objects: list[TypedName] = []
    counters: dict[str, int] = defaultdict(int)
    levels = 0
    for level in range(1, max_levels + 1):
        new: list[tuple[Stream, tuple[str, ...], dict[str, str]]] = []
        for stream in streams.streams:
            for binding in fact_bindings(stream.domain, facts):
                inputs = tuple(binding[v] for v in stream.inputs)
                if (stream.name, inputs) in seen:
                    continue
                seen.add((stream.name, inputs))
                new.append((stream, inputs, binding))
        if not new:
            break
        levels = level
        if len(instances) + len(new) > max_instances:
            raise InstantiationLimitError(
                f"optimistic instantiation needs more than {max_instances} stream instances "
                f"at level {level}; raise max_instances or lower max_levels"
            )
        for stream, inputs, binding in new:
            mapping = dict(binding)
            outputs = []
            for out in stream.outputs:
                base = out.name.lstrip("?")
                counters[base] += 1
                name = f"{OPTIMISTIC_PREFIX}{base}{counters[base]}"
                mapping[out.name] = name
                outputs.append(name)
                objects.append(TypedName(name, out.type))
            index = len(instances)
            inst = StreamInstance(
                stream=stream.name,
                inputs=inputs,
                outputs=tuple(outputs),
                domain=tuple([a.substitute(mapping) for a in stream.domain]),
                certified=tuple([a.substitute(mapping) for a in stream.certified]),
                level=level,
                kind=stream.kind,
                output_types=tuple(o.type for o in stream.outputs),
            )
            instances.append(inst)
            for name in outputs:
                producer[name] = index
            if stream.kind == "predicate":
                tests.setdefault(inst.certified[0], index)
        # Facts of this level become usable only at the next level.
        for index in range(len(instances) - len(new), len(instances)):
            if instances[index].kind == "predicate":
                continue  # assumed false: a lazy test certifies nothing
            for atom in instances[index].certified:
                if atom not in init and atom not in certifier:
                    certifier[atom] = index
                facts[atom.predicate].add(atom.args)
    log.debug("instantiated %d stream instances over %d levels", len(instances), levels)
    return OptimisticInstantiation(
        instances=tuple(instances),
        objects=tuple(objects),
        certifier=certifier,
        levels=levels,
        producer=producer,
        tests=tests,
    )

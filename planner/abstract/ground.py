"""A STRIPS task grounded here and written in Fast Downward's SAS format, without its translator.

Fast Downward's translator reads PDDL, grounds it by a Datalog exploration and looks for
invariants; on the kitchen's compiled tasks that is 0.3 s (kitchen-8) to 0.9 s (kitchen-12) of
CPU before any search, where a greedy search then finds a plan in 0.03 s. A STRIPS task (literal
preconditions, plain effects, constant costs) needs none of it: its ground actions are a join of
their static preconditions (facts no action changes: here almost all are optimistic stream
facts) filtered by a relaxed exploration of the fluents, and every reachable fluent atom becomes
one binary SAS variable. The search then sees the same task the translator would have given it,
less its mutex groups (which the FF heuristic and greedy searches do not read).

Anything beyond STRIPS (derived predicates, quantifiers, disjunctions, conditional effects,
function-valued costs) goes through the translator instead (:mod:`planner.abstract.downward`).
"""

from __future__ import annotations

import logging
import math
from collections import defaultdict
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

from planner.pddl.semantics import Universe
from planner.pddl.structs import Action, Atom, Domain, Literal, Problem, TypedName, is_variable

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class GroundOperator:
    """One action applied to objects: preconditions and effects on fluent variables."""

    name: str  # "move q0 opt-q1 opt-t2": what a plan file prints between parentheses
    pre: tuple[tuple[int, bool], ...]  # (variable, whether the atom must hold)
    add: tuple[int, ...]
    delete: tuple[int, ...]
    cost: int


@dataclass(frozen=True)
class GroundTask:
    """A grounded STRIPS task over binary fluent variables."""

    atoms: tuple[Atom, ...]  # variable i is atoms[i] (true or false)
    operators: tuple[GroundOperator, ...]
    init: frozenset[int]  # the variables true initially
    goal: tuple[tuple[int, bool], ...]
    metric: bool  # whether costs count (else every operator costs 1)
    unreachable_goal: tuple[Literal, ...] = ()  # goal literals no relaxed exploration reaches

    @property
    def solvable_relaxed(self) -> bool:
        return not self.unreachable_goal

    def to_sas(self) -> str:
        """The task in Fast Downward's SAS format (version 3), one binary variable per atom
        (value 0: the atom holds) and no mutex groups."""
        out: list[str] = ["begin_version", "3", "end_version"]
        out += ["begin_metric", "1" if self.metric else "0", "end_metric"]
        out.append(str(len(self.atoms)))
        for i, atom in enumerate(self.atoms):
            text = f"{atom.predicate}({', '.join(atom.args)})"
            out += [
                "begin_variable",
                f"var{i}",
                "-1",
                "2",
                f"Atom {text}",
                f"NegatedAtom {text}",
                "end_variable",
            ]
        out.append("0")  # mutex groups
        out.append("begin_state")
        out += ["0" if i in self.init else "1" for i in range(len(self.atoms))]
        out.append("end_state")
        out += ["begin_goal", str(len(self.goal))]
        out += [f"{var} {0 if holds else 1}" for var, holds in self.goal]
        out.append("end_goal")
        out.append(str(len(self.operators)))
        for op in self.operators:
            required = dict(op.pre)
            effects: dict[int, int] = {var: 1 for var in op.delete}
            effects.update({var: 0 for var in op.add})  # an atom both added and deleted holds
            prevail = [(v, h) for v, h in op.pre if v not in effects]
            out += ["begin_operator", op.name, str(len(prevail))]
            out += [f"{var} {0 if holds else 1}" for var, holds in prevail]
            out.append(str(len(effects)))
            for var, value in effects.items():
                before = required.get(var)
                pre = -1 if before is None else (0 if before else 1)
                out.append(f"0 {var} {pre} {value}")
            out += [str(op.cost if self.metric else 1), "end_operator"]
        out.append("0")  # axioms
        return "\n".join(out) + "\n"


class _Facts:
    """Facts by predicate, with an index per pattern of bound argument positions."""

    def __init__(self) -> None:
        self.by_predicate: dict[str, set[tuple[str, ...]]] = defaultdict(set)
        self._index: dict[tuple[str, tuple[int, ...]], dict[tuple[str, ...], list[tuple[str, ...]]]]
        self._index = {}

    def add(self, atom: Atom) -> bool:
        found = self.by_predicate[atom.predicate]
        if atom.args in found:
            return False
        found.add(atom.args)
        for (predicate, positions), table in self._index.items():
            if predicate == atom.predicate:
                key = tuple(atom.args[i] for i in positions)
                table.setdefault(key, []).append(atom.args)
        return True

    def count(self, predicate: str) -> int:
        return len(self.by_predicate.get(predicate, ()))

    def matching(
        self, predicate: str, positions: tuple[int, ...], key: tuple[str, ...]
    ) -> Sequence[tuple[str, ...]]:
        if not positions:
            return sorted(self.by_predicate.get(predicate, ()))
        table = self._index.get((predicate, positions))
        if table is None:
            table = {}
            for args in sorted(self.by_predicate.get(predicate, ())):
                table.setdefault(tuple(args[i] for i in positions), []).append(args)
            self._index[(predicate, positions)] = table
        return table.get(key, ())


class _FactSource(Protocol):
    def count(self, predicate: str) -> int: ...

    def matching(
        self, predicate: str, positions: tuple[int, ...], key: tuple[str, ...]
    ) -> Sequence[tuple[str, ...]]: ...


def _join(atoms: Sequence[Atom], facts: _FactSource) -> Iterator[dict[str, str]]:
    """Every binding of the atoms' variables under which all of them are facts."""
    remaining = list(atoms)
    binding: dict[str, str] = {}

    def pick() -> int:
        # The atom with the fewest candidates given what is bound (bound arguments first).
        best, best_score = 0, math.inf
        for i, atom in enumerate(remaining):
            bound = sum(1 for a in atom.args if not is_variable(a) or a in binding)
            score = facts.count(atom.predicate) / (1 + 100 * bound)
            if score < best_score:
                best, best_score = i, score
        return best

    def extend() -> Iterator[dict[str, str]]:
        if not remaining:
            yield dict(binding)
            return
        atom = remaining.pop(pick())
        positions = tuple(i for i, a in enumerate(atom.args) if not is_variable(a) or a in binding)
        key = tuple(binding.get(atom.args[i], atom.args[i]) for i in positions)
        for args in facts.matching(atom.predicate, positions, key):
            if len(args) != len(atom.args):
                continue
            added: list[str] = []
            ok = True
            for term, value in zip(atom.args, args, strict=True):
                if not is_variable(term):
                    continue
                bound = binding.get(term)
                if bound is None:
                    binding[term] = value
                    added.append(term)
                elif bound != value:
                    ok = False
                    break
            if ok:
                yield from extend()
            for term in added:
                del binding[term]
        remaining.append(atom)

    yield from extend()


_Terms = tuple[str, ...]  # an atom's arguments: variables ("?x") and objects
_Fact = tuple[str, tuple[str, ...]]  # (predicate, objects)


def _fill(terms: _Terms, binding: Mapping[str, str]) -> tuple[str, ...]:
    return tuple([binding[t] if t[:1] == "?" else t for t in terms])


@dataclass
class _Schema:
    """An action split for grounding: what its static atoms bind, what the fluents check."""

    action: Action
    static: list[Atom]  # positive preconditions on static facts (bind parameters by a join)
    positive: list[tuple[str, _Terms]]  # positive preconditions on fluents
    negative: list[tuple[str, _Terms]]  # negative preconditions on fluents
    static_negative: list[tuple[str, _Terms]]
    equalities: list[tuple[str, str, bool]]
    adds: list[tuple[str, _Terms]]
    dels: list[tuple[str, _Terms]]
    free: list[TypedName]  # parameters no positive precondition binds
    fluent_join: bool  # some parameter is bound only by a fluent precondition
    candidates: list[dict[str, str]] | None = None  # the static join, made once
    fired: list[dict[str, str]] = field(default_factory=list)  # applicable bindings found
    done: set[tuple[str, ...]] = field(default_factory=set)  # their parameter values


def _split(action: Action, fluents: set[str]) -> _Schema:
    if action.conditions or action.effects or any(p.either for p in action.params):
        raise ValueError(f"action {action.name} is not STRIPS: ground it with the translator")
    static: list[Atom] = []
    positive: list[tuple[str, _Terms]] = []
    negative: list[tuple[str, _Terms]] = []
    static_negative: list[tuple[str, _Terms]] = []
    equalities: list[tuple[str, str, bool]] = []
    for lit in action.preconditions:
        atom = lit.atom
        if lit.is_equality:
            equalities.append((atom.args[0], atom.args[1], lit.positive))
        elif atom.predicate in fluents:
            (positive if lit.positive else negative).append((atom.predicate, atom.args))
        elif lit.positive:
            static.append(atom)
        else:
            static_negative.append((atom.predicate, atom.args))
    by_static = {a for atom in static for a in atom.args}
    by_any = by_static | {a for _, terms in positive for a in terms}
    return _Schema(
        action,
        static,
        positive,
        negative,
        static_negative,
        equalities,
        [(a.predicate, a.args) for a in action.add_effects],
        [(a.predicate, a.args) for a in action.del_effects],
        [p for p in action.params if p.name not in by_any],
        any(p.name not in by_static and p.name in by_any for p in action.params),
    )


def ground_strips(
    domain: Domain,
    problem: Problem,
    *,
    extra_objects: Iterable[TypedName] = (),
    extra_init: Iterable[Atom] = (),
    function_values: Mapping[tuple[str, tuple[str, ...]], float] | None = None,
    cost_scale: float = 1.0,
) -> tuple[GroundTask, dict[str, tuple[str, tuple[str, ...]]]]:
    """Ground a STRIPS task (literal preconditions, plain effects).

    ``function_values`` values the actions' cost terms ((name, args) -> value; an action with a
    term that has no value is never applicable, as the translator's "defined" guard makes it).
    Costs are multiplied by ``cost_scale`` and rounded.

    Returns the task and, per operator name, the action and arguments it grounds.
    """
    function_values = function_values or {}
    fluents = {a.predicate for act in domain.actions for a in act.add_effects}
    fluents |= {a.predicate for act in domain.actions for a in act.del_effects}
    universe = Universe.of_problem(domain, problem, extra_objects)
    static = _Facts()
    reached_facts = _Facts()
    facts_init = {*problem.init, *extra_init}
    for atom in facts_init:
        (reached_facts if atom.predicate in fluents else static).add(atom)
    static_set = {(p, args) for p, found in static.by_predicate.items() for args in found}
    reached: set[_Fact] = {(a.predicate, a.args) for a in facts_init if a.predicate in fluents}
    schemas = [_split(action, fluents) for action in domain.actions]
    merged = _Merged(static, reached_facts)

    def admissible(schema: _Schema, binding: dict[str, str]) -> bool:
        for param in schema.action.params:
            if not universe.fits(binding[param.name], param):
                return False
        for left, right, positive in schema.equalities:
            if (binding.get(left, left) == binding.get(right, right)) != positive:
                return False
        for predicate, terms in schema.static_negative:
            fact = (predicate, _fill(terms, binding))
            if fact in static_set:
                return False
        return True

    def candidates(schema: _Schema) -> Iterable[dict[str, str]]:
        if schema.fluent_join:  # rare: join the fluents reached so far, every round
            atoms = [*schema.static, *(Atom(p, t) for p, t in schema.positive)]
            return (
                b
                for found in _join(atoms, merged)
                for b in _extend_free(found, schema.free, universe)
                if admissible(schema, b)
            )
        if schema.candidates is None:
            schema.candidates = [
                b
                for found in _join(schema.static, static)
                for b in _extend_free(found, schema.free, universe)
                if admissible(schema, b)
            ]
        return schema.candidates

    # Relaxed exploration: apply every action whose positive preconditions were reached (their
    # negative ones are left to the search), until no new fluent atom appears.
    changed = True
    while changed:
        changed = False
        for schema in schemas:
            for binding in candidates(schema):
                values = tuple(binding[p.name] for p in schema.action.params)
                if values in schema.done:
                    continue
                if not all((p, _fill(t, binding)) in reached for p, t in schema.positive):
                    continue
                schema.done.add(values)
                schema.fired.append(binding)
                for predicate, terms in schema.adds:
                    fact = (predicate, _fill(terms, binding))
                    if fact not in reached:
                        reached.add(fact)
                        reached_facts.add(Atom(*fact))
                        changed = True
    atoms: list[Atom] = []
    index: dict[_Fact, int] = {}
    for fact in sorted(reached):
        index[fact] = len(atoms)
        atoms.append(Atom(*fact))
    metric = any(a.cost is not None or a.cost_terms for a in domain.actions)
    operators: list[GroundOperator] = []
    names: dict[str, tuple[str, tuple[str, ...]]] = {}
    for schema in schemas:
        action = schema.action
        for binding in schema.fired:
            cost = _cost_of(action, binding, function_values)
            if cost is None:
                continue
            pre: list[tuple[int, bool]] = []
            for predicate, terms in schema.positive:
                pre.append((index[(predicate, _fill(terms, binding))], True))
            for predicate, terms in schema.negative:
                var = index.get((predicate, _fill(terms, binding)))
                if var is not None:  # an atom never reached is false: (not ...) holds
                    pre.append((var, False))
            args = tuple(binding[p.name] for p in action.params)
            name = " ".join((action.name, *args))
            adds = {index[(p, _fill(t, binding))] for p, t in schema.adds}
            dels = {index.get((p, _fill(t, binding)), -1) for p, t in schema.dels} - {-1}
            operators.append(
                GroundOperator(
                    name,
                    tuple(dict.fromkeys(pre)),
                    tuple(sorted(adds)),
                    tuple(sorted(dels - adds)),
                    round(cost * cost_scale),
                )
            )
            names[name] = (action.name, args)
    goal: list[tuple[int, bool]] = []
    missing: list[Literal] = []
    for lit in problem.goal:
        if lit.is_equality:
            if (lit.atom.args[0] == lit.atom.args[1]) != lit.positive:
                missing.append(lit)
            continue
        var = index.get((lit.atom.predicate, lit.atom.args))
        if var is not None:
            goal.append((var, lit.positive))
        elif lit.atom.predicate in fluents:
            if lit.positive:
                missing.append(lit)  # never reached
        elif (lit.atom in facts_init) != lit.positive:
            missing.append(lit)  # a static fact that does not hold as the goal needs
    init = frozenset(
        index[(a.predicate, a.args)] for a in facts_init if (a.predicate, a.args) in index
    )
    task = GroundTask(tuple(atoms), tuple(operators), init, tuple(goal), metric, tuple(missing))
    log.debug("grounded %d operators over %d fluent atoms", len(operators), len(atoms))
    return task, names


class _Merged:
    """The static facts and the reached fluents, read as one fact set by :func:`_join`."""

    def __init__(self, static: _Facts, reached: _Facts) -> None:
        self.static = static
        self.reached = reached

    def _of(self, predicate: str) -> _Facts:
        return self.static if predicate in self.static.by_predicate else self.reached

    def count(self, predicate: str) -> int:
        return self._of(predicate).count(predicate)

    def matching(
        self, predicate: str, positions: tuple[int, ...], key: tuple[str, ...]
    ) -> Sequence[tuple[str, ...]]:
        return self._of(predicate).matching(predicate, positions, key)


def _cost_of(
    action: Action, args: Mapping[str, str], values: Mapping[tuple[str, tuple[str, ...]], float]
) -> float | None:
    """The action's cost (its number plus its terms' values); None when a term has none."""
    total = action.cost or 0.0
    for term in action.cost_terms:
        value = values.get((term.name, _fill(term.args, args)))
        if value is None:
            return None
        total += value
    return total


def _extend_free(
    binding: dict[str, str], free: Sequence[TypedName], universe: Universe
) -> Iterator[dict[str, str]]:
    """The binding extended to the parameters no positive precondition binds (any object of
    their type)."""
    if not free:
        yield binding
        return
    head, rest = free[0], free[1:]
    for obj in universe.of(head):
        extended = {**binding, head.name: obj}
        yield from _extend_free(extended, rest, universe)

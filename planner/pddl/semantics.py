"""What the language means in a state: objects by type, derived predicates, conditions and
effects.

A state is a set of ground atoms (closed world). Derived predicates hold where one of their
bodies does, as the least fixed point (recursion allowed; a predicate and those it depends on
negatively must not be mutually recursive). Quantifiers range over the objects of their type;
where a conjunction has a positive atom over a variable, candidates come from the state's facts
for that atom instead of from every object of the type.

An evaluator may be told that some atoms are unknown (a lazily evaluated test not yet made):
truth is then three-valued (Kleene): ``None`` where the value depends on an unknown atom.
"""

from __future__ import annotations

import itertools
from collections import defaultdict
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping
from dataclasses import dataclass

from planner.pddl.structs import (
    EQUALITY,
    OBJECT_TYPE,
    Action,
    And,
    Atom,
    ConditionalEffect,
    DerivedPredicate,
    Domain,
    Exists,
    ForAll,
    Formula,
    Imply,
    Literal,
    Not,
    Or,
    Problem,
    TypedName,
    literals,
)

Truth = bool | None  # None: depends on an atom whose value is not known yet


class Universe:
    """The objects of a task, by type (an object counts for its type and every ancestor)."""

    def __init__(self, domain: Domain, objects: Iterable[TypedName] = ()) -> None:
        self.domain = domain
        self._types: dict[str, str] = {}
        self._by_type: dict[str, list[str]] = defaultdict(list)
        self._supertypes: dict[str, tuple[str, ...]] = {}
        for obj in objects:
            self.add(obj)

    @classmethod
    def of_problem(
        cls, domain: Domain, problem: Problem, extra: Iterable[TypedName] = ()
    ) -> Universe:
        """Constants, the problem's objects and ``extra`` (optimistic objects)."""
        return cls(domain, (*domain.constants, *problem.objects, *extra))

    def add(self, obj: TypedName) -> None:
        if obj.name in self._types:
            return
        self._types[obj.name] = obj.type
        for t in self._ancestors(obj.type):
            self._by_type[t].append(obj.name)

    def _ancestors(self, type_name: str) -> tuple[str, ...]:
        found = self._supertypes.get(type_name)
        if found is None:
            found = self.domain.supertypes(type_name)
            self._supertypes[type_name] = found
        return found

    def __contains__(self, name: object) -> bool:
        return name in self._types

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._types)

    def of(self, typed: TypedName) -> list[str]:
        """Objects that may stand for ``typed`` (any of its ``either`` types)."""
        if len(typed.types) == 1:
            return self._by_type.get(typed.types[0], [])
        out: dict[str, None] = {}
        for t in typed.types:
            out.update(dict.fromkeys(self._by_type.get(t, [])))
        return list(out)

    def fits(self, name: str, typed: TypedName) -> bool:
        """Whether object ``name`` may stand for ``typed``."""
        own = self._types.get(name)
        if own is None:
            return False
        if typed.types == (OBJECT_TYPE,):
            return True
        return any(t in typed.types for t in self._ancestors(own))


def negation(formula: Formula) -> Formula:
    """``(not formula)`` with the negation pushed down to the literals."""
    if isinstance(formula, Literal):
        return Literal(formula.atom, not formula.positive)
    if isinstance(formula, And):
        return Or(tuple(negation(p) for p in formula.parts))
    if isinstance(formula, Or):
        return And(tuple(negation(p) for p in formula.parts))
    if isinstance(formula, Not):
        return formula.part
    if isinstance(formula, Imply):
        return And((formula.condition, negation(formula.consequence)))
    if isinstance(formula, Exists):
        return ForAll(formula.variables, negation(formula.body))
    return Exists(formula.variables, negation(formula.body))


def _conjuncts(formula: Formula) -> list[Formula]:
    if isinstance(formula, And):
        return [c for p in formula.parts for c in _conjuncts(p)]
    return [formula]


def derived_strata(domain: Domain) -> dict[str, frozenset[str]]:
    """Per derived predicate, the derived predicates it is mutually recursive with (itself
    included when it depends on itself; empty when it is not recursive)."""
    rules: dict[str, list[DerivedPredicate]] = defaultdict(list)
    for d in domain.derived:
        rules[d.name].append(d)
    uses = {
        name: {lit.atom.predicate for d in ds for lit, _ in literals(d.body)} & set(rules)
        for name, ds in rules.items()
    }
    reach: dict[str, set[str]] = {}
    for name in rules:
        seen: set[str] = set()
        todo = list(uses[name])
        while todo:
            n = todo.pop()
            if n not in seen:
                seen.add(n)
                todo.extend(uses[n])
        reach[name] = seen
    return {name: frozenset(n for n in reach[name] if name in reach[n]) for name in rules}


FactIndex = dict[str, set[tuple[str, ...]]]  # predicate -> argument tuples


def index_facts(facts: Iterable[Atom]) -> FactIndex:
    """Facts by predicate (for an evaluator's ``background``, built once and shared)."""
    index: FactIndex = defaultdict(set)
    for atom in facts:
        index[atom.predicate].add(atom.args)
    return index


@dataclass(frozen=True)
class GroundEffects:
    """What one applied action changes: delete first, then add."""

    adds: frozenset[Atom]
    dels: frozenset[Atom]

    def apply(self, state: Collection[Atom]) -> frozenset[Atom]:
        return frozenset((set(state) - self.dels) | self.adds)


class Evaluator:
    """Truth of formulas in one state; derived atoms are computed on demand and kept."""

    def __init__(
        self,
        domain: Domain,
        universe: Universe,
        facts: Iterable[Atom],
        *,
        background: FactIndex | None = None,
        unknown: Callable[[Atom], bool] | None = None,
        uncertain: frozenset[str] = frozenset(),
    ) -> None:
        """The state is ``facts`` and, when given, the ``background`` facts (the same for
        many states: index them once). ``unknown`` tells which absent atoms are unknown
        rather than false; their predicates must be in ``uncertain``."""
        self.domain = domain
        self.universe = universe
        self._unknown = unknown
        self._uncertain = uncertain
        self._index = index_facts(facts)
        self._background: FactIndex = background or {}
        self._rules: dict[str, list[DerivedPredicate]] = defaultdict(list)
        for d in domain.derived:
            self._rules[d.name].append(d)
        self._strata = derived_strata(domain) if domain.derived else {}
        self._derived: dict[Atom, Truth] = {}
        self._active: set[Atom] = set()
        self._fixed: set[str] = set()  # recursive groups whose fixed point is known
        # While the fixed point of a recursive group is computed: its current extension.
        self._fixing: dict[str, set[tuple[str, ...]]] = {}

    # --- atoms ----------------------------------------------------------------------------

    def atom(self, atom: Atom) -> Truth:
        """Truth of a ground atom."""
        if atom.predicate == EQUALITY:
            return atom.args[0] == atom.args[1]
        if atom.predicate in self._rules:
            return self._derived_truth(atom)
        if atom.args in self._index.get(atom.predicate, ()) or atom.args in self._background.get(
            atom.predicate, ()
        ):
            return True
        if self._unknown is not None and self._unknown(atom):
            return None
        return False

    def _derived_truth(self, atom: Atom) -> Truth:
        fixing = self._fixing.get(atom.predicate)
        if fixing is not None:
            return atom.args in fixing
        if atom in self._derived:
            return self._derived[atom]
        group = self._strata.get(atom.predicate, frozenset())
        if group:
            if atom.predicate not in self._fixed:
                self._fix(group)
                self._fixed.update(group)
            return self._derived.get(atom, False)
        if atom in self._active:  # cannot happen without recursion; be safe
            return False
        self._active.add(atom)
        try:
            value = self._rule_truth(atom)
        finally:
            self._active.discard(atom)
        self._derived[atom] = value
        return value

    def _rule_truth(self, atom: Atom) -> Truth:
        result: Truth = False
        for rule in self._rules[atom.predicate]:
            if not all(
                self.universe.fits(a, p) for a, p in zip(atom.args, rule.params, strict=True)
            ):
                continue
            env = {p.name: a for p, a in zip(rule.params, atom.args, strict=True)}
            value = self.truth(rule.body, env)
            if value is True:
                return True
            if value is None:
                result = None
        return result

    def _fix(self, group: frozenset[str]) -> None:
        """The least fixed point of a recursive group of derived predicates, twice when some
        atoms are unknown: with them false (what surely holds) and true (what may hold)."""
        lower = self._fixpoint(group, optimistic=False)
        upper = lower if self._unknown is None else self._fixpoint(group, optimistic=True)
        for name in group:
            for args in upper[name]:
                self._derived[Atom(name, args)] = True if args in lower[name] else None
        for name in group:
            for args in lower[name]:
                self._derived[Atom(name, args)] = True

    def _fixpoint(
        self, group: frozenset[str], *, optimistic: bool
    ) -> dict[str, set[tuple[str, ...]]]:
        """Atoms of ``group`` derivable when unknown atoms are false, or (``optimistic``) when
        they may be true."""
        ext: dict[str, set[tuple[str, ...]]] = {name: set() for name in group}
        self._fixing.update(ext)
        try:
            changed = True
            while changed:
                changed = False
                for name in group:
                    for rule in self._rules[name]:
                        for env in self.witnesses(rule.params, rule.body, {}):
                            args = tuple(env[p.name] for p in rule.params)
                            if args in ext[name]:
                                continue
                            value = self.truth(rule.body, env)
                            if value is True or (optimistic and value is None):
                                ext[name].add(args)
                                changed = True
        finally:
            for name in group:
                self._fixing.pop(name, None)
        return ext

    # --- formulas -------------------------------------------------------------------------

    def holds(self, formula: Formula, env: Mapping[str, str] | None = None) -> bool:
        """True when ``formula`` surely holds (unknown atoms cannot make it false)."""
        return self.truth(formula, env or {}) is True

    def truth(self, formula: Formula, env: Mapping[str, str]) -> Truth:
        if isinstance(formula, Literal):
            value = self.atom(formula.atom.substitute(env))
            return value if value is None or formula.positive else not value
        if isinstance(formula, And | Or):
            decisive = isinstance(formula, Or)  # one true part decides an or, a false one an and
            result: Truth = not decisive
            for part in formula.parts:
                value = self.truth(part, env)
                if value is decisive:
                    return decisive
                if value is None:
                    result = None
            return result
        if isinstance(formula, Not):
            value = self.truth(formula.part, env)
            return None if value is None else not value
        if isinstance(formula, Imply):
            return self.truth(Or((negation(formula.condition), formula.consequence)), env)
        if isinstance(formula, Exists):
            result = False
            for binding in self.witnesses(formula.variables, formula.body, env):
                value = self.truth(formula.body, binding)
                if value is True:
                    return True
                if value is None:
                    result = None
            return result
        # ForAll: no binding of the variables makes the body false (or unknown)
        violation = negation(formula.body)
        result = True
        for binding in self.witnesses(formula.variables, violation, env):
            value = self.truth(formula.body, binding)
            if value is False:
                return False
            if value is None:
                result = None
        return result

    def witnesses(
        self, variables: tuple[TypedName, ...], body: Formula, env: Mapping[str, str]
    ) -> Iterator[dict[str, str]]:
        """Bindings of ``variables`` (extending ``env``) that may satisfy ``body``: every one
        that does is among them. Positive atoms of the body's top conjunction narrow them to
        the state's facts; other variables range over the objects of their type."""
        names = {v.name for v in variables}
        drivers = [
            c.atom
            for c in _conjuncts(body)
            if isinstance(c, Literal)
            and c.positive
            and c.atom.predicate != EQUALITY
            and (c.atom.predicate not in self._rules or c.atom.predicate in self._fixing)
            and c.atom.predicate not in self._uncertain
            and any(a in names for a in c.atom.args)
        ]
        base = {k: v for k, v in env.items() if k not in names}
        typed = {v.name: v for v in variables}

        def extend(i: int, binding: dict[str, str]) -> Iterator[dict[str, str]]:
            if i == len(drivers):
                rest = [v for v in variables if v.name not in binding]
                for values in itertools.product(*(self.universe.of(v) for v in rest)):
                    yield {**binding, **{v.name: x for v, x in zip(rest, values, strict=True)}}
                return
            atom = drivers[i]
            source = self._fixing.get(atom.predicate)
            tuples = source if source is not None else self._facts_of(atom.predicate)
            for args in list(tuples):
                added: dict[str, str] = {}
                ok = True
                for term, value in zip(atom.args, args, strict=True):
                    bound = binding.get(term, added.get(term))
                    if term in names:
                        if bound is None:
                            if not self.universe.fits(value, typed[term]):
                                ok = False
                                break
                            added[term] = value
                        elif bound != value:
                            ok = False
                            break
                    elif (bound if bound is not None else term) != value:
                        ok = False
                        break
                if ok:
                    yield from extend(i + 1, {**binding, **added})

        yield from extend(0, base)

    def _facts_of(self, predicate: str) -> set[tuple[str, ...]]:
        own = self._index.get(predicate, set())
        more = self._background.get(predicate)
        return own | more if more else own

    # --- effects --------------------------------------------------------------------------

    def effects(self, action: Action, args: tuple[str, ...]) -> GroundEffects:
        """The atoms ``action(args)`` adds and deletes here (conditions read this state)."""
        mapping = dict(zip(action.param_names, args, strict=True))
        adds = {a.substitute(mapping) for a in action.add_effects}
        dels = {a.substitute(mapping) for a in action.del_effects}
        for effect in action.effects:
            for env in self.firing(effect.substitute(mapping)):
                adds.update(a.substitute(env) for a in effect.adds)
                dels.update(a.substitute(env) for a in effect.dels)
        return GroundEffects(frozenset(adds), frozenset(dels - adds))

    def firing(self, effect: ConditionalEffect) -> Iterator[dict[str, str]]:
        """Bindings of the effect's variables under which its condition holds."""
        if not effect.variables:
            if effect.condition is None or self.holds(effect.condition):
                yield {}
            return
        body = effect.condition if effect.condition is not None else And(())
        for env in self.witnesses(effect.variables, body, {}):
            if effect.condition is None or self.holds(effect.condition, env):
                yield env

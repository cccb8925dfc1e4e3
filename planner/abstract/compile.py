"""The classical task the top-k planners solve: the domain's actions, every optimistic fact in
the initial state.

A STRIPS domain is written as it is. Otherwise the domain is rewritten into what both
translators (Fast Downward's, under K* and SymK) accept:

- ``(either t u)`` variables become plain objects guarded by a static predicate true of the
  objects of either type (SymK's parser allows ``either`` only in predicate declarations);
- a function-valued cost ``(increase (total-cost) (f ?x ?y))`` keeps its term; the values go
  into the initial state for every tuple where the function is defined (a value in the
  problem's ``:init``, or a stream ``:function`` whose domain holds optimistically), guarded by
  a static "defined" predicate so that the translator never grounds an action whose cost it
  has no value for. A stream function's value is computed where every input is a real object
  (with the Python function, when one is given), else it is its lower bound. Several cost
  terms of one action become one function, their sum. Costs that are not all integers are
  multiplied by ``cost_scale`` and rounded (the planners take integer costs only).

- an action whose precondition is a disjunction (``or``, ``imply``, a negated ``and``, outside
  quantifiers) is split into one action per disjunct of its disjunctive normal form, named
  ``NAME--1``, ``NAME--2``, ...: the translators would split it anyway, but under one name, so
  a plan would not say which disjunct it relies on, and so which streams it needs. The plan's
  actions get their own names back, each with the precondition of its disjunct.

Derived predicates, quantified conditions and conditional effects are written as they are;
the translators compile them (axioms, parameters).
"""

from __future__ import annotations

import itertools
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

from planner.abstract.instantiate import OPTIMISTIC_PREFIX, OptimisticInstantiation, fact_bindings
from planner.abstract.skeleton import GroundAction
from planner.pddl.semantics import Universe, negation
from planner.pddl.structs import (
    OBJECT_TYPE,
    Action,
    And,
    Atom,
    DerivedPredicate,
    Domain,
    Exists,
    ForAll,
    Formula,
    FunctionDecl,
    FunctionTerm,
    Imply,
    Literal,
    Not,
    Or,
    Predicate,
    Problem,
    StreamSet,
    TypedName,
    free_variables,
    is_variable,
)
from planner.pddl.writer import write_domain, write_problem

DEFAULT_COST_SCALE = 100.0  # real costs are kept to 1/100 (centiseconds when costs are seconds)
MAX_DISJUNCTS = 32  # a precondition with more disjuncts stays one action (the translator splits)


class FunctionEvaluator(Protocol):
    """Values of a stream file's numeric functions (a :class:`StreamRuntime` is one)."""

    def lower_bound(self, name: str) -> float: ...

    def evaluate(self, name: str, inputs: tuple[Any, ...]) -> float: ...


@dataclass(frozen=True)
class PlannerTask:
    """PDDL text for a top-k planner, and how its costs relate to the real ones."""

    domain_pddl: str
    problem_pddl: str
    cost_scale: float = 1.0  # planner cost = real cost x cost_scale
    # planner action name -> (the domain's action, the precondition of its disjunct)
    variants: Mapping[str, tuple[str, Formula]] = field(default_factory=dict)

    def original(self, action: GroundAction) -> tuple[GroundAction, Formula | None]:
        """A planner's action as the domain's, with the precondition it was planned by
        (None: the action's own)."""
        found = self.variants.get(action.name)
        if found is None:
            return action, None
        return GroundAction(found[0], action.args), found[1]


def _fresh(base: str, taken: set[str]) -> str:
    name, n = base, 1
    while name in taken:
        n += 1
        name = f"{base}-{n}"
    taken.add(name)
    return name


class _Either:
    """Replaces ``(either ...)`` variables by guarded objects."""

    def __init__(self, taken: set[str]) -> None:
        self.taken = taken
        self.guards: dict[tuple[str, ...], str] = {}

    def guard(self, typed: TypedName) -> Literal:
        name = self.guards.get(typed.either)
        if name is None:
            name = _fresh("either-" + "-".join(typed.either), self.taken)
            self.guards[typed.either] = name
        return Literal(Atom(name, (typed.name,)))

    def names(self, names: Sequence[TypedName]) -> tuple[tuple[TypedName, ...], list[Literal]]:
        plain = tuple(TypedName(n.name) if n.either else n for n in names)
        return plain, [self.guard(n) for n in names if n.either]

    def formula(self, f: Formula) -> Formula:
        if isinstance(f, Literal):
            return f
        if isinstance(f, And):
            return And(tuple(self.formula(p) for p in f.parts))
        if isinstance(f, Or):
            return Or(tuple(self.formula(p) for p in f.parts))
        if isinstance(f, Not):
            return Not(self.formula(f.part))
        if isinstance(f, Imply):
            return Imply(self.formula(f.condition), self.formula(f.consequence))
        variables, guards = self.names(f.variables)
        body = self.formula(f.body)
        if isinstance(f, Exists):
            return Exists(variables, And((*guards, body)) if guards else body)
        return ForAll(variables, Imply(And(tuple(guards)), body) if guards else body)

    def facts(self, universe: Universe) -> set[Atom]:
        out: set[Atom] = set()
        for types, name in self.guards.items():
            probe = TypedName("?x", OBJECT_TYPE, types)
            out.update(Atom(name, (o,)) for o in universe.of(probe))
        return out


def _dnf(formula: Formula, limit: int) -> list[list[Formula]] | None:
    """The disjuncts of ``formula``'s disjunctive normal form, each a list of conjuncts
    (literals and quantified formulas); None beyond ``limit`` disjuncts."""
    if isinstance(formula, And):
        result: list[list[Formula]] = [[]]
        for part in formula.parts:
            sub = _dnf(part, limit)
            if sub is None:
                return None
            result = [a + b for a in result for b in sub]
            if len(result) > limit:
                return None
        return result
    if isinstance(formula, Or):
        out: list[list[Formula]] = []
        for part in formula.parts:
            sub = _dnf(part, limit)
            if sub is None:
                return None
            out += sub
            if len(out) > limit:
                return None
        return out
    if isinstance(formula, Imply):
        return _dnf(Or((negation(formula.condition), formula.consequence)), limit)
    if isinstance(formula, Not):
        return _dnf(negation(formula.part), limit)
    return [[formula]]


def _split_disjunctions(
    domain: Domain, taken: set[str]
) -> tuple[Domain, dict[str, tuple[str, Formula]]]:
    """One action per disjunct of each disjunctive precondition (see the module)."""
    actions: list[Action] = []
    variants: dict[str, tuple[str, Formula]] = {}
    for a in domain.actions:
        disjuncts = _dnf(a.precondition, MAX_DISJUNCTS) if a.conditions else None
        if disjuncts is None or len(disjuncts) < 2:
            actions.append(a)
            continue
        for i, parts in enumerate(disjuncts, start=1):
            name = _fresh(f"{a.name}--{i}", taken)
            literals_ = tuple(p for p in parts if isinstance(p, Literal))
            others = tuple(p for p in parts if not isinstance(p, Literal))
            actions.append(replace(a, name=name, preconditions=literals_, conditions=others))
            variants[name] = (a.name, And(tuple(parts)))
    return replace(domain, actions=tuple(actions)), variants


def _guard_universals(domain: Domain, taken: set[str]) -> Domain:
    """Each universally quantified condition of an action's precondition, ``(forall (?x)
    body)``, becomes ``(not (violated-N ?free))`` with a derived predicate ``(violated-N ?free)
    := (exists (?x ?z) (and GUARD (not body)))``, where ``?free`` are the condition's free
    variables and GUARD the action's static preconditions on them (their other variables ``?z``
    quantified too).

    The same precondition wherever the action applies (GUARD holds there), but grounded only
    where it may: the translators make a universal precondition an axiom over its free
    variables, and with nothing to bind them they range over every object of their type.
    With the optimistic objects of a task that is every pose by every configuration: PDDLStream's
    ``place`` (clear of every block on the table) took Fast Downward's translator 13 s to
    ground on pickplace-4, for 193 operators."""
    changing = {a.predicate for act in domain.actions for a in (*act.add_effects, *act.del_effects)}
    for act in domain.actions:
        for effect in act.effects:
            changing |= {a.predicate for a in (*effect.adds, *effect.dels)}
    changing |= {d.name for d in domain.derived}
    derived = list(domain.derived)
    predicates = list(domain.predicates)
    actions = []
    for action in domain.actions:
        conditions: list[Formula] = []
        by_name = {p.name: p for p in action.params}
        for condition in action.conditions:
            free = sorted(free_variables(condition)) if isinstance(condition, ForAll) else []
            guards = [
                lit
                for lit in action.preconditions
                if lit.positive
                and not lit.is_equality
                and lit.atom.predicate not in changing
                and set(lit.atom.variables) & set(free)
            ]
            if not free or not guards:
                conditions.append(condition)
                continue
            assert isinstance(condition, ForAll)
            extra = sorted({v for g in guards for v in g.atom.variables} - set(free))
            name = _fresh(f"violated-{action.name}", taken)
            params = tuple(by_name.get(v, TypedName(v)) for v in free)
            body: Formula = And((*guards, negation(condition.body)))
            inner = (*condition.variables, *(by_name.get(v, TypedName(v)) for v in extra))
            derived.append(DerivedPredicate(name, params, Exists(inner, body)))
            predicates.append(Predicate(name, params))
            conditions.append(Literal(Atom(name, tuple(free)), positive=False))
        literals = tuple(c for c in conditions if isinstance(c, Literal))
        actions.append(
            replace(
                action,
                preconditions=(*action.preconditions, *literals),
                conditions=tuple(c for c in conditions if not isinstance(c, Literal)),
            )
        )
    return replace(
        domain, actions=tuple(actions), derived=tuple(derived), predicates=tuple(predicates)
    )


def _has_either(domain: Domain, problem: Problem) -> bool:
    from planner.pddl.structs import quantified_types

    formulas: list[Formula] = [*problem.goal_conditions, *(d.body for d in domain.derived)]
    for a in domain.actions:
        if any(p.either for p in a.params):
            return True
        formulas += a.conditions
        for e in a.effects:
            if any(v.either for v in e.variables):
                return True
            if e.condition is not None:
                formulas.append(e.condition)
    if any(p.either for d in domain.derived for p in d.params):
        return True
    if any(p.either for pr in domain.predicates for p in pr.params):
        return True
    return any(v.either for f in formulas for v in quantified_types(f))


def _without_either(domain: Domain, problem: Problem, either: _Either) -> tuple[Domain, Problem]:
    actions = []
    for a in domain.actions:
        params, guards = either.names(a.params)
        effects = []
        for e in a.effects:
            variables, eguards = either.names(e.variables)
            condition = e.condition if e.condition is None else either.formula(e.condition)
            if eguards:
                condition = And((*eguards, *([condition] if condition is not None else [])))
            effects.append(replace(e, variables=variables, condition=condition))
        actions.append(
            replace(
                a,
                params=params,
                preconditions=(*a.preconditions, *guards),
                conditions=tuple(either.formula(c) for c in a.conditions),
                effects=tuple(effects),
            )
        )
    derived = []
    for d in domain.derived:
        params, guards = either.names(d.params)
        body = either.formula(d.body)
        derived.append(DerivedPredicate(d.name, params, And((*guards, body)) if guards else body))
    predicates = [Predicate(p.name, either.names(p.params)[0]) for p in domain.predicates]
    predicates += [Predicate(name, (TypedName("?x"),)) for name in either.guards.values()]
    new_domain = replace(
        domain, actions=tuple(actions), derived=tuple(derived), predicates=tuple(predicates)
    )
    new_problem = replace(
        problem, goal_conditions=tuple(either.formula(c) for c in problem.goal_conditions)
    )
    return new_domain, new_problem


@dataclass
class _Costs:
    """Function-valued costs: the defined tuples of each function and their values."""

    values: dict[FunctionTerm, float]
    defined: dict[str, list[tuple[str, ...]]]


def _function_values(
    domain: Domain,
    problem: Problem,
    inst: OptimisticInstantiation,
    streams: StreamSet | None,
    functions: FunctionEvaluator | None,
) -> _Costs:
    used = {t.name for a in domain.actions for t in a.cost_terms}
    values: dict[FunctionTerm, float] = {}
    defined: dict[str, list[tuple[str, ...]]] = defaultdict(list)
    for term, v in problem.function_values.items():
        if term.name in used:
            values[term] = float(v)
            defined[term.name].append(term.args)
    declared = {f.name: f for f in streams.functions} if streams is not None else {}
    facts: dict[str, set[tuple[str, ...]]] = defaultdict(set)
    for atom in (*problem.init, *inst.facts):
        facts[atom.predicate].add(atom.args)
    for name in sorted(used):
        fn = declared.get(name)
        if fn is None:
            continue
        for binding in fact_bindings(fn.domain, facts):
            args = tuple(binding[v] for v in fn.inputs)
            term = FunctionTerm(name, args)
            if term in values:
                continue  # a value in :init wins
            real = not any(a.startswith(OPTIMISTIC_PREFIX) for a in args)
            if functions is None:
                value = 0.0
            elif real:
                inputs = tuple(problem.values.get(a, a) for a in args)
                value = functions.evaluate(name, inputs)
            else:
                value = functions.lower_bound(name)
            values[term] = value
            defined[name].append(args)
    return _Costs(values, dict(defined))


def _combine(action: Action, costs: _Costs, taken: set[str]) -> tuple[Action, FunctionDecl | None]:
    """An action whose cost is a number plus several terms gets one function, their sum."""
    if not action.cost_terms or (len(action.cost_terms) == 1 and action.cost is None):
        return action, None
    variables = list(dict.fromkeys(a for t in action.cost_terms for a in t.args if is_variable(a)))
    name = _fresh(f"cost-of-{action.name}", taken)
    by_var = {p.name: p for p in action.params}
    decl = FunctionDecl(name, tuple(by_var.get(v, TypedName(v)) for v in variables))
    per_term = [costs.defined.get(t.name, []) for t in action.cost_terms]
    for combo in itertools.product(*per_term):
        binding: dict[str, str] = {}
        ok = True
        for term, args in zip(action.cost_terms, combo, strict=True):
            for formal, actual in zip(term.args, args, strict=True):
                if not is_variable(formal):
                    ok = ok and formal == actual
                elif binding.setdefault(formal, actual) != actual:
                    ok = False
        if not ok:
            continue
        total = (action.cost or 0.0) + sum(
            costs.values[FunctionTerm(t.name, a)]
            for t, a in zip(action.cost_terms, combo, strict=True)
        )
        key = tuple(binding[v] for v in variables)
        costs.values[FunctionTerm(name, key)] = total
        costs.defined.setdefault(name, []).append(key)
    combined = replace(action, cost=None, cost_terms=(FunctionTerm(name, tuple(variables)),))
    return combined, decl


def _scale(numbers: Iterable[float], cost_scale: float) -> float:
    return 1.0 if all(float(x).is_integer() for x in numbers) else cost_scale


def is_strips_task(domain: Domain, problem: Problem) -> bool:
    """Whether the task is STRIPS with constant costs: written as it is, and groundable
    without the translator (:mod:`planner.abstract.ground`)."""
    return domain.is_strips and not problem.goal_conditions and not _has_either(domain, problem)


def function_values(
    domain: Domain,
    problem: Problem,
    inst: OptimisticInstantiation,
    streams: StreamSet | None,
    functions: FunctionEvaluator | None,
) -> dict[FunctionTerm, float]:
    """The value of every cost term an action may have: from the problem's ``:init``, or its
    stream function (computed where every input is real, else its lower bound)."""
    return _function_values(domain, problem, inst, streams, functions).values


def compile_planner_task(
    domain: Domain,
    problem: Problem,
    inst: OptimisticInstantiation,
    *,
    streams: StreamSet | None = None,
    functions: FunctionEvaluator | None = None,
    cost_scale: float = DEFAULT_COST_SCALE,
    exclude: frozenset[Atom] = frozenset(),
) -> PlannerTask:
    """The top-k planners' task for ``problem`` with every optimistic fact of ``inst`` but
    those in ``exclude``."""
    if is_strips_task(domain, problem):
        return PlannerTask(
            write_domain(domain),
            write_problem(
                problem, domain, extra_objects=inst.objects, extra_init=inst.facts - exclude
            ),
        )
    taken = (
        {p.name for p in domain.predicates}
        | {f.name for f in domain.functions}
        | {t.name for t in domain.types}
        | {a.name for a in domain.actions}
    )
    domain = _guard_universals(domain, taken)
    domain, variants = _split_disjunctions(domain, taken)
    extra_init: set[Atom] = set(inst.facts - exclude)
    universe = Universe.of_problem(domain, problem, inst.objects)
    if _has_either(domain, problem):
        either = _Either(taken)
        domain, problem = _without_either(domain, problem, either)
        extra_init |= either.facts(universe)
    costs = _function_values(domain, problem, inst, streams, functions)
    actions, decls = [], list(domain.functions)
    for a in domain.actions:
        combined, decl = _combine(a, costs, taken)
        actions.append(combined)
        if decl is not None:
            decls.append(decl)
    guards: dict[str, str] = {}
    guarded = []
    for a in actions:
        extra: list[Literal] = []
        for term in a.cost_terms:
            if term.name not in guards:
                guards[term.name] = _fresh(f"defined-{term.name}", taken)
            extra.append(Literal(Atom(guards[term.name], term.args)))
        guarded.append(replace(a, preconditions=(*a.preconditions, *extra)))
    used = {t.name for a in guarded for t in a.cost_terms}
    arity = {d.name: d.arity for d in decls}
    predicates = list(domain.predicates) + [
        Predicate(guards[f], tuple(TypedName(f"?x{i}") for i in range(arity[f]))) for f in guards
    ]
    for f in used:
        extra_init.update(Atom(guards[f], args) for args in costs.defined.get(f, []))
    values = {t: v for t, v in costs.values.items() if t.name in used}
    scale = _scale([*values.values(), *(a.cost or 0 for a in guarded)], cost_scale)
    scaled = {t: float(round(v * scale)) for t, v in values.items()}
    final = [
        replace(a, cost=None if a.cost is None else float(round(a.cost * scale))) for a in guarded
    ]
    planner_domain = replace(
        domain,
        actions=tuple(final),
        predicates=tuple(predicates),
        functions=tuple(d for d in decls if d.name in used),
    )
    adl = (":adl",) if problem.goal_conditions else ()
    return PlannerTask(
        write_domain(planner_domain, requirements=adl),
        write_problem(
            problem,
            planner_domain,
            extra_objects=inst.objects,
            extra_init=extra_init,
            function_values=scaled,
        ),
        cost_scale=scale,
        variants=variants,
    )

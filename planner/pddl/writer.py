"""Write domains and problems back to PDDL text (the input of the top-k planners).

A STRIPS domain is written exactly as before ADL support existed (the top-k planners see the
same text, so seeded runs stay the same); derived predicates, ADL formulas and effects,
numeric functions and their values are written where the domain has them.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping

from planner.pddl.structs import (
    OBJECT_TYPE,
    Action,
    Atom,
    Domain,
    Formula,
    FunctionTerm,
    Literal,
    Problem,
    TypedName,
    literals,
)


def _typed(names: Iterable[TypedName], typed: bool) -> str:
    if not typed:
        return " ".join(n.name for n in names)
    return " ".join(f"{n.name} - {n.type_text()}" for n in names)


def _conj(items: list[str]) -> str:
    if not items:
        return "(and)"
    return "(and " + " ".join(items) + ")"


def number_text(value: float) -> str:
    """``3`` for integral values, else the shortest exact decimal."""
    return str(int(value)) if float(value).is_integer() else repr(float(value))


def _formulas(domain: Domain) -> Iterator[Formula]:
    for a in domain.actions:
        yield from a.preconditions
        yield from a.conditions
        for e in a.effects:
            if e.condition is not None:
                yield e.condition
    for d in domain.derived:
        yield d.body


def _requirements(domain: Domain, extra: Iterable[str]) -> list[str]:
    reqs = [":strips"]
    if domain.typed:
        reqs.append(":typing")
    if domain.is_strips:
        if any(not lit.positive for a in domain.actions for lit in a.preconditions):
            reqs.append(":negative-preconditions")
        if any(lit.is_equality for a in domain.actions for lit in a.preconditions):
            reqs.append(":equality")
    else:
        found = [lit for f in _formulas(domain) for lit, _ in literals(f)]
        if any(not lit.positive for lit in found):
            reqs.append(":negative-preconditions")
        if any(lit.is_equality for lit in found):
            reqs.append(":equality")
        reqs.append(":adl")
    if domain.derived:
        reqs.append(":derived-predicates")
    if domain.uses_action_costs:
        reqs.append(":action-costs")
    reqs += [r for r in extra if r not in reqs]
    return reqs


def _cost_effects(action: Action) -> list[str]:
    out = [f"(increase (total-cost) {term})" for term in action.cost_terms]
    if action.cost is not None or not out:
        out.insert(0, f"(increase (total-cost) {number_text(action.cost or 0)})")
    return out


def write_domain(domain: Domain, *, requirements: Iterable[str] = ()) -> str:
    """The domain as PDDL; ``requirements`` are declared besides those its parts need (a
    problem's ADL goal needs ``:adl`` of the task)."""
    typed = domain.typed
    lines = [
        f"(define (domain {domain.name})",
        f"  (:requirements {' '.join(_requirements(domain, requirements))})",
    ]
    if typed:
        types = [t for t in domain.types if t.name != OBJECT_TYPE]
        lines.append(f"  (:types {_typed(types, True)})")
    if domain.constants:
        lines.append(f"  (:constants {_typed(domain.constants, typed)})")
    lines.append("  (:predicates")
    for p in domain.predicates:
        lines.append(f"    ({' '.join([p.name, _typed(p.params, typed)]).strip()})")
    lines.append("  )")
    if domain.functions:
        decls = " ".join(
            f"({' '.join([f.name, _typed(f.params, typed)]).strip()}) - number"
            for f in domain.functions
        )
        costs = "(total-cost) - number " if domain.uses_action_costs else ""
        lines.append(f"  (:functions {costs}{decls})")
    elif domain.uses_action_costs:
        lines.append("  (:functions (total-cost) - number)")
    for d in domain.derived:
        head = " ".join([d.name, _typed(d.params, typed)]).strip()
        lines.append(f"  (:derived ({head}) {d.body})")
    for a in domain.actions:
        effects = [str(e) for e in a.add_effects] + [f"(not {e})" for e in a.del_effects]
        effects += [str(e) for e in a.effects]
        if domain.uses_action_costs:
            effects += _cost_effects(a)
        precondition = [str(lit) for lit in a.preconditions] + [str(f) for f in a.conditions]
        lines += [
            f"  (:action {a.name}",
            f"    :parameters ({_typed(a.params, typed)})",
            f"    :precondition {_conj(precondition)}",
            f"    :effect {_conj(effects)})",
        ]
    lines.append(")")
    return "\n".join(lines) + "\n"


def write_problem(
    problem: Problem,
    domain: Domain,
    *,
    extra_objects: Iterable[TypedName] = (),
    extra_init: Iterable[Atom] = (),
    goal: Iterable[Literal] | None = None,
    function_values: Mapping[FunctionTerm, float] | None = None,
) -> str:
    """The problem as PDDL; ``function_values`` replaces the problem's own numeric values."""
    typed = domain.typed
    objects = list(problem.objects) + list(extra_objects)
    init = sorted(set(problem.init) | set(extra_init))
    values = problem.function_values if function_values is None else function_values
    lines = [
        f"(define (problem {problem.name})",
        f"  (:domain {domain.name})",
        f"  (:objects {_typed(objects, typed)})",
        "  (:init",
    ]
    lines += [f"    {atom}" for atom in init]
    lines += [f"    (= {term} {number_text(v)})" for term, v in sorted(values.items())]
    if domain.uses_action_costs:
        lines.append("    (= (total-cost) 0)")
    lines.append("  )")
    goal_parts = [str(lit) for lit in (problem.goal if goal is None else tuple(goal))]
    if goal is None:
        goal_parts += [str(f) for f in problem.goal_conditions]
    lines.append(f"  (:goal {_conj(goal_parts)})")
    if domain.uses_action_costs:
        lines.append("  (:metric minimize (total-cost))")
    lines.append(")")
    return "\n".join(lines) + "\n"

"""Write domains and problems back to PDDL text (the input of the top-k planners)."""

from __future__ import annotations

from collections.abc import Iterable

from planner.pddl.structs import OBJECT_TYPE, Atom, Domain, Literal, Problem, TypedName


def _typed(names: Iterable[TypedName], typed: bool) -> str:
    if not typed:
        return " ".join(n.name for n in names)
    return " ".join(f"{n.name} - {n.type}" for n in names)


def _conj(items: list[str]) -> str:
    if not items:
        return "(and)"
    return "(and " + " ".join(items) + ")"


def write_domain(domain: Domain) -> str:
    typed = domain.typed
    reqs = [":strips"]
    if typed:
        reqs.append(":typing")
    if any(not lit.positive for a in domain.actions for lit in a.preconditions):
        reqs.append(":negative-preconditions")
    if any(lit.is_equality for a in domain.actions for lit in a.preconditions):
        reqs.append(":equality")
    if domain.uses_action_costs:
        reqs.append(":action-costs")
    lines = [f"(define (domain {domain.name})", f"  (:requirements {' '.join(reqs)})"]
    if typed:
        types = [t for t in domain.types if t.name != OBJECT_TYPE]
        lines.append(f"  (:types {_typed(types, True)})")
    if domain.constants:
        lines.append(f"  (:constants {_typed(domain.constants, typed)})")
    lines.append("  (:predicates")
    for p in domain.predicates:
        lines.append(f"    ({' '.join([p.name, _typed(p.params, typed)]).strip()})")
    lines.append("  )")
    if domain.uses_action_costs:
        lines.append("  (:functions (total-cost) - number)")
    for a in domain.actions:
        effects = [str(e) for e in a.add_effects] + [f"(not {e})" for e in a.del_effects]
        if domain.uses_action_costs:
            effects.append(f"(increase (total-cost) {a.cost or 0})")
        lines += [
            f"  (:action {a.name}",
            f"    :parameters ({_typed(a.params, typed)})",
            f"    :precondition {_conj([str(lit) for lit in a.preconditions])}",
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
) -> str:
    typed = domain.typed
    objects = list(problem.objects) + list(extra_objects)
    init = sorted(set(problem.init) | set(extra_init))
    lines = [
        f"(define (problem {problem.name})",
        f"  (:domain {domain.name})",
        f"  (:objects {_typed(objects, typed)})",
        "  (:init",
    ]
    lines += [f"    {atom}" for atom in init]
    if domain.uses_action_costs:
        lines.append("    (= (total-cost) 0)")
    lines.append("  )")
    goal_lits = problem.goal if goal is None else tuple(goal)
    lines.append(f"  (:goal {_conj([str(lit) for lit in goal_lits])})")
    if domain.uses_action_costs:
        lines.append("  (:metric minimize (total-cost))")
    lines.append(")")
    return "\n".join(lines) + "\n"

"""The language construct by construct: each test domain parses into the types that say what
it means, writes back to PDDL that parses the same, and the evaluator reads it right."""

from __future__ import annotations

import pytest

from planner.pddl import (
    And,
    Atom,
    ConditionalEffect,
    Exists,
    ForAll,
    FunctionTerm,
    Imply,
    Literal,
    Or,
    TypedName,
    parse_domain,
    parse_problem,
    parse_streams,
    write_domain,
    write_problem,
)
from planner.pddl.semantics import Evaluator, Universe, negation
from tests.pddl.domains import CASES, load


@pytest.mark.parametrize("name", sorted(CASES))
def test_every_case_writes_back_to_what_it_parsed(name: str) -> None:
    case = load(name)
    again = parse_domain(write_domain(case.domain), file="again.pddl")
    assert again.actions == case.domain.actions
    assert again.derived == case.domain.derived
    assert again.predicates == case.domain.predicates
    assert again.functions == case.domain.functions
    back = parse_problem(write_problem(case.problem, case.domain), case.domain)
    assert back.init == case.problem.init and back.goal == case.problem.goal
    assert back.goal_conditions == case.problem.goal_conditions
    assert dict(back.function_values) == dict(case.problem.function_values)


def test_derived_predicates_and_quantified_bodies() -> None:
    d = load("derived").domain
    (unsafe,) = d.derived
    assert unsafe.name == "unsafe" and [p.type for p in unsafe.params] == ["block", "pose"]
    assert isinstance(unsafe.body, Exists)
    assert [v.name for v in unsafe.body.variables] == ["?b2", "?p2"]
    place = d.action("place")
    assert Literal(Atom("unsafe", ("?b", "?p")), positive=False) in place.preconditions


def test_disjunction_and_implication_are_conditions() -> None:
    d = load("disjunction").domain
    place = d.action("place")
    assert place.conditions == (
        Or((Literal(Atom("reach-left", ("?p",))), Literal(Atom("reach-right", ("?p",))))),
        Imply(Literal(Atom("fragile", ("?b",))), Literal(Atom("padded", ("?r",)))),
    )
    goal = load("disjunction").problem
    assert goal.goal == () and isinstance(goal.goal_conditions[0], Or)


def test_universal_conditions_and_goals() -> None:
    case = load("quantifiers")
    place = case.domain.action("place")
    (forall,) = place.conditions
    assert isinstance(forall, ForAll) and isinstance(forall.body, Imply)
    assert isinstance(case.problem.goal_conditions[0], ForAll)


def test_conditional_universal_effects() -> None:
    carry = load("effects").domain.action("carry")
    (effect,) = carry.effects
    assert isinstance(effect, ConditionalEffect)
    assert [v.name for v in effect.variables] == ["?b", "?s"]
    assert effect.dels == (Atom("loaded", ("?b", "?s")), Atom("occupied", ("?s",)))
    assert carry.add_effects == (Atom("tray-at", ("?to",)),)


def test_either_types() -> None:
    pick = load("either").domain.action("pick")
    assert pick.params[0] == TypedName("?o", "object", ("block", "tool"))
    assert not pick.is_strips


def test_function_costs_and_values() -> None:
    case = load("costs")
    drive = case.domain.action("drive")
    assert drive.cost is None and drive.cost_terms == (FunctionTerm("road", ("?a", "?b")),)
    assert case.domain.action("pick").cost == 1
    assert case.problem.function_values[FunctionTerm("road", ("depot", "hall"))] == 2.5
    functions = load("functions").streams.function("dist")
    assert functions.inputs == ("?q1", "?q2") and len(functions.domain) == 2


def test_stream_fluents_predicates_and_rules() -> None:
    assert load("fluents").streams.stream("sample-free-pose").fluents == ("at",)
    collide = load("predicate").streams.stream("collide")
    assert collide.kind == "predicate" and collide.is_test
    assert collide.certified == (Atom("collide", ("?b", "?p", "?b2", "?p2")),)
    streams = load("rule").streams
    rule = streams.stream("rule-1")
    assert rule.kind == "rule" and rule.certified == (Atom("goal-pose", ("?b", "?p")),)
    assert "rule-1" not in streams.binding_names  # a rule needs no Python binding


def test_lazy_predicates_cannot_also_be_certified() -> None:
    case = load("predicate")
    text = (
        "(define (stream s) (:predicate (collide ?b ?p ?b2 ?p2) (and (pose ?b ?p) (pose ?b2 ?p2)))"
        "\n  (:stream t :inputs (?b ?p) :domain (pose ?b ?p) :certified (collide ?b ?p ?b ?p)))"
    )
    with pytest.raises(Exception, match="declares as a lazily evaluated test"):
        parse_streams(text, case.domain)


# --- what the formulas mean ------------------------------------------------------------------


def evaluator(name: str, facts: set[Atom]) -> Evaluator:
    case = load(name)
    return Evaluator(case.domain, Universe.of_problem(case.domain, case.problem), facts)


def test_recursive_derived_predicate_is_the_least_fixed_point() -> None:
    on = {Atom("on", ("a", "b")), Atom("on", ("b", "c"))}
    ev = evaluator("tower", on)
    assert ev.holds(Literal(Atom("above", ("a", "c"))))  # through b
    assert ev.holds(Literal(Atom("above", ("b", "c"))))
    assert not ev.holds(Literal(Atom("above", ("c", "a"))))
    assert not ev.holds(Literal(Atom("above", ("a", "a"))))


def test_quantifiers_range_over_the_objects_of_their_type() -> None:
    ev = evaluator("quantifiers", {Atom("in", ("a", "goal")), Atom("target", ("goal",))})
    goal = load("quantifiers").problem.goal_formula
    assert not ev.holds(goal)  # b is not in the goal region
    both = {Atom("in", ("a", "goal")), Atom("in", ("b", "goal")), Atom("target", ("goal",))}
    assert evaluator("quantifiers", both).holds(goal)
    every = ForAll((TypedName("?r", "region"),), Literal(Atom("region", ("?r",))))
    regions = {Atom("region", ("start",)), Atom("region", ("goal",))}
    assert evaluator("quantifiers", regions).holds(every)
    assert not evaluator("quantifiers", {Atom("region", ("start",))}).holds(every)


def test_either_typed_quantifier_covers_both_types_only() -> None:
    movable = Literal(Atom("movable", ("?o",)))
    typed = TypedName("?o", "object", ("block", "tool"))
    all_movable = ForAll((typed,), movable)
    facts = {Atom("movable", ("cube",)), Atom("movable", ("hammer",))}
    assert evaluator("either", facts).holds(all_movable)  # the vice is neither type
    assert not evaluator("either", {Atom("movable", ("cube",))}).holds(all_movable)


def test_conditional_effects_read_the_state_before_the_action() -> None:
    case = load("effects")
    carry = case.domain.action("carry")
    facts = {
        Atom("tray-at", ("kitchen",)),
        Atom("loaded", ("a", "s1")),
        Atom("loaded", ("b", "s2")),
        Atom("occupied", ("s1",)),
        Atom("occupied", ("s2",)),
        Atom("stable", ("s1", "table")),
    }
    universe = Universe.of_problem(
        case.domain, case.problem, [TypedName("s1", "slot"), TypedName("s2", "slot")]
    )
    effects = Evaluator(case.domain, universe, facts).effects(carry, ("kitchen", "table", "w"))
    after = effects.apply(facts)
    assert Atom("loaded", ("a", "s1")) in after  # a stable slot keeps its block
    assert Atom("loaded", ("b", "s2")) not in after and Atom("occupied", ("s2",)) not in after
    assert Atom("tray-at", ("table",)) in after and Atom("tray-at", ("kitchen",)) not in after


def test_unknown_atoms_make_truth_unknown_not_false() -> None:
    case = load("predicate")
    universe = Universe.of_problem(case.domain, case.problem)
    unsafe = Literal(Atom("unsafe", ("a", "x0-a")), positive=False)
    facts = {Atom("at", ("b", "x0-b"))}
    ev = Evaluator(
        case.domain,
        universe,
        facts,
        unknown=lambda atom: atom.predicate == "collide",
        uncertain=frozenset({"collide"}),
    )
    assert ev.truth(unsafe, {}) is None  # whether a collides with b is not known
    known = Evaluator(case.domain, universe, facts)
    assert known.truth(unsafe, {}) is True  # closed world: no collision fact, no collision


def test_negation_is_pushed_to_the_literals() -> None:
    p, q = Literal(Atom("p")), Literal(Atom("q"))
    assert negation(And((p, q))) == Or((Literal(Atom("p"), False), Literal(Atom("q"), False)))
    assert negation(Imply(p, q)) == And((p, Literal(Atom("q"), False)))
    x = (TypedName("?x"),)
    px = Literal(Atom("p", ("?x",)))
    assert negation(Exists(x, px)) == ForAll(x, Literal(Atom("p", ("?x",)), False))

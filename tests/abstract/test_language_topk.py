"""Every construct of the language through both top-k planners: k skeletons whose stream plans
replay fact by fact (the helper replays each), and hold the streams the construct demands."""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import pytest

from planner.abstract import (
    AbstractPlan,
    AbstractResult,
    GroundAction,
    PlanReplayError,
    UnreachableGoalError,
    instantiate,
    replay,
)
from planner.abstract.compile import compile_planner_task
from planner.abstract.topk import sas_supports_lmcut
from planner.pddl import Atom, FunctionTerm, Literal
from tests.pddl.domains import CASES, abstract, load

pytestmark = pytest.mark.slow
BACKENDS = ("adaptive", "kstar", "symk")


@cache
def plans(name: str, backend: str) -> AbstractResult:
    return abstract(load(name), backend, k=8)


def streams_of(plan: AbstractPlan) -> list[str]:
    return [str(s) for s in plan.stream_plan]


def without(plan: AbstractPlan, stream: str) -> AbstractPlan:
    kept = [s for s in plan.stream_plan if s.stream != stream]
    return AbstractPlan(plan.actions, tuple(kept), plan.cost)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name", sorted(CASES))
def test_each_case_gets_k_skeletons_that_replay(name: str, backend: str) -> None:
    """k = 8 skeletons, or all there are: a skeleton is a distinct stream plan, and in some
    cases every action plan needs the same streams (costs: one grasp whatever the roads), so
    larger requests find no new one."""
    result = plans(name, backend)
    assert result.plans, f"{name}: no plan from {backend}"
    assert result.backend == backend
    assert len(result.plans) == 8 or result.stop_reason in ("exhausted", "no-new-skeletons")
    costs = [p.cost for p in result.plans]
    assert costs == sorted(costs)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize(
    ("name", "unmet"),
    [("derived", r"precondition \(not \(unsafe"), ("safe", r"precondition \(safe")],
)
def test_a_derived_precondition_pulls_in_the_tests_of_its_facts(
    backend: str, name: str, unmet: str
) -> None:
    """``derived``: (not (unsafe ...)), unsafe an exists over a test's facts; ``safe``: (safe
    ...), a forall ... imply over them. Either way the stream plan tests the new pose against
    every block standing where it is placed, and without those tests it does not replay."""
    case = load(name)
    best = plans(name, backend).plans[0]
    assert len(best.actions) == 4  # pick and place each block
    first, second = (a for a in best.actions if a.name == "place")
    # Placing the first block tests its pose against the block still at the start; placing
    # the second tests against the first, where it now stands.
    assert f"test-cfree({first.args[0]} {first.args[1]} {second.args[0]} x0-{second.args[0]})" in (
        streams_of(best)
    )
    assert f"test-cfree({second.args[0]} {second.args[1]} {first.args[0]} {first.args[1]})" in (
        streams_of(best)
    )
    with pytest.raises(PlanReplayError, match=unmet):
        replay(without(best, "test-cfree"), case.domain, case.problem, case.streams)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_recursive_derived_goal_needs_every_stack_on_its_way(backend: str) -> None:
    best = plans("tower", backend).plans[0]
    assert [a.name for a in best.actions] == ["pick", "stack", "pick", "stack"]
    stacks = [a for a in best.actions if a.name == "stack"]
    assert [(a.args[0], a.args[1]) for a in stacks] == [("b", "c"), ("a", "b")]
    tests = [s for s in best.stream_plan if s.stream == "test-stable"]
    assert {s.inputs[2] for s in tests} == {a.args[2] for a in stacks}


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_planners_choice_of_disjunct_decides_the_tests(backend: str) -> None:
    # k large enough that diversity (one plan per action multiset first) keeps every variant
    result = abstract(load("disjunction"), backend, k=24)
    # Picking the egg at x0-egg is planned by one arm or the other: both kinds of skeleton
    # are there, each with the reach test of its own disjunct.
    firsts = {
        p.stream_plan[0].stream for p in result.plans if p.stream_plan[0].inputs[1] == "x0-egg"
    }
    assert firsts == {"test-left", "test-right"}
    for plan in result.plans:
        if len(plan.actions) != 2:
            continue  # longer plans pick the egg again, maybe with the other arm
        place = plan.actions[1]
        reach = [s.stream for s in plan.stream_plan if s.stream.startswith("test-")]
        assert len(reach) == 2  # one reach test per action: the arm of its disjunct
        assert plan.stream_plan[-1].inputs == ("egg", place.args[1])


@pytest.mark.parametrize("backend", BACKENDS)
def test_an_existential_witness_pulls_in_its_stream(backend: str) -> None:
    case = load("quantifiers")
    best = plans("quantifiers", backend).plans[0]
    grasps = [s for s in best.stream_plan if s.stream == "sample-grasp"]
    assert sorted(s.inputs[0] for s in grasps) == ["a", "b"]  # no action names a grasp
    assert not any(o.startswith("opt-g") for a in best.actions for o in a.args)
    with pytest.raises(PlanReplayError, match="exists"):
        replay(without(best, "sample-grasp"), case.domain, case.problem, case.streams)
    with pytest.raises(PlanReplayError, match="forall"):
        replay(without(best, "test-cfree"), case.domain, case.problem, case.streams)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_conditional_effect_needs_the_facts_its_condition_reads(backend: str) -> None:
    case = load("effects")
    best = plans("effects", backend).plans[0]
    loads = {a.args[1] for a in best.actions if a.name == "load"}
    stable = {s.inputs for s in best.stream_plan if s.stream == "test-stable"}
    assert stable == {(slot, "table") for slot in loads}
    # Without the tests, the carry drops the blocks: unloading them fails.
    with pytest.raises(PlanReplayError, match=r"unload .* precondition \(loaded"):
        replay(without(best, "test-stable"), case.domain, case.problem, case.streams)


@pytest.mark.parametrize("backend", BACKENDS)
def test_either_types_admit_both_types_and_nothing_else(backend: str) -> None:
    case = load("either")
    for plan in plans("either", backend).plans:
        assert {a.args[0] for a in plan.actions} == {"cube", "hammer"}
    vice = replace(case.problem, goal=(Literal(Atom("in", ("vice", "goal"))),))
    with pytest.raises(UnreachableGoalError):
        abstract(case, backend, k=1, problem=vice)
    plan = plans("either", backend).plans[0]
    wrong = AbstractPlan((GroundAction("pick", ("vice", "x0-vice", "start")),), (), 1.0)
    with pytest.raises(PlanReplayError, match=r"vice is not a known \(either block tool\)"):
        replay(wrong, case.domain, case.problem)
    assert plan.actions[0].args[0] != "vice"


@pytest.mark.parametrize("backend", BACKENDS)
def test_function_costs_from_init_rank_the_plans(backend: str) -> None:
    result = plans("costs", backend)
    best = result.plans[0]
    assert best.cost == 13.5  # the detour through the hall, both ways, plus pick and place
    assert [a.args for a in best.actions if a.name == "drive"] == [
        ("depot", "hall"),
        ("hall", "shelf"),
        ("shelf", "hall"),
        ("hall", "depot"),
    ]


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_road_without_a_value_is_not_driven(backend: str) -> None:
    """An undefined function value makes the action inapplicable (as in PDDL), rather than
    crashing the translator: without (road hall shelf) the detour works one way only."""
    case = load("costs")
    values = dict(case.problem.function_values)
    del values[FunctionTerm("road", ("hall", "shelf"))]
    problem = replace(case.problem, function_values=values)
    result = abstract(case, backend, k=3, problem=problem)
    assert all(a.args != ("hall", "shelf") for p in result.plans for a in p.actions)
    assert result.plans[0].cost == 9.5 + 1 + 3.25 + 2.5 + 1


def test_stream_functions_are_valued_where_bound_and_bounded_elsewhere() -> None:
    case = load("functions")
    inst = instantiate(case.streams, case.problem, max_levels=4, max_instances=1000)
    task = compile_planner_task(
        case.domain, case.problem, inst, streams=case.streams, functions=case.runtime(0)
    )
    assert task.cost_scale == 100  # the distances are not integers
    # (dist q0 q0) is real: |0 - 0| = 0; (dist q0 opt-q1) is optimistic: the lower bound 0.5
    assert "(= (dist q0 q0) 0)" in task.problem_pddl
    assert "(= (dist q0 opt-q1) 50)" in task.problem_pddl
    assert "(defined-dist q0 opt-q1)" in task.problem_pddl
    assert "(defined-dist ?q1 ?q2)" in task.domain_pddl
    unbounded = compile_planner_task(case.domain, case.problem, inst, streams=case.streams)
    assert "(= (dist q0 opt-q1) 0)" in unbounded.problem_pddl  # the default lower bound


@pytest.mark.parametrize("backend", BACKENDS)
def test_stream_function_costs_use_the_lower_bound(backend: str) -> None:
    result = plans("functions", backend)
    # Two moves between optimistic views at the lower bound 0.5, two inspections at 1.
    assert result.plans[0].cost == 3.0
    assert FunctionTerm("dist", ("q0", "q0")) not in load("functions").problem.function_values


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_lazy_predicate_is_tested_where_the_plan_needs_it_false(backend: str) -> None:
    case = load("predicate")
    best = plans("predicate", backend).plans[0]
    tests = [s for s in best.stream_plan if s.stream == "collide"]
    assert len(tests) == 2 and all(s.kind == "predicate" for s in tests)
    with pytest.raises(PlanReplayError, match="lazily evaluated but tested by no stream"):
        replay(without(best, "collide"), case.domain, case.problem, case.streams)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_rule_is_no_query_but_its_facts_follow(backend: str) -> None:
    case = load("rule")
    best = plans("rule", backend).plans[0]
    assert [s.stream for s in best.stream_plan] == ["sample-pose", "test-reachable"]
    with pytest.raises(PlanReplayError, match="goal-pose"):
        replay(best, case.domain, case.problem)  # without the stream file, no rule applies


def test_kstar_takes_lmcut_only_without_axioms_or_conditional_effects() -> None:
    header = "begin_version\n3\nend_version\nbegin_metric\n1\nend_metric\n"
    plain = "begin_operator\nmove a b\n1\n0 1\n1\n0 2 0 1\n1\nend_operator\n0\n"
    conditional = "begin_operator\nmove a b\n0\n1\n1 3 0 2 0 1\n1\nend_operator\n0\n"
    assert sas_supports_lmcut(header + plain)
    assert not sas_supports_lmcut(header + conditional)
    assert not sas_supports_lmcut(header + plain + "begin_rule\n1\n0 1\n2 0 1\nend_rule\n")

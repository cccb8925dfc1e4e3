"""Optimistic instantiation, stream-plan recovery and uniqueness, on the line domain."""

from __future__ import annotations

from dataclasses import replace

import pytest

from planner.abstract import (
    AbstractConfig,
    AbstractPlan,
    InstantiationLimitError,
    PlanReplayError,
    UnreachableGoalError,
    canonical_key,
    instantiate,
    plan_abstract,
    replay,
)
from planner.domains import LoadedDomain
from planner.pddl import Atom, Literal, Problem


def test_instantiation_is_level_by_level(line: LoadedDomain, line_problem: Problem) -> None:
    inst = instantiate(line.streams, line_problem, max_levels=4, max_instances=1000)
    by_level = {(i.stream, i.level) for i in inst.instances}
    # poses for 2 blocks x 2 regions and reach tests on the initial poses need only init facts;
    # reach tests on sampled poses come one level later.
    assert ("sample-pose", 1) in by_level and ("test-reachable", 1) in by_level
    assert ("test-reachable", 2) in by_level and ("sample-pose", 2) not in by_level
    assert len(inst.instances) == 4 + 2 + 4 and inst.levels == 2
    for obj in inst.objects:
        assert obj.name.startswith("opt-p") and obj.type == "pose"
    one = instantiate(line.streams, line_problem, max_levels=1, max_instances=1000)
    assert one.levels == 1 and len(one.instances) == 6
    with pytest.raises(InstantiationLimitError, match="more than 5"):
        instantiate(line.streams, line_problem, max_levels=4, max_instances=5)


def test_reserved_prefix_is_refused(line: LoadedDomain, line_problem: Problem) -> None:
    from planner.pddl import TypedName

    bad = replace(line_problem, objects=(*line_problem.objects, TypedName("opt-p1", "pose")))
    with pytest.raises(ValueError, match="reserved prefix"):
        instantiate(line.streams, bad, max_levels=2, max_instances=100)


@pytest.mark.slow
def test_plans_are_unique_and_replay(line: LoadedDomain, line_problem: Problem) -> None:
    config = AbstractConfig(k=8, backend="kstar")  # the 8 cheapest
    result = plan_abstract(line.domain, line.streams, line_problem, config)
    assert len(result.plans) == 8
    keys = {canonical_key(p.actions, p.stream_plan) for p in result.plans}
    assert len(keys) == 8
    for plan in result.plans:
        replay(plan, line.domain, line_problem)
        produced = [o for s in plan.stream_plan for o in s.outputs]
        used = {a for act in plan.actions for a in act.args if a.startswith("opt-")}
        assert used <= set(produced)  # every optimistic object in the plan is bound by a stream
        assert len(produced) == len(set(produced))
    costs = [p.cost for p in result.plans]
    assert costs == sorted(costs) and costs[0] == 4  # pick and place each block


@pytest.mark.slow
def test_stream_plan_follows_the_actions(line: LoadedDomain, line_problem: Problem) -> None:
    plan = plan_abstract(line.domain, line.streams, line_problem, AbstractConfig(k=1)).plans[0]
    first_place = next(a for a in plan.actions if a.name == "place")
    pose = first_place.args[1]
    names = [str(s) for s in plan.stream_plan]
    producer = next(i for i, s in enumerate(plan.stream_plan) if pose in s.outputs)
    tester = next(
        i
        for i, s in enumerate(plan.stream_plan)
        if s.stream == "test-reachable" and pose in s.inputs
    )
    assert producer < tester, names


@pytest.mark.slow
def test_replay_catches_a_missing_stream(line: LoadedDomain, line_problem: Problem) -> None:
    plan = plan_abstract(line.domain, line.streams, line_problem, AbstractConfig(k=1)).plans[0]
    sampler = next(i for i, s in enumerate(plan.stream_plan) if s.stream == "sample-pose")
    broken = AbstractPlan(
        plan.actions, plan.stream_plan[:sampler] + plan.stream_plan[sampler + 1 :], plan.cost
    )
    with pytest.raises(PlanReplayError, match=r"is not produced earlier|bound by no stream"):
        replay(broken, line.domain, line_problem)
    truncated = AbstractPlan(plan.actions[:-1], plan.stream_plan, plan.cost)
    with pytest.raises(PlanReplayError, match="goal"):
        replay(truncated, line.domain, line_problem)


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["adaptive", "kstar", "symk"])
def test_unreachable_goal_is_a_typed_error(
    line: LoadedDomain, line_problem: Problem, backend: str
) -> None:
    # No stream certifies (holding ...) without a block, and no block is called "ghost-free":
    # demand that a block be both held and in a region, which no action allows.
    goal = (Literal(Atom("holding", ("a",))), Literal(Atom("hand-empty")))
    impossible = replace(line_problem, goal=goal)
    with pytest.raises(UnreachableGoalError, match="unreachable even if every stream succeeds"):
        plan_abstract(line.domain, line.streams, impossible, AbstractConfig(k=3, backend=backend))


@pytest.mark.slow
def test_growing_requests_until_k_unique(line: LoadedDomain, line_problem: Problem) -> None:
    # With no oversampling the first request is exactly k; ask for more than one call gives.
    config = AbstractConfig(k=30, oversample=1.0, backend="kstar")
    result = plan_abstract(line.domain, line.streams, line_problem, config)
    assert result.unique >= len(result.plans)
    assert len(result.plans) == 30 or result.stop_reason == "exhausted"
    assert (len(result.plans) == 30) == (result.stop_reason == "enough")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"k": 0}, "k must be between 1"),
        ({"k": 10**6}, "k must be between 1"),
        ({"backend": "fd"}, "unknown skeleton source 'fd' .known: adaptive, kstar, symk"),
        ({"growth": 1.0}, "growth must exceed 1"),
    ],
)
def test_config_is_checked(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        AbstractConfig(**kwargs)  # type: ignore[arg-type]


@pytest.mark.slow
def test_topk_timeout_is_a_typed_error_and_leaves_no_process(
    kitchen: LoadedDomain,
) -> None:
    import subprocess

    from planner.abstract import TopKPlannerError, compile_task, get_topk_planner
    from planner.domains import problem_for_scene

    _, problem = problem_for_scene("kitchen-8")
    inst = instantiate(kitchen.streams, problem, max_levels=4, max_instances=50_000)
    domain_pddl, problem_pddl = compile_task(kitchen.domain, problem, inst)
    with pytest.raises(TopKPlannerError, match=r"symk: timed out after 0.5 s"):
        get_topk_planner("symk").plan(domain_pddl, problem_pddl, 500, timeout_s=0.5)
    left = subprocess.run(["pgrep", "-f", "tamp-symk-"], capture_output=True, text=True)
    assert left.stdout.strip() == ""

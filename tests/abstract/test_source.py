"""The skeleton source: skeletons on demand from greedy searches, as cheap as the top-k
planner's, and replanned on what the search proved false or doubts."""

from __future__ import annotations

from dataclasses import replace

import pytest

from planner.abstract import (
    AbstractConfig,
    Feedback,
    PlannerTimeoutError,
    SkeletonSource,
    UnreachableGoalError,
    plan_abstract,
    replay,
)
from planner.abstract.compile import compile_planner_task
from planner.abstract.downward import SasTask, search_plan, translate
from planner.abstract.ground import ground_strips
from planner.abstract.instantiate import instantiate
from planner.domains import LoadedDomain, problem_for_scene
from planner.pddl import Atom, Literal, Problem
from tests.pddl.domains import CASES, abstract, load

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_first_skeleton_costs_no_more_than_kstars_cheapest(name: str) -> None:
    """On every small task of the test domains (each a construct of the language), the
    adaptive source's first skeleton is as cheap as K*'s optimal one, and replays."""
    case = load(name)
    cheapest = abstract(case, "kstar", k=1).plans[0].cost
    first = abstract(case, "adaptive", k=1).plans[0]  # the helper replays it
    assert first.cost <= cheapest + 1e-9, f"{name}: {first.cost} against K*'s {cheapest}"


def test_line_and_kitchen_first_skeletons_are_optimal() -> None:
    for scene in ("line-2", "kitchen-2", "kitchen-4"):
        loaded, problem = problem_for_scene(scene)
        costs = {}
        for backend in ("adaptive", "kstar"):
            config = AbstractConfig(k=1, backend=backend)
            costs[backend] = plan_abstract(loaded.domain, loaded.streams, problem, config)
        assert costs["adaptive"].plans[0].cost == costs["kstar"].plans[0].cost, scene


def test_direct_grounding_gives_the_translators_task(kitchen: LoadedDomain) -> None:
    """The STRIPS grounding written straight to SAS has the translator's operators, and an
    optimal search on either finds plans of one cost."""
    _, problem = problem_for_scene("kitchen-2")
    inst = instantiate(kitchen.streams, problem, max_levels=4, max_instances=10_000)
    task, names = ground_strips(
        kitchen.domain, problem, extra_objects=inst.objects, extra_init=inst.facts
    )
    planner = compile_planner_task(kitchen.domain, problem, inst)
    translated = translate(planner.domain_pddl, planner.problem_pddl, timeout_s=120)
    direct = SasTask(task.to_sas(), "direct", 0.0, len(task.operators))
    assert direct.operators == translated.operators == len(names)
    optimal = "astar(lmcut())"
    a = search_plan(direct, optimal, timeout_s=120)
    b = search_plan(translated, optimal, timeout_s=120)
    assert a is not None and b is not None and a.cost == b.cost == 16


def test_more_skeletons_on_demand_are_new_and_as_cheap(kitchen: LoadedDomain) -> None:
    _, problem = problem_for_scene("kitchen-4")
    source = SkeletonSource(kitchen.domain, kitchen.streams, problem)
    first = source.request(1)
    more = source.request(5)
    plans = [*first.plans, *more.plans]
    assert len(first.plans) == 1 and len(more.plans) == 5
    assert len({tuple(p.actions) for p in plans}) == 6
    assert all(p.cost == first.plans[0].cost for p in plans)  # all 4! orders cost the same
    for plan in plans:
        replay(plan, kitchen.domain, problem)
    assert source.requests == 2 and source.seconds["total"] >= first.seconds + more.seconds


def test_a_fact_proved_false_or_doubted_changes_the_next_skeleton(
    line: LoadedDomain, line_problem: Problem
) -> None:
    """The line domain's first skeleton places a at the pose sample-pose draws in the goal
    region, and tests that pose's reach. Told that reach fact is false, the source plans
    without it: nothing else reaches the goal, so the goal is unreachable. Told it is doubted,
    it plans without it if it can, and with it when nothing else reaches the goal."""
    source = SkeletonSource(line.domain, line.streams, line_problem)
    first = source.request(1).plans[0]
    tested = [
        s for s in first.stream_plan if s.stream == "test-reachable" and s.inputs[-1][:4] == "opt-"
    ]
    assert tested, [str(s) for s in first.stream_plan]
    fact = tested[0].certified[0]
    doubted = source.request(3, Feedback(doubted=frozenset({fact})))
    assert doubted.plans  # with the doubted fact: nothing else reaches the goal
    assert not source.exhausted_for(Feedback(doubted=frozenset({fact})))
    false = source.request(3, Feedback(false=frozenset({fact})))
    assert false.plans == () and false.exhausted
    assert source.exhausted_for(Feedback(false=frozenset({fact})))


def test_a_doubted_fact_is_planned_around_when_it_can_be() -> None:
    """pickplace-blocked-3: B stands in the red region. The first skeleton places A in red
    beside B (its pose clear of B's, optimistically). With that clearance doubted, the next
    skeleton moves B first."""
    loaded, problem = problem_for_scene("examples/pick_place_2d/scenes/pickplace-blocked-3.json")
    source = SkeletonSource(loaded.domain, loaded.streams, problem)
    first = source.request(1).plans[0]
    assert [a.name for a in first.actions if a.name != "move"] == ["pick", "place"]
    clear = [s for s in first.stream_plan if s.stream == "test-cfree" and s.inputs[2] == "b"]
    assert clear
    doubted = frozenset(a for s in clear for a in s.certified)
    moved = source.request(1, Feedback(doubted=doubted)).plans
    assert moved
    picked = [a.args[0] for a in moved[0].actions if a.name == "pick"]
    assert picked[0] == "b" and "a" in picked  # B out of the way, then A
    replay(moved[0], loaded.domain, problem, loaded.streams)


def test_an_unreachable_goal_and_a_timeout_are_typed_errors(
    line: LoadedDomain, line_problem: Problem
) -> None:
    impossible = replace(
        line_problem, goal=(Literal(Atom("holding", ("a",))), Literal(Atom("hand-empty")))
    )
    with pytest.raises(UnreachableGoalError, match="unreachable even if every stream succeeds"):
        SkeletonSource(line.domain, line.streams, impossible).request(1)
    loaded, problem = problem_for_scene("kitchen-8")
    source = SkeletonSource(loaded.domain, loaded.streams, problem, timeout_s=0.001)
    with pytest.raises(PlannerTimeoutError, match="timed out"):
        source.request(1)

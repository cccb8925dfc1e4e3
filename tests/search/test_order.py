"""The stream order of a tree search: cheap doubtful tests first, never before what they read."""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import replace
from pathlib import Path

import pytest

from planner.abstract import AbstractConfig, plan_abstract
from planner.abstract.skeleton import AbstractPlan
from planner.api import RunConfig, solve
from planner.domains import LoadedDomain, problem_for_scene
from planner.domains.kitchen import MODEL
from planner.pddl.structs import Atom, Problem
from planner.planners import PlanningTask, model_order
from planner.search.binding import stream_contexts
from planner.search.learned import StreamCost
from planner.search.order import dependencies, order_streams, seconds_per_failure


def _fluents() -> frozenset[str]:
    loaded, _ = problem_for_scene("kitchen-1", seed=0)
    return frozenset(
        a.predicate for act in loaded.domain.actions for a in act.add_effects + act.del_effects
    )


FLUENTS = _fluents()


def kitchen(
    scene: str = "kitchen-2", k: int = 3
) -> tuple[
    tuple[AbstractPlan, ...],
    list[list[frozenset[Atom]]],
    dict[str, object],
    tuple[LoadedDomain, Problem],
]:
    loaded, problem = problem_for_scene(scene, seed=0)
    plans = plan_abstract(
        loaded.domain,
        loaded.streams,
        problem,
        AbstractConfig(k=k, diversity_ignore=loaded.spec.diversity_ignore),
    ).plans
    states = [stream_contexts(p, loaded.domain, problem) for p in plans]
    initial: dict[str, object] = {o.name: o.name for o in problem.objects}
    initial.update(problem.values)
    return plans, states, initial, (loaded, problem)


def check_binding_order(
    plan: AbstractPlan,
    states: list[frozenset[Atom]],
    unread: Mapping[str, Collection[str]] | None = None,
) -> None:
    """Every stream's inputs and the context objects its sampler reads are made before it."""
    made: set[str] = set()
    produced = set(plan.optimistic_objects)
    for inst, state in zip(plan.stream_plan, states, strict=True):
        skip = (unread or {}).get(inst.stream, ())
        read = set(inst.inputs) | {
            x for a in state if a.predicate in FLUENTS and a.predicate not in skip for x in a.args
        }
        missing = (read & produced) - made
        assert not missing, f"{inst} reads {missing} before they are bound"
        made.update(inst.outputs)


def test_motions_go_last_and_nothing_is_read_before_it_is_bound() -> None:
    plans, states, _, _ = kitchen()
    plan = plans[0]
    scores = [100.0 if s.stream == "plan-motion" else 0.01 for s in plan.stream_plan]
    ordered, ordered_states = order_streams(plan, states[0], FLUENTS, scores)
    kinds = [s.stream for s in ordered.stream_plan]
    first_motion = kinds.index("plan-motion")
    assert set(kinds[first_motion:]) == {"plan-motion"}  # no cheap test after a motion
    assert kinds[:first_motion] != [s.stream for s in plan.stream_plan][:first_motion]
    # The same streams, each with its own context and first use, in an order that binds.
    assert sorted(map(str, ordered.stream_plan)) == sorted(map(str, plan.stream_plan))
    pairs = dict(
        zip(map(str, plan.stream_plan), zip(states[0], plan.first_use, strict=True), strict=True)
    )
    for inst, state, use in zip(
        ordered.stream_plan, ordered_states, ordered.first_use, strict=True
    ):
        assert pairs[str(inst)] == (state, use)
    assert ordered.actions == plan.actions
    check_binding_order(ordered, ordered_states)


def test_a_placement_waits_for_the_blocks_it_sees_even_when_it_scores_lowest() -> None:
    plans, states, _, _ = kitchen()
    plan, plan_states = plans[0], states[0]
    deps = dependencies(plan, plan_states, FLUENTS)
    # A placement whose context holds another block's placed pose depends on that placement.
    seen = [
        (i, j)
        for i, inst in enumerate(plan.stream_plan)
        for j in deps[i]
        if inst.stream == "sample-placement" and plan.stream_plan[j].stream == "sample-placement"
    ]
    assert seen, "kitchen-2 puts both blocks on the sink and the stove"
    i, j = seen[0]
    scores = [1.0] * len(plan.stream_plan)
    scores[i] = -1.0  # the most wanted stream of all still waits for what it reads
    ordered, _ = order_streams(plan, plan_states, FLUENTS, scores)
    position = {str(s): n for n, s in enumerate(ordered.stream_plan)}
    assert position[str(plan.stream_plan[j])] < position[str(plan.stream_plan[i])]


def test_cheap_and_doubtful_before_dear_and_sure() -> None:
    placement = StreamCost(p_s=0.5, r_s=0.0002, r_f=0.0005, r_m=0.0)
    ik = StreamCost(p_s=0.6, r_s=0.02, r_f=0.02, r_m=0.0)
    motion = StreamCost(p_s=0.99, r_s=2.5, r_f=2.0, r_m=9.0)
    certain = StreamCost(p_s=1.0, r_s=3.0, r_f=0.0, r_m=0.0)
    ratios = [seconds_per_failure(c) for c in (placement, ik, motion, certain)]
    assert ratios == sorted(ratios)
    assert seconds_per_failure(certain) < float("inf")


def test_the_shipped_model_orders_kitchen_4_tests_before_motions() -> None:
    """Motions last; and the placements on the stove come one after another, before the IK
    that stands between them in the plan (a placement does not read where the robot stands),
    so a stove left with no room is blamed on placements alone (kitchen-6 seed 1014: with an
    IK, a grasp and a sink placement between each two stove placements, the search spent
    300 s re-sampling those instead of the stove)."""
    from planner.learning.predictor import ModelPredictor

    plans, states, initial, (loaded, problem) = kitchen("kitchen-4", k=2)
    predictor = ModelPredictor.load(MODEL, domain=loaded)
    unread = loaded.spec.unread
    task = PlanningTask(
        loaded, problem, plans, dict(initial), 0.0, loaded.static_context(problem), list(states)
    )
    task = model_order(task, predictor)
    ordered, ordered_states = task.plans, task.states
    for plan, plan_states in zip(ordered, ordered_states, strict=True):
        kinds = [s.stream for s in plan.stream_plan]
        first_motion = kinds.index("plan-motion")
        assert set(kinds[first_motion:]) == {"plan-motion"}
        check_binding_order(plan, plan_states, unread)
        stove = [
            i
            for i, s in enumerate(plan.stream_plan)
            if s.stream == "sample-placement" and s.inputs[1] == "stove"
        ]
        assert len(stove) == 4
        between = {plan.stream_plan[i].stream for i in range(stove[0], stove[-1])}
        assert "inverse-kinematics" not in between, kinds
    with pytest.raises(AssertionError, match="before they are bound"):
        # Read in full, a placement's context names the configuration and grasp its IK binds.
        check_binding_order(ordered[0], ordered_states[0])


def test_contexts_out_of_binding_order_are_refused() -> None:
    plans, states, _, _ = kitchen()
    plan = plans[0]
    # Swap the plan's streams but not their contexts: a stream would read a later output.
    swapped = replace(
        plan,
        stream_plan=tuple(reversed(plan.stream_plan)),
        first_use=tuple(reversed(plan.first_use)),
    )
    with pytest.raises(ValueError, match="made by a later stream"):
        dependencies(swapped, list(reversed(states[0])), FLUENTS)


def test_an_unknown_order_or_a_model_order_for_sequential_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown stream order 'fastest'"):
        RunConfig(scene="kitchen-1", order="fastest")
    with pytest.raises(ValueError, match="tree searches"):
        RunConfig(scene="kitchen-1", planner="sequential", order="model")
    assert RunConfig(scene="kitchen-1", planner="learned").stream_order == "model"
    # model_order is the learned planner's part; the paper's planner keeps the plans' order.
    assert RunConfig(scene="kitchen-1", planner="learned:model_order=off").stream_order == "plan"
    assert RunConfig(scene="kitchen-1", planner="paper").stream_order == "plan"
    assert RunConfig(scene="kitchen-1", planner="paper:model_order=on").stream_order == "model"
    assert RunConfig(scene="kitchen-1").stream_order == "plan"
    assert RunConfig(scene="kitchen-1", order="model").stream_order == "model"


def test_a_domain_whose_unread_names_an_unknown_stream_is_refused(tmp_path: Path) -> None:
    import shutil

    from planner.domains import DomainLoadError, load_domain

    kitchen_dir = load_domain("kitchen").directory
    for name in ("domain.pddl", "stream.pddl"):
        shutil.copy(kitchen_dir / name, tmp_path / name)
    (tmp_path / "domain.py").write_text(
        "from dataclasses import replace\n"
        "from planner.domains.kitchen import DOMAIN as KITCHEN\n"
        "DOMAIN = replace(KITCHEN, unread={'sample-placment': ('at-conf',)}, directory=None)\n",
        encoding="utf-8",
    )
    with pytest.raises(
        DomainLoadError, match=r"unread names streams not in .*stream\.pddl: sample-placment"
    ):
        load_domain(tmp_path)


ORDER_SCENE = str(Path(__file__).parent / "order_domain" / "scenes" / "order-1.json")


@pytest.mark.parametrize("model_order", ["on", "off"])
def test_the_model_order_finds_the_doubtful_value_before_paying_for_the_dear_one(
    tmp_path: Path, model_order: str
) -> None:
    """model_order, on a domain built for it (tests/search/order_domain): the plan needs a dear
    value that is always found, then a cheap one found one query in four, which does not read
    the first. With priors from recorded baseline runs, the learned planner looks for the
    doubtful value first and pays for the dear one once, when it is sure to be used; off, it
    keeps the plan's order and pays for the dear value before it knows the plan can be bound."""
    from dataclasses import asdict

    from planner.runs import record_run
    from planner.store import RunStore

    db = tmp_path / "priors.db"
    store = RunStore(f"sqlite:///{db}")
    for seed in range(3):
        config = RunConfig(scene=ORDER_SCENE, seed=seed, planner="baseline", budget_s=30)
        run_id = store.create_run(config.scene, seed, config.planner, asdict(config))
        assert record_run(config, store, run_id).status == "solved"
    store.close()
    for seed in range(3):
        config = RunConfig(
            scene=ORDER_SCENE,
            seed=seed,
            planner=f"learned:model_order={model_order}",
            budget_s=30,
            priors_db=str(db),
        )
        result = solve(config).result
        assert result.solved
        streams = [q.stream for q in result.queries]
        found = next(
            i for i, q in enumerate(result.queries) if q.stream == "sample-cheap" and q.success
        )
        dear_before = streams[:found].count("sample-dear")
        if model_order == "on":
            assert streams[0] == "sample-cheap" and dear_before == 0
            assert streams.count("sample-dear") == 1
        else:
            assert streams[0] == "sample-dear" and dear_before >= 1

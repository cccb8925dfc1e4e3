"""The learned policy's arithmetic (Eq. 1 and 4) and decisions, with a hand-written predictor
standing in for trained models on the pure-Python line domain. Each named part of
``LearnedConfig`` has a test here (or in test_reuse.py, test_order.py and
test_language_search.py) whose outcome changes when the part is switched off."""

from __future__ import annotations

import json
import math
import time
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from planner.abstract import AbstractConfig, plan_abstract
from planner.domains import problem_for_scene
from planner.events import Emitter, ListSink, ModelPrediction
from planner.search.binding import stream_contexts
from planner.search.costs import P_FLOOR
from planner.search.learned import (
    EXPLORE_STREAMS,
    LearnedConfig,
    LearnedPolicy,
    StreamCost,
    remaining_cost,
)
from planner.search.mcts import TreeSearch
from planner.search.tree import ROOT

SCENE = str(Path(__file__).parent / "line-reach.json")


def test_equation_1_and_4() -> None:
    assert StreamCost(0.5, 1.0, 2.0, 3.0).expected == pytest.approx(1 + 3 + 1 * 2)
    assert StreamCost(1.0, 1.0, 5.0, 0.0).expected == pytest.approx(1.0)
    floored = StreamCost(0.0, 1.0, 2.0, 0.0).expected  # P_S as given, but never 0
    assert floored == pytest.approx(1 + (1 - P_FLOOR) / P_FLOOR * 2)
    assert remaining_cost([StreamCost(0.5, 1, 2, 3), StreamCost(1, 1, 5, 0)]) == pytest.approx(7)


class CountingPredictor:
    """A hand-written predictor that counts the rows it was asked for."""

    def __init__(self) -> None:
        self.rows = 0

    def predict_rows(
        self, rows: Sequence[tuple[str, Sequence[Any | None], Mapping[str, Any]]]
    ) -> list[StreamCost]:
        self.rows += len(rows)
        return [self.cost(*row) for row in rows]

    def cost(
        self, stream: str, inputs: Sequence[Any | None], context: Mapping[str, Any]
    ) -> StreamCost:
        raise NotImplementedError


class ReachOracle(CountingPredictor):
    """Knows the line-reach rule: a pose beyond x = 2.25 fails the reach test."""

    def cost(
        self, stream: str, inputs: Sequence[Any | None], context: Mapping[str, Any]
    ) -> StreamCost:
        if stream == "test-reachable" and isinstance(inputs[1], float):
            return StreamCost(1.0 if abs(inputs[1]) <= 2.25 else 0.0, 0.01, 0.01, 0.0)
        if stream == "test-reachable":
            return StreamCost(0.4, 0.01, 0.01, 0.0)  # unknown pose: 40% reachable
        return StreamCost(1.0, 0.01, 0.01, 0.0)


def make(
    sink: ListSink, predictor: Any = None, config: LearnedConfig | None = None
) -> tuple[TreeSearch, LearnedPolicy]:
    loaded, problem = problem_for_scene(SCENE, seed=3)
    plans = plan_abstract(loaded.domain, loaded.streams, problem, AbstractConfig(k=4)).plans
    states = [stream_contexts(p, loaded.domain, problem) for p in plans]
    values = {o.name: o.name for o in problem.objects} | dict(problem.values)
    emitter = Emitter("t", sink)

    def emit(node: Any, first: StreamCost, q: float) -> None:
        emitter.emit(
            ModelPrediction,
            node_id=node.id,
            p_s=first.p_s,
            r_s=first.r_s,
            r_f=first.r_f,
            r_m=first.r_m,
            q=q,
        )

    policy = LearnedPolicy(
        predictor or ReachOracle(),
        plans,
        states,
        values,
        lambda v: v,
        frozenset({"at", "in", "holding", "hand-empty"}),
        config or LearnedConfig(),
        on_prediction=emit,
    )
    search = TreeSearch(
        plans, states, values, loaded.runtime(problem, seed=3), policy, emitter=emitter
    )
    return search, policy


def up_to_first_pose(tree: Any, plan: Any, plan_index: int) -> tuple[Any, int, str]:
    """A branch of ``plan`` bound up to its first sample-pose query: (the node that makes that
    query, the query's index, the pose object it binds)."""
    i = next(j for j, s in enumerate(plan.stream_plan) if s.stream == "sample-pose")
    node = tree.add(ROOT, plan_index=plan_index, depth=0, success=True)
    for depth in range(1, i + 1):
        node = tree.add(node.id, plan_index=plan_index, depth=depth, success=True)
    return node, i, plan.stream_plan[i].outputs[0]


def test_learned_search_solves_and_reports_predictions() -> None:
    sink = ListSink()
    search, policy = make(sink)
    result = search.run(deadline=time.perf_counter() + 30)
    assert result.solved
    assert len(search.tree[ROOT].children) == len(search.skeletons)  # all plans scored at once
    predictions = [e for e in sink.events if isinstance(e, ModelPrediction)]
    assert predictions and all(e.q >= 0 for e in predictions)
    # Along the solution, a bound reachable pose makes the rest of the plan cheaper.
    path = search.tree.path(result.node_id or 0)[1:]
    qs = [policy.q(search.tree, search.tree[i]) for i in path]
    assert qs[-1] == 0.0 and qs[0] == max(qs)


class RowHash(CountingPredictor):
    """Predicts from every value of a row, inputs and context alike: a row that a node took
    from its parent although its own binding changed it would show as a different prediction."""

    def cost(
        self, stream: str, inputs: Sequence[Any | None], context: Mapping[str, Any]
    ) -> StreamCost:
        row = [stream, inputs, context]
        h = zlib.crc32(json.dumps(row, sort_keys=True, default=str).encode())
        return StreamCost(0.2 + 0.79 * (h % 1000) / 1000, 0.01, 0.02, 0.0)


def test_a_node_predicts_only_the_rows_its_binding_changed_and_they_match_a_full_recount() -> None:
    search, policy = make(ListSink(), RowHash())
    search.run(deadline=time.perf_counter() + 2)
    tree = search.tree
    predicted = [n for n in tree.nodes[1:] if n.success]
    assert len(predicted) > 5
    # A second policy predicts each node afresh (children first: no parent's rows to take),
    # every row of every node.
    _, fresh = make(ListSink(), RowHash())
    for node in reversed(predicted):
        assert fresh.q(tree, node) == policy.q(tree, node), node
    assert isinstance(policy.predictor, RowHash) and isinstance(fresh.predictor, RowHash)
    assert policy.predictor.rows < fresh.predictor.rows  # some rows came from the parent's


def test_a_bad_binding_makes_querying_again_the_better_action() -> None:
    search, policy = make(ListSink())
    search.run(deadline=time.perf_counter() + 30)
    tree = search.tree
    # Find a sample-pose node whose pose is out of reach and one within reach.
    bad = [n for n in tree.nodes[1:] if n.outputs and abs(next(iter(n.outputs.values()))) > 2.25]
    good = [n for n in tree.nodes[1:] if n.outputs and abs(next(iter(n.outputs.values()))) <= 2.25]
    assert bad and good
    assert policy.q(tree, bad[0]) > 5 * policy.q(tree, good[0])


def test_policy_prefers_the_cheap_certain_branch() -> None:
    search, policy = make(ListSink())
    tree = search.tree
    plan = search.skeletons[0]
    i = next(j for j, s in enumerate(plan.stream_plan) if s.stream == "sample-pose")
    assert all(not s.outputs for s in plan.stream_plan[:i])  # only tests come before
    node = tree.add(ROOT, plan_index=0, depth=0, success=True)
    for depth in range(1, i + 1):  # the tests before it succeeded
        node = tree.add(node.id, plan_index=0, depth=depth, success=True)
    pose = plan.stream_plan[i].outputs[0]
    # Two bindings of the pose: one the gripper reaches, one it cannot.
    certain = tree.add(node.id, plan_index=0, depth=i + 1, success=True, outputs={pose: 1.5})
    unlikely = tree.add(node.id, plan_index=0, depth=i + 1, success=True, outputs={pose: 3.9})
    node.visits, certain.visits, unlikely.visits = 2, 1, 1
    assert policy.q(tree, unlikely) > policy.q(tree, certain)
    assert policy.pick_child(tree, node).id == certain.id
    assert not policy.expand(tree, node)  # a certain child beats sampling the pose again


@pytest.mark.parametrize("dead_ends", [True, False])
def test_a_dead_end_blames_the_last_choice_it_depends_on(dead_ends: bool) -> None:
    """dead_ends (backjumping): b's poses fail their reach test whatever is tried, and the test
    depends on where a stands (a fact of its state); the choices in between bind nothing it
    reads, so the doubt lands on a's pose, and sampling a new pose for a becomes the better
    action. Off: the search goes on trying b."""
    search, policy = make(ListSink(), config=LearnedConfig(dead_ends=dead_ends))
    tree = search.tree
    plan = search.skeletons[0]
    streams = [s.stream for s in plan.stream_plan]
    assert streams[:6] == ["test-reachable", "sample-pose", "test-reachable"] * 2
    a_pose, b_pose = plan.stream_plan[1].outputs[0], plan.stream_plan[4].outputs[0]
    top = tree.add(ROOT, plan_index=0, depth=0, success=True)
    choose_a = tree.add(top.id, plan_index=0, depth=1, success=True)  # next: a's pose
    placed_a = tree.add(choose_a.id, plan_index=0, depth=2, success=True, outputs={a_pose: 2.0})
    reached_a = tree.add(placed_a.id, plan_index=0, depth=3, success=True)
    choose_b = tree.add(reached_a.id, plan_index=0, depth=4, success=True)  # next: b's pose
    poses_b = [
        tree.add(choose_b.id, plan_index=0, depth=5, success=True, outputs={b_pose: x})
        for x in (1.5, 2.1)
    ]
    for node in (top, choose_a, placed_a, reached_a, choose_b, *poses_b):
        node.visits = 3
    policy.pick_plan(tree)
    assert not policy.expand(tree, choose_a)  # a's pose looks fine: go on with it
    # One of b's poses fails its reach test twice in a row (one failure is never a dead end):
    # that stays with b's pose (the other is untried).
    for _ in range(2):
        tree.add(poses_b[0].id, plan_index=0, depth=6, success=False)
    policy.pick_plan(tree)
    assert placed_a.id not in policy.dead
    assert not policy.expand(tree, choose_a)
    # Both fail, more than P_S = 1 explains: every pose for b fails with a where it is.
    tree.add(poses_b[1].id, plan_index=0, depth=6, success=False)
    policy.pick_plan(tree)
    assert placed_a.id not in policy.dead  # once is chance
    tree.add(poses_b[1].id, plan_index=0, depth=6, success=False)
    policy.pick_plan(tree)
    if not dead_ends:
        assert not policy.dead
        assert not policy.expand(tree, choose_a)
        return
    assert {p.id for p in poses_b} | {choose_b.id, reached_a.id, placed_a.id} <= set(policy.dead)
    assert choose_a.id not in policy.dead  # the one that chooses a's pose: choose again
    assert policy.expand(tree, choose_a)  # now: sample another pose for a


@pytest.mark.parametrize("given", [True, False])
def test_a_known_failure_backjumps_to_what_its_state_holds(given: bool) -> None:
    """exhausted_given: b's pose sampler (here reading the whole state it is given) found
    nothing and said it will not, and the same failure came back as a known one: what it was
    given is its inputs and the objects of its state, which holds a at its pose, so the search
    backjumps over the choices in between to a's pose and samples another. Off: a's pose
    stays live (one known failure is explained by its own prediction)."""
    search, policy = make(ListSink(), config=LearnedConfig(exhausted_given=given))
    tree = search.tree
    plan = search.skeletons[0]
    a_pose = plan.stream_plan[1].outputs[0]
    top = tree.add(ROOT, plan_index=0, depth=0, success=True)
    choose_a = tree.add(top.id, plan_index=0, depth=1, success=True)  # next: a's pose
    placed_a = tree.add(choose_a.id, plan_index=0, depth=2, success=True, outputs={a_pose: 2.0})
    reached_a = tree.add(placed_a.id, plan_index=0, depth=3, success=True)
    choose_b = tree.add(reached_a.id, plan_index=0, depth=4, success=True)  # next: b's pose
    assert a_pose in policy._given(choose_b)  # (at a opt-p) is a fact of b's pose's state
    tree.add(choose_b.id, plan_index=0, depth=5, success=False)
    choose_b.exhausted = choose_b.known_failure = True
    for node in (top, choose_a, placed_a, reached_a, choose_b):
        node.visits = 3
    policy.pick_plan(tree)
    if not given:
        assert placed_a.id not in policy.dead
        assert not policy.expand(tree, choose_a)
        return
    assert {choose_b.id, reached_a.id, placed_a.id} <= set(policy.dead)
    assert choose_a.id not in policy.dead
    assert policy.expand(tree, choose_a)  # sample another pose for a


class SureOracle(ReachOracle):
    """Like :class:`ReachOracle`, but b's reach test is sure to pass (P_S 0.999)."""

    def cost(
        self, stream: str, inputs: Sequence[Any | None], context: Mapping[str, Any]
    ) -> StreamCost:
        if stream == "test-reachable" and isinstance(inputs[1], float) and inputs[1] > 1.0:
            return StreamCost(0.999, 0.01, 0.01, 0.0)
        return super().cost(stream, inputs, context)


def _failing_b(config: LearnedConfig, failures: int) -> tuple[LearnedPolicy, Any]:
    """b's reach test at a pose of 1.5 fails ``failures`` times: (policy, the node making it)."""
    search, policy = make(ListSink(), SureOracle(), config)
    tree = search.tree
    plan = search.skeletons[0]
    a_pose, b_pose = plan.stream_plan[1].outputs[0], plan.stream_plan[4].outputs[0]
    node = tree.add(ROOT, plan_index=0, depth=0, success=True)
    for depth, outputs in enumerate(({}, {a_pose: 0.5}, {}, {}, {b_pose: 1.5}), start=1):
        node = tree.add(node.id, plan_index=0, depth=depth, success=True, outputs=outputs)
    for _ in range(failures):
        tree.add(node.id, plan_index=0, depth=6, success=False)
    policy.pick_plan(tree)
    return policy, node


def test_one_failure_is_never_a_dead_end() -> None:
    """However sure the model is, a node becomes a dead end only after failures in a row: one
    failed query predicted at 0.999 is chance (a try landing where a block stands), not a
    reason to throw a bound plan away; two are a dead end."""
    policy, tester = _failing_b(LearnedConfig(), failures=1)
    assert tester.id not in policy.dead
    policy, tester = _failing_b(LearnedConfig(), failures=2)
    assert tester.id in policy.dead


def test_every_node_a_rollout_makes_gets_a_prediction() -> None:
    """The page colours every node by its predicted cost: the nodes of the last rollout (the
    solution's branch) are predicted too, though the search ends with that rollout."""
    sink = ListSink()
    search, _ = make(sink)
    result = search.run(deadline=time.perf_counter() + 30)
    assert result.solved
    predicted = {e.node_id for e in sink.events if isinstance(e, ModelPrediction)}
    tree = search.tree
    branch = tree.path(result.node_id or 0)[1:-1]  # below the root, above the bound leaf
    assert branch and set(branch) <= predicted
    made = [
        n.id
        for n in tree.nodes[1:]
        if n.success and n.depth < len(search.skeletons[n.plan_index].stream_plan)
    ]
    assert set(made) <= predicted


@pytest.mark.parametrize("subtree_min", [True, False])
def test_progress_below_a_node_makes_it_the_one_to_follow(subtree_min: bool) -> None:
    """subtree_min: two results of the same first test look alike, but below one of them the
    search has already bound a reachable pose for a: its subtree's lowest Q vouches for it, and
    the policy follows it. Off, each is judged by its own Q, the same for both, and the first
    one made wins the tie."""
    config = LearnedConfig(c_explore=0.0, subtree_min=subtree_min)
    search, policy = make(ListSink(), config=config)
    tree = search.tree
    plan = search.skeletons[0]
    a_pose = plan.stream_plan[1].outputs[0]
    top = tree.add(ROOT, plan_index=0, depth=0, success=True)
    untried = tree.add(top.id, plan_index=0, depth=1, success=True)
    explored = tree.add(top.id, plan_index=0, depth=1, success=True)
    placed = tree.add(explored.id, plan_index=0, depth=2, success=True, outputs={a_pose: 1.0})
    for node in (top, untried, explored, placed):
        node.visits = 2
    policy.pick_plan(tree)
    assert policy.q(tree, untried) == pytest.approx(policy.q(tree, explored))
    assert policy.pick_child(tree, top).id == (explored.id if subtree_min else untried.id)


@pytest.mark.parametrize("plans_by_estimate", [True, False])
def test_the_search_goes_back_to_the_plan_it_has_started(plans_by_estimate: bool) -> None:
    """plans_by_estimate: two stream plans predicted alike, one started (its first test bound,
    visited often), the other never tried. On, the started plan's progress decides and the search
    goes back down it; off (UCT among plans, as the paper), the exploration bonus of the untried
    plan outweighs that progress and the search leaves the started plan for it."""
    config = LearnedConfig(c_explore=1.0, plans_by_estimate=plans_by_estimate)
    search, policy = make(ListSink(), config=config)
    tree = search.tree
    started = tree.add(ROOT, plan_index=0, depth=0, success=True)
    untried = tree.add(ROOT, plan_index=0, depth=0, success=True)
    bound = tree.add(started.id, plan_index=0, depth=1, success=True)
    tree[ROOT].visits = started.visits = bound.visits = 20
    policy.pick_plan(tree)
    assert policy.q(tree, started) == pytest.approx(policy.q(tree, untried))
    assert policy.q(tree, bound) < policy.q(tree, started)
    assert policy.pick_plan(tree).id == (started.id if plans_by_estimate else untried.id)


@pytest.mark.parametrize("by_length", [True, False])
def test_a_long_stream_plan_explores_in_proportion_less(by_length: bool) -> None:
    """explore_by_length: up to EXPLORE_STREAMS streams a plan has UCT's weight c_explore; a
    plan five times as long has a fifth of it (kitchen-20's 180 streams: 0.01), so a bonus
    competes with value differences that shrink as the plan grows. Off: c_explore at every
    length. The paper's planner keeps it off."""
    search, policy = make(ListSink(), config=LearnedConfig(explore_by_length=by_length))
    short = search.skeletons[0]
    assert len(short.stream_plan) <= EXPLORE_STREAMS
    times = 5 * EXPLORE_STREAMS // len(short.stream_plan)
    long = replace(
        short, stream_plan=tuple(short.stream_plan) * times, first_use=short.first_use * times
    )
    policy.plans_added([short, long], [search.states[0], search.states[0] * times])
    weight = policy.config.c_explore
    assert policy._bonus(3, 100, 0) == pytest.approx(weight * math.sqrt(math.log(101) / 4))
    ratio = policy._bonus(3, 100, 1) / policy._bonus(3, 100, 0)
    n = len(long.stream_plan)
    assert ratio == pytest.approx(EXPLORE_STREAMS / n if by_length else 1.0)
    assert LearnedConfig.paper().explore_by_length is False

"""The learned policy's arithmetic (Eq. 1 and 4) and decisions, with a hand-written predictor
standing in for trained models on the pure-Python line domain. Each named part of
``LearnedConfig`` has a test here (or in test_reuse.py, test_order.py and
test_language_search.py) whose outcome changes when the part is switched off."""

from __future__ import annotations

import json
import time
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pytest

from planner.abstract import AbstractConfig, plan_abstract
from planner.domains import problem_for_scene
from planner.events import Emitter, ListSink, ModelPrediction
from planner.search.binding import stream_contexts
from planner.search.costs import P_FLOOR
from planner.search.learned import (
    DEAD_END_MAX,
    LearnedConfig,
    LearnedPolicy,
    StreamCost,
    remaining_cost,
    with_dead_ends,
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


def test_dead_ends_scale_the_rest_of_the_plan() -> None:
    """A prediction below the stream's usual success rate is a dead end in that part: with
    chance F that the rest is feasible, Eq. 4's cost is paid 1 / F times."""
    usual = StreamCost(0.6, 1.0, 1.0, 0.0, p_prior=0.6)
    assert usual.dead_end == 0.0  # failing as often as usual is chance, not a dead end
    assert StreamCost(0.9, 1.0, 1.0, 0.0, p_prior=0.6).dead_end == 0.0
    crowded = StreamCost(0.15, 1.0, 1.0, 0.0, p_prior=0.6)
    assert crowded.dead_end == pytest.approx(0.75)  # 1 - 0.15 / 0.6
    assert StreamCost(0.0, 1.0, 1.0, 0.0, p_prior=0.6).dead_end == pytest.approx(DEAD_END_MAX)
    assert StreamCost(0.1, 1.0, 1.0, 0.0).dead_end == 0.0  # no prior rate: Eq. 4 as it is
    assert with_dead_ends(10.0, 0.25) == pytest.approx(40.0)
    assert with_dead_ends(10.0, 0.0) == pytest.approx(10.0 / (1 - DEAD_END_MAX))
    # The crowded stove: a placement that fails in milliseconds barely moves Eq. 4, so a branch
    # whose last placement will not fit looks cheaper than one with a longer motion ...
    crowded = [StreamCost(0.05, 0.001, 0.001, 0.0, p_prior=0.9), StreamCost(1.0, 1.0, 0.0, 0.0)]
    clear = [StreamCost(0.9, 0.001, 0.001, 0.0, p_prior=0.9), StreamCost(1.0, 1.5, 0.0, 0.0)]
    assert remaining_cost(crowded) < remaining_cost(clear)

    def q(costs: list[StreamCost]) -> float:
        feasible = 1.0
        for c in costs:
            feasible *= 1.0 - c.dead_end
        return with_dead_ends(remaining_cost(costs), feasible)

    assert q(crowded) > 5 * q(clear)  # ... and with dead ends it is the one to avoid


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


class SureOracle(ReachOracle):
    """Like :class:`ReachOracle`, but b's reach test is sure to pass (P_S 0.999), and its
    stream usually passes 90% of the time; with ``doubt``, the model instead predicts 0.03 for
    it (far below the usual rate: it foresees the failure)."""

    def __init__(self, doubt: bool = False) -> None:
        super().__init__()
        self.doubt = doubt

    def cost(
        self, stream: str, inputs: Sequence[Any | None], context: Mapping[str, Any]
    ) -> StreamCost:
        if stream == "test-reachable" and isinstance(inputs[1], float) and inputs[1] > 1.0:
            return StreamCost(0.03 if self.doubt else 0.999, 0.01, 0.01, 0.0, p_prior=0.9)
        return super().cost(stream, inputs, context)


def _failing_b(config: LearnedConfig, doubt: bool, failures: int) -> tuple[LearnedPolicy, Any]:
    """b's reach test at a pose of 1.5 fails ``failures`` times: (policy, the node making it)."""
    search, policy = make(ListSink(), SureOracle(doubt), config)
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
    policy, tester = _failing_b(LearnedConfig(), doubt=False, failures=1)
    assert tester.id not in policy.dead
    policy, tester = _failing_b(LearnedConfig(), doubt=False, failures=2)
    assert tester.id in policy.dead


@pytest.mark.parametrize("prior", [True, False])
def test_a_failure_the_model_foresaw_is_a_dead_end_sooner(prior: bool) -> None:
    """dead_end_prior: a query predicted far below its stream's usual rate (0.03 against 0.9)
    is, to the model, likely a dead end, and failures confirm it: two make it one. Without the
    prior, two failures are what 0.03 explains: the search goes on insisting (76 would be
    needed)."""
    config = LearnedConfig(dead_end_prior=prior)
    policy, tester = _failing_b(config, doubt=True, failures=2)
    assert (tester.id in policy.dead) is prior


class CrowdedOracle(ReachOracle):
    """Like :class:`ReachOracle`, but sampling a pose fails one time in five, in milliseconds
    (as a placement on a crowded stove does), and a reach test takes a second (as a motion
    does)."""

    def predict_rows(
        self, rows: Sequence[tuple[str, Sequence[Any | None], Mapping[str, Any]]]
    ) -> list[StreamCost]:
        out = super().predict_rows(rows)
        return [
            StreamCost(0.8, 0.001, 0.001, 0.0)
            if stream == "sample-pose"
            else StreamCost(cost.p_s, 1.0, 1.0, 0.0)
            for (stream, _, _), cost in zip(rows, out, strict=True)
        ]


def crowded_search(
    config: LearnedConfig | None = None,
) -> tuple[TreeSearch, LearnedPolicy, str, Any]:
    """A line search under :class:`CrowdedOracle`: (search, policy, a's pose object, the first
    plan's node, added by hand)."""
    search, policy = make(ListSink(), config=config)
    policy.predictor = CrowdedOracle()
    a_pose = search.skeletons[0].stream_plan[1].outputs[0]
    top = search.tree.add(ROOT, plan_index=0, depth=0, success=True)
    return search, policy, a_pose, top


def shared_pose_tree(
    b_poses: Sequence[float], config: LearnedConfig | None = None
) -> tuple[LearnedPolicy, Any, Any, Any, list[Any]]:
    """a placed at 2.0 once; below it, one branch per pose of b in ``b_poses``, each up to
    b's reach test: (policy, tree, the node choosing a's pose, the node binding it, the nodes
    making b's reach test)."""
    search, policy = make(ListSink(), config=config)
    tree = search.tree
    plan = search.skeletons[0]
    a_pose, b_pose = plan.stream_plan[1].outputs[0], plan.stream_plan[4].outputs[0]
    top = tree.add(ROOT, plan_index=0, depth=0, success=True)
    choose_a = tree.add(top.id, plan_index=0, depth=1, success=True)
    placed_a = tree.add(choose_a.id, plan_index=0, depth=2, success=True, outputs={a_pose: 2.0})
    reached_a = tree.add(placed_a.id, plan_index=0, depth=3, success=True)
    choose_b = tree.add(reached_a.id, plan_index=0, depth=4, success=True)
    testers = [
        tree.add(choose_b.id, plan_index=0, depth=5, success=True, outputs={b_pose: x})
        for x in b_poses
    ]
    for node in (top, choose_a, placed_a, reached_a, choose_b, *testers):
        node.visits = 3
    return policy, tree, choose_a, placed_a, testers


@pytest.mark.parametrize("shared", [True, False])
def test_a_query_failing_under_varied_later_choices_blames_the_earlier_ones_it_shares(
    shared: bool,
) -> None:
    """b's reach test reads a's pose and b's. It fails once under each of three poses of b the
    model takes for reachable: no single query failed twice, but every failure shared a's pose,
    so a's pose is the dead end and the search samples a new one (kitchen-4 seed 1009 with 96
    IK base poses: the last block's stove placement failed 99 times, each under a new place of
    the block before it, while the first blocks' places that left no room were never
    re-sampled). Without shared_culprits nothing blames a's pose."""
    config = LearnedConfig(shared_culprits=shared)
    policy, search_tree, choose_a, placed_a, testers = shared_pose_tree([1.5, 1.7, 1.9], config)
    for node in testers[:2]:
        search_tree.add(node.id, plan_index=0, depth=6, success=False)
    policy.pick_plan(search_tree)
    assert placed_a.id not in policy.dead  # twice could be the poses of b
    assert not policy.expand(search_tree, choose_a)
    search_tree.add(testers[2].id, plan_index=0, depth=6, success=False)
    policy.pick_plan(search_tree)
    if not shared:
        assert placed_a.id not in policy.dead
        assert not policy.expand(search_tree, choose_a)
        return
    assert placed_a.id in policy.dead and all(t.id in policy.dead for t in testers)
    assert choose_a.id not in policy.dead  # the one to choose again
    assert policy.expand(search_tree, choose_a)  # now: sample another pose for a


def test_a_success_under_the_shared_choices_clears_them() -> None:
    """The same failures, but one pose of b passed its test with a where it is: a's pose is not
    what makes b's test fail, so it is not blamed."""
    policy, tree, choose_a, placed_a, testers = shared_pose_tree([1.5, 1.7, 1.9, 0.5])
    for node in testers[:3]:
        tree.add(node.id, plan_index=0, depth=6, success=False)
    tree.add(testers[3].id, plan_index=0, depth=6, success=True)
    policy.pick_plan(tree)
    assert placed_a.id not in policy.dead
    assert not policy.expand(tree, choose_a)


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

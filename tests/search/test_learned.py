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
from planner.search.learned import (
    DEAD_END_MAX,
    P_MIN,
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
    clamped = StreamCost(0.0, 1.0, 2.0, 0.0).expected
    assert clamped == pytest.approx(1 + (1 - P_MIN) / P_MIN * 2)
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
    tree, fresh = search.tree, RowHash()
    predicted = [n for n in tree.nodes[1:] if n.id in policy._terms]
    assert len(predicted) > 5
    full = 0
    for node in predicted:
        values = {**policy.initial_values, **tree.bindings(node.id)}
        rows = policy._rows(node.plan_index, node.depth, values)
        full += len(rows)
        assert policy._terms[node.id] == list(
            zip([policy._key(r) for r in rows], fresh.predict_rows(rows), strict=True)
        )
    assert isinstance(policy.predictor, RowHash)
    assert policy.predictor.rows < full  # some rows came from the parent's (50 of 66 here)


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


def test_failures_make_insisting_costlier_and_a_success_makes_it_cheaper() -> None:
    from planner.search.learned import ITERATION_S, StreamCost, after_attempts

    cost = StreamCost(p_s=0.5, r_s=0.01, r_f=0.001, r_m=0.0)
    assert after_attempts(cost, 0, 0) == pytest.approx(cost.expected)
    insisting = [after_attempts(cost, 0, n) for n in range(0, 30, 3)]
    assert insisting == sorted(insisting) and insisting[-1] > 1000  # a dead end, eventually
    # prior of a dead end: 1 - P_S = 0.5; 3 failures: P(feasible) = 0.5 * 0.125 /
    # (0.5 * 0.125 + 0.5) = 1/9, and the chance of success is half of it
    p = 0.5 * (0.5 * 0.125) / (0.5 * 0.125 + 0.5)
    assert after_attempts(cost, 0, 3) == pytest.approx(0.01 + (1 - p) / p * (0.001 + ITERATION_S))
    # one success proves the binding feasible: p = (2 * 0.5 + 1) / (2 + 1 + 3) = 1/3
    assert after_attempts(cost, 1, 3) == pytest.approx(0.01 + 2.0 * (0.001 + ITERATION_S))
    assert after_attempts(cost, 1, 3) < after_attempts(cost, 0, 3)


@pytest.mark.parametrize("pooled", [True, False])
def test_the_same_query_from_two_nodes_pools_its_outcomes(pooled: bool) -> None:
    """pooled_evidence: the failures of a query made from one node make the same query from
    another node look costlier too; off, each node learns from its own attempts only."""
    search, policy = make(ListSink(), config=LearnedConfig(pooled_evidence=pooled))
    tree = search.tree
    node, i, pose = up_to_first_pose(tree, search.skeletons[0], 0)
    first = tree.add(node.id, plan_index=0, depth=i + 1, success=True, outputs={pose: 2.0})
    twin = tree.add(node.id, plan_index=0, depth=i + 1, success=True, outputs={pose: 2.0})
    other = tree.add(node.id, plan_index=0, depth=i + 1, success=True, outputs={pose: 1.0})
    before = [policy.q(tree, n) for n in (first, twin, other)]
    for _ in range(6):  # the next query fails from the first node, again and again
        tree.add(first.id, plan_index=0, depth=i + 2, success=False)
    policy.pick_plan(tree)  # each iteration starts by counting the outcomes so far
    after = [policy.q(tree, n) for n in (first, twin, other)]
    assert after[0] > before[0]
    if pooled:
        assert after[1] == pytest.approx(after[0])  # the twin learns too
    else:
        assert after[1] == pytest.approx(before[1])  # the twin has not tried
    assert after[2] == pytest.approx(before[2])  # another query does not


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
    q_before = policy.q(tree, choose_a)
    # One of b's poses fails its reach test twice in a row (one failure is never a dead end):
    # that stays with b's pose (the other is untried).
    for _ in range(2):
        tree.add(poses_b[0].id, plan_index=0, depth=6, success=False)
    policy.pick_plan(tree)
    assert policy.q(tree, choose_a) == pytest.approx(q_before)
    assert not policy.expand(tree, choose_a)
    # Both fail, more than P_S = 1 explains: every pose for b fails with a where it is.
    tree.add(poses_b[1].id, plan_index=0, depth=6, success=False)
    policy.pick_plan(tree)
    assert policy.q(tree, choose_a) == pytest.approx(q_before)  # once is chance
    tree.add(poses_b[1].id, plan_index=0, depth=6, success=False)
    policy.pick_plan(tree)
    if not dead_ends:
        assert policy.q(tree, choose_a) == pytest.approx(q_before) and not policy.dead
        assert not policy.expand(tree, choose_a)
        return
    assert policy.q(tree, choose_a) > 2 * q_before
    assert policy.expand(tree, choose_a)  # now: sample another pose for a


def test_a_bound_trajectory_counts_its_execution_seconds() -> None:
    """bound_execution: total time is planning plus execution: of two bindings alike but for
    how long the robot will take to execute them, the policy goes on with the shorter one, and a
    long one makes binding it again worth its planning seconds. Off, the two look the same."""
    off, off_policy = make(ListSink(), config=LearnedConfig(bound_execution=False))
    node, i, pose = up_to_first_pose(off.tree, off.skeletons[0], 0)
    slow, quick = (
        off.tree.add(
            node.id, plan_index=0, depth=i + 1, success=True, outputs={pose: 1.5}, execution_s=s
        )
        for s in (9.0, 2.0)
    )
    assert off_policy.q(off.tree, slow) == pytest.approx(off_policy.q(off.tree, quick))
    search, policy = make(ListSink())
    tree = search.tree
    node, i, pose = up_to_first_pose(tree, search.skeletons[0], 0)
    slow = tree.add(
        node.id, plan_index=0, depth=i + 1, success=True, outputs={pose: 1.5}, execution_s=9.0
    )
    quick = tree.add(
        node.id, plan_index=0, depth=i + 1, success=True, outputs={pose: 1.5}, execution_s=2.0
    )
    node.visits, slow.visits, quick.visits = 2, 1, 1
    assert policy.q(tree, slow) - policy.q(tree, quick) == pytest.approx(7.0)
    assert policy.pick_child(tree, node).id == quick.id
    # Below the slow one, the seconds stay counted: progress does not hide them.
    below = tree.add(slow.id, plan_index=0, depth=i + 2, success=True)
    assert policy.q(tree, below) >= 9.0
    # Alone, a binding that takes far longer to execute than sampling again costs is dropped.
    other, k, pose1 = up_to_first_pose(tree, search.skeletons[1], 1)
    lone = tree.add(
        other.id, plan_index=1, depth=k + 1, success=True, outputs={pose1: 1.5}, execution_s=60.0
    )
    other.visits, lone.visits = 5, 5
    policy.pick_plan(tree)
    assert policy.expand(tree, other)


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


def test_the_same_query_failing_under_choices_it_does_not_read_is_a_dead_end() -> None:
    """Failures of one query count together across the nodes that make it (same inputs, same
    relevant state), as long as it never succeeded. b's pose fails to sample once after each of
    two choices it does not read, and the doubt lands on a's pose. A failure that costs
    milliseconds barely raises the cost of trying again, so only the dead end makes the search
    go back (kitchen-4 seed 1000: the last stove placement failed once after each of 13 new
    grasps, IK solutions and motions of that block, and the crowded stove was never blamed)."""
    search, policy, a_pose, top = crowded_search()
    tree = search.tree
    choose_a = tree.add(top.id, plan_index=0, depth=1, success=True)
    placed_a = tree.add(choose_a.id, plan_index=0, depth=2, success=True, outputs={a_pose: 2.0})
    reached_a = tree.add(placed_a.id, plan_index=0, depth=3, success=True)
    twins = [tree.add(reached_a.id, plan_index=0, depth=4, success=True) for _ in range(2)]
    for node in (top, choose_a, placed_a, reached_a, *twins):
        node.visits = 3
    tree.add(twins[0].id, plan_index=0, depth=5, success=False)  # b's pose: no room
    policy.pick_plan(tree)
    q_before = policy.q(tree, choose_a)
    assert not policy.expand(tree, choose_a)  # once is chance
    tree.add(twins[1].id, plan_index=0, depth=5, success=False)  # the same query, again
    policy.pick_plan(tree)
    assert policy._estimate(tree, placed_a) > 5 * q_before
    assert policy.expand(tree, choose_a)  # now: sample another pose for a


@pytest.mark.parametrize("calibration", [True, False])
def test_children_worse_than_predicted_make_querying_again_look_worse_too(
    calibration: bool,
) -> None:
    """calibration: a new child is predicted from masked inputs; children that all come out
    seconds worse (here: poses the model expects to execute in no time take 5 to 7 s) raise the
    cost of querying again, so after a few the search goes on with the best one instead of
    sampling for ever in the hope of the predicted average. Off, it keeps sampling."""
    config = LearnedConfig(c_explore=0.0, calibration=calibration)  # values only: no bonus
    search, policy = make(ListSink(), config=config)
    tree = search.tree
    node, i, pose = up_to_first_pose(tree, search.skeletons[0], 0)
    policy.pick_plan(tree)
    alone = policy.q(tree, node)
    kids = [
        tree.add(
            node.id, plan_index=0, depth=i + 1, success=True, outputs={pose: 1.5}, execution_s=s
        )
        for s in (7.0, 6.0)
    ]
    node.visits = 3
    for kid in kids:
        kid.visits = 1
    policy.pick_plan(tree)
    if not calibration:
        assert policy.q(tree, node) == pytest.approx(alone)
        best = tree.add(
            node.id, plan_index=0, depth=i + 1, success=True, outputs={pose: 1.5}, execution_s=5.0
        )
        best.visits, node.visits = 1, 4
        policy.pick_plan(tree)
        assert policy.expand(tree, node)  # the predicted average looks better than any child
        return
    # the two surprises, 7 s and 6 s, over 2 children plus the half a child the guess weighs
    assert policy.q(tree, node) == pytest.approx(alone + (7.0 + 6.0) / 2.5, abs=0.05)
    assert policy.expand(tree, node)  # two so far: the model's guess still weighs
    best = tree.add(
        node.id, plan_index=0, depth=i + 1, success=True, outputs={pose: 1.5}, execution_s=5.0
    )
    best.visits, node.visits = 1, 4
    policy.pick_plan(tree)
    assert not policy.expand(tree, node)  # 5 s is as good as a new one is likely to be
    assert policy.pick_child(tree, node).id == best.id


@pytest.mark.parametrize("pooled", [True, False])
def test_an_attempt_that_has_not_reached_the_failures_does_not_stop_the_pooling(
    pooled: bool,
) -> None:
    """Three nodes make the same query (a's pose, after the same test). Two of its results led
    to dead ends (b's pose finds no room, twice each); the third has not been tried further
    yet. That fresh attempt proves nothing, so the failures still pool and the makers of the
    doomed results are dead ends (kitchen-4 seed 1025: every re-sampled grasp made a new maker
    of the third block's stove placement, and its unexplored child kept the crowded stove from
    being blamed for 521 placements). Without pooled_evidence, each maker counts its own two
    failures only, too few to be a dead end."""
    search, policy, a_pose, top = crowded_search(LearnedConfig(pooled_evidence=pooled))
    tree = search.tree
    makers = [tree.add(top.id, plan_index=0, depth=1, success=True) for _ in range(3)]
    placed = [
        tree.add(m.id, plan_index=0, depth=2, success=True, outputs={a_pose: 2.0}) for m in makers
    ]
    nodes = [top, *makers, *placed]
    for i in (0, 2):  # these two bindings of a's pose leave b no room
        reached = tree.add(placed[i].id, plan_index=0, depth=3, success=True)
        tested = tree.add(reached.id, plan_index=0, depth=4, success=True)
        nodes += [reached, tested]
        for _ in range(2):
            tree.add(tested.id, plan_index=0, depth=5, success=False)
    for node in nodes:
        node.visits = 3
    policy.pick_plan(tree)
    dead = policy.dead
    if not pooled:
        assert makers[0].id not in dead and makers[2].id not in dead
        return
    assert placed[0].id in dead and placed[2].id in dead and placed[1].id not in dead
    assert makers[0].id in dead and makers[2].id in dead  # one dead child each, pooled to two
    assert makers[1].id not in dead  # its own attempt is still open


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
    config = LearnedConfig(c_explore=0.0, calibration=False, subtree_min=subtree_min)
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


@pytest.mark.parametrize("clamp", [True, False])
def test_a_near_zero_prediction_does_not_make_a_cheap_query_look_endless(clamp: bool) -> None:
    """p_clamp: a query the model gives P_S of 1e-9, at a millisecond a try, costs 49 ms by Eq.
    1 with P_S clamped at 0.02 (cheaper than a one-second query the model is sure of: worth a
    try); without the clamp (only the floor of 1e-6) it costs 1,000 s, and nothing makes it
    worth trying."""
    from planner.search.costs import expected

    config = LearnedConfig(p_clamp=clamp)
    hopeless = expected(StreamCost(1e-9, 0.001, 0.001, 0.0), p_min=config.p_min)
    sure = expected(StreamCost(1.0, 1.0, 1.0, 0.0), p_min=config.p_min)
    assert (hopeless < sure) is clamp
    assert hopeless == pytest.approx(0.001 + 0.98 / 0.02 * 0.001 if clamp else 1000.0, rel=1e-3)

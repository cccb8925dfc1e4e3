"""eTAMP's PW-UCT rules against hand-computed cases."""

from __future__ import annotations

import math

import pytest

from planner.abstract import AbstractPlan, GroundAction, StreamInstance
from planner.search.baseline import (
    BaselineConfig,
    failure_value,
    should_widen,
    success_value,
    ucb,
)
from planner.search.mcts import BaselinePolicy
from planner.search.tree import ROOT, Tree

CFG = BaselineConfig()


def test_ucb_matches_the_formula() -> None:
    assert ucb(0.5, 0, 10, 0.1) == math.inf
    assert ucb(0.5, 4, 10, 0.1) == pytest.approx(0.5 + 0.1 * math.sqrt(math.log(10) / 4))
    assert ucb(0.2, 1, 1, 1.1) == pytest.approx(0.2)  # ln 1 = 0


@pytest.mark.parametrize(
    ("visits", "children", "widen"),
    [(0, 0, True), (13, 1, False), (14, 1, True), (54, 2, False), (55, 2, True)],
)
def test_progressive_widening_threshold(visits: int, children: int, widen: bool) -> None:
    assert should_widen(visits, children, CFG.widen_k) is widen


def test_leaf_values() -> None:
    assert failure_value(3, 10, CFG) == pytest.approx(0.03)
    assert failure_value(0, 10, CFG) == 0.0
    assert success_value([1.0, 1.0], CFG) == pytest.approx(1 + 2 * 0.1 * math.exp(-1))


def test_root_opens_plans_by_its_own_widening_rule() -> None:
    policy = BaselinePolicy(CFG)
    tree = Tree()
    assert policy.add_plan(tree, 0, 5)  # the first plan always
    tree.add(ROOT, plan_index=0, depth=0, success=True)
    tree[ROOT].visits = 6
    assert not policy.add_plan(tree, 1, 5)  # 6 > 6 * 1^2 is false
    tree[ROOT].visits = 7
    assert policy.add_plan(tree, 1, 5)
    assert not policy.add_plan(tree, 5, 5)  # no plan left


def test_selection_prefers_unvisited_then_value() -> None:
    policy = BaselinePolicy(CFG)
    tree = Tree()
    plan = tree.add(ROOT, plan_index=0, depth=0, success=True)
    a = tree.add(plan.id, plan_index=0, depth=1, success=True)
    b = tree.add(plan.id, plan_index=0, depth=1, success=True)
    tree.add(plan.id, plan_index=0, depth=1, success=False)  # failed queries are never picked
    plan.visits, a.visits, a.value = 3, 3, 0.9
    assert policy.pick_child(tree, plan).id == b.id  # unvisited first
    b.visits, b.value = 1, 0.2
    assert policy.pick_child(tree, plan).id == a.id
    # 3 children and 3 visits: no widening; with 122 visits: 122 > 13.5 * 9.
    assert not policy.expand(tree, plan)
    plan.visits = 122
    assert policy.expand(tree, plan)


def test_failure_deeper_in_the_plan_is_worth_more() -> None:
    policy = BaselinePolicy(CFG)
    tree = Tree()
    streams = tuple(StreamInstance(f"s{i}", (), (f"opt-x{i}",), (), (), 1) for i in range(4))
    skeleton = AbstractPlan((GroundAction("noop", ()),) * 2, streams, 2.0)
    plan = tree.add(ROOT, plan_index=0, depth=0, success=True)
    shallow = tree.add(plan.id, plan_index=0, depth=1, success=False)  # stream 0 failed
    ok = tree.add(plan.id, plan_index=0, depth=1, success=True)
    ok2 = tree.add(ok.id, plan_index=0, depth=2, success=True)
    deep = tree.add(ok2.id, plan_index=0, depth=3, success=False)  # stream 2 failed
    assert policy.leaf_value(shallow, skeleton) == 0.0
    assert policy.leaf_value(deep, skeleton) == pytest.approx(0.1 * 2 / 4)

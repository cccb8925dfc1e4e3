"""The learned policy (Bradley & Roy): UCT over the expected remaining cost of a stream plan.

A node's value is -Q, Q the expected seconds still to spend on its plan (Eq. 4): for each
remaining stream, R_S + R_M + (1 - P_S) / P_S * R_F, predicted by per-stream models from the
stream's inputs (zero and masked where not bound yet) and the scene. "Query this stream again"
is scored by the same formula, so there is no progressive-widening rule. The models are reached
through the :class:`Predictor` protocol, so this module needs no torch.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from planner.abstract.skeleton import AbstractPlan
from planner.pddl.structs import Atom
from planner.search.tree import ROOT, Node, Tree

P_MIN = 0.02  # P_S is clamped here: a stream never looks hopeless (Eq. 1 divides by it)


@dataclass(frozen=True)
class StreamCost:
    """Predicted outcome and costs of one stream query (seconds)."""

    p_s: float
    r_s: float
    r_f: float
    r_m: float

    @property
    def expected(self) -> float:
        """Eq. 1: expected seconds to get one success, execution included."""
        p = min(max(self.p_s, P_MIN), 1.0)
        return self.r_s + self.r_m + (1.0 - p) / p * self.r_f


def remaining_cost(costs: Sequence[StreamCost]) -> float:
    """Eq. 4: expected seconds for the rest of a stream plan."""
    return sum(c.expected for c in costs)


class Predictor(Protocol):
    """Batched predictions: one (stream, encoded inputs or None, context) per row."""

    def predict_rows(
        self, rows: Sequence[tuple[str, Sequence[Any | None], Mapping[str, Any]]]
    ) -> list[StreamCost]: ...


@dataclass(frozen=True)
class LearnedConfig:
    c_explore: float = 0.05  # UCT exploration weight on normalised values (paper: UCT)


@dataclass
class LearnedPolicy:
    """UCT with value -Q (normalised to (0, 1] by the best plan's Q) and no widening rule."""

    predictor: Predictor
    skeletons: Sequence[AbstractPlan]
    states: Sequence[Sequence[frozenset[Atom]]]
    initial_values: Mapping[str, Any]
    encode: Callable[[Any], Any]
    fluents: frozenset[str]
    config: LearnedConfig = field(default_factory=LearnedConfig)
    on_prediction: Callable[[Node, StreamCost, float], None] | None = None
    _q: dict[int, float] = field(default_factory=dict)
    _best: dict[int, float] = field(default_factory=dict)  # lowest Q reached below a node
    _tree: Tree | None = None
    _scale: float = 0.0

    # --- Q of a node -------------------------------------------------------------------------

    def _rows(
        self, plan_index: int, depth: int, values: Mapping[str, Any]
    ) -> list[tuple[str, list[Any | None], dict[str, Any]]]:
        plan = self.skeletons[plan_index]
        rows = []
        for i in range(depth, len(plan.stream_plan)):
            inst = plan.stream_plan[i]
            inputs = [self.encode(values[n]) if n in values else None for n in inst.inputs]
            facts = sorted(a for a in self.states[plan_index][i] if a.predicate in self.fluents)
            names = {x for a in facts for x in a.args}
            context = {
                "facts": [[a.predicate, *a.args] for a in facts],
                "values": {
                    n: self.encode(values[n])
                    for n in sorted(names)
                    if n in values and not isinstance(values[n], str)
                },
            }
            rows.append((inst.stream, inputs, context))
        return rows

    def q(self, tree: Tree, node: Node) -> float:
        """Expected remaining seconds of ``node``'s plan from its next stream on (cached)."""
        if node.id in self._q:
            return self._q[node.id]
        values = {**self.initial_values, **tree.bindings(node.id)}
        rows = self._rows(node.plan_index, node.depth, values)
        costs = self.predictor.predict_rows(rows) if rows else []
        q = remaining_cost(costs)
        self._q[node.id] = q
        if self.on_prediction is not None and costs:
            self.on_prediction(node, costs[0], q)
        return q

    def _estimate(self, tree: Tree, node: Node) -> float:
        """The node's Q, or the lowest Q reached below it: progress in a plan counts."""
        return min(self.q(tree, node), self._best.get(node.id, math.inf))

    def _value(self, q: float) -> float:
        return self._scale / (self._scale + q) if self._scale > 0 else 1.0 / (1.0 + q)

    def _bonus(self, visits: int, parent_visits: int) -> float:
        return self.config.c_explore * math.sqrt(math.log(parent_visits + 1) / (visits + 1))

    # --- the Policy protocol -----------------------------------------------------------------

    def initial_plans(self, total: int) -> int:
        return total  # every stream plan is scored from the start

    def add_plan(self, tree: Tree, plans_added: int, plans_total: int) -> bool:
        return plans_added < plans_total  # only if initial_plans left some closed

    def pick_plan(self, tree: Tree) -> Node:
        self._tree = tree
        root = tree[ROOT]
        plans = [tree[c] for c in root.children]
        if self._scale <= 0:
            self._scale = max(min(self.q(tree, p) for p in plans), 1e-3)
        return max(
            plans,
            key=lambda n: self._value(self._estimate(tree, n)) + self._bonus(n.visits, root.visits),
        )

    def expand(self, tree: Tree, node: Node) -> bool:
        live = tree.live_children(node.id)
        if not live:
            return True
        again = self._value(self.q(tree, node)) + self._bonus(len(node.children), node.visits)
        best = max(self._value(self.q(tree, c)) + self._bonus(c.visits, node.visits) for c in live)
        return again > best

    def pick_child(self, tree: Tree, node: Node) -> Node:
        return max(
            tree.live_children(node.id),
            key=lambda c: self._value(self._estimate(tree, c)) + self._bonus(c.visits, node.visits),
        )

    def leaf_value(self, leaf: Node, plan: AbstractPlan) -> float:
        """Back up the lowest Q reached (by the leaf, or before a failed query) to the root."""
        if self._tree is not None:
            # A failed query still shows how far the plan got: its parent's Q.
            reached = leaf if leaf.success or leaf.parent is None else self._tree[leaf.parent]
            q = self.q(self._tree, reached)
            for i in self._tree.path(reached.id):
                self._best[i] = min(self._best.get(i, math.inf), q)
        return 1.0 if leaf.success else 0.0

"""What failed queries teach the learned search, apart from the policy that reads it.

- **Dead ends** (``dead_ends``): a node whose next query has failed, or led only to dead ends,
  more often in a row than its prediction explains (:func:`planner.search.costs.dead_after`).
  Its reason is the objects those failures depend on; if the node's own outputs are not among
  them, re-sampling them cannot help, so its parent is a dead end too, and so on up to the node
  that bound something the failures depend on (backjumping). A dead end counts as a failed
  attempt of its parent's query.

They are kept up to date as the tree grows: a refresh costs what its new nodes change, not the
whole tree (the search's own seconds per node stay flat as the tree grows). A node is a dead end
while anything marks it: its own failures, or a dead end below it whose reason it did not bind.
Its reason is the union of its marks' reasons, so backjumping stops at the nearest node that
bound anything a failure below depends on.
"""

from __future__ import annotations

import heapq
import math
from collections import Counter
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Protocol

from planner.search.costs import (
    DEAD_END_DOUBT,
    DEAD_END_MIN,
    P_FLOOR,
    StreamCost,
    dead_after,
)
from planner.search.tree import ROOT, Node, Tree

_Source = int  # a dead end's source: the node whose own failures make it


class NodeQueries(Protocol):
    """What the evidence reads of a node that queries: its next query's prediction (None while
    the node is not predicted) and the objects that query's outcome depends on (its inputs and
    the objects of the fluent facts that matter)."""

    def first(self, node: Node) -> StreamCost | None: ...

    def relevant(self, node: Node) -> set[str]: ...

    def precise(self, node: Node) -> bool:
        """Whether ``relevant`` is what the next query reads (not the whole state, which a
        sampler given the context may read)."""
        ...

    def given(self, node: Node) -> set[str]:
        """The objects the next query's answer is a function of, as the search's memory of
        known failures keys it: its inputs and the objects of every fluent fact of the state
        it is given (nothing left out as a guess)."""
        ...


@dataclass
class Evidence:
    """Dead ends as of the last :meth:`refresh` (see the module)."""

    queries: NodeQueries
    dead_ends: bool = True  # dead_ends
    # An exhausted node (its stream said it has nothing more for these inputs) with nothing
    # live below is a dead end at once, whatever its prediction (LearnedConfig.exhausted_dead).
    exhausted_dead: bool = True
    # With exhausted_dead: where the sampler reads the whole state it is given, a node whose
    # query came back as a known failure is a dead end too, its reason every object of that
    # state and its inputs (what the search's memory of the failure keys on:
    # LearnedConfig.exhausted_given).
    exhausted_given: bool = True
    # Per dead node: its reason (the union of its marks' reasons).
    reasons: dict[int, frozenset[str]] = field(default_factory=dict)
    _seen: int = 0
    _marks: dict[int, dict[_Source, frozenset[str]]] = field(default_factory=dict)
    _chains: dict[_Source, tuple[frozenset[str], list[int]]] = field(default_factory=dict)
    _live: Counter[int] = field(default_factory=Counter)  # per node: children alive
    _below: dict[int, Counter[str]] = field(default_factory=dict)  # dead children's reasons
    _threshold: dict[int, int] = field(default_factory=dict)
    _changed: set[int] = field(default_factory=set)
    _queue: list[int] = field(default_factory=list)
    _queued: set[int] = field(default_factory=set)
    _survivals: dict[int, float] = field(default_factory=dict)  # see _survival

    @property
    def dead(self) -> Mapping[int, frozenset[str]]:
        """The nodes taken for dead ends (with their reasons), as of the last refresh."""
        return self.reasons

    def refresh(self, tree: Tree) -> set[int]:
        """Take in the tree's new nodes; returns the nodes that became or stopped being dead
        ends."""
        self._changed = set()
        new = tree.nodes[max(self._seen, 1) :]
        self._seen = len(tree.nodes)
        if not self.dead_ends:
            return set()
        for node in new:
            parent = node.parent
            if parent is None or parent == ROOT:
                continue
            if node.success:
                self._live[parent] += 1
            self._push(parent)
        while self._queue:
            node_id = -heapq.heappop(self._queue)
            self._queued.discard(node_id)
            self._evaluate(tree, tree[node_id])
        changed, self._changed = self._changed, set()
        return changed

    # --- a node's own failures ---------------------------------------------------------------

    def _push(self, node_id: int) -> None:
        if node_id != ROOT and node_id not in self._queued:
            self._queued.add(node_id)
            heapq.heappush(self._queue, -node_id)  # deepest (newest) first: children, then parents

    def _threshold_of(self, node: Node, first: StreamCost) -> int:
        found = self._threshold.get(node.id)
        if found is None:
            found = self._threshold[node.id] = dead_after(first.p_s)
        return found

    def _evaluate(self, tree: Tree, node: Node) -> None:
        """Whether the node's own failures make it a dead end, and why. An exhausted node
        with nothing live below is one at once (with ``exhausted_dead``, where what its query
        reads is known, :meth:`_exhausted_reads`): its stream will give nothing more, so its
        reason is what its failed queries (if any) and the dead ends below it depend on."""
        reason: frozenset[str] | None = None
        first = self.queries.first(node) if node.success and node.depth > 0 else None
        if first is not None and node.children and not self._live[node.id]:
            below = frozenset(self._below.get(node.id) or ())
            if self._unexplained(tree, node, first):
                reason = frozenset(self.queries.relevant(node)) | below
            elif self.exhausted_dead and node.exhausted:
                reads = self._exhausted_reads(node)
                if reads is not None:
                    failed = any(not tree[c].success for c in node.children)
                    reason = below | (reads if failed else frozenset())
        self._set_source(tree, node.id, node, reason)

    def _exhausted_reads(self, node: Node) -> frozenset[str] | None:
        """What an exhausted node's failed queries depend on, where that is known (None: not
        known, the node is left alone): what its sampler reads (its inputs and declared
        fluents, but for those a failure is taken not to depend on), or, for a sampler that
        reads the whole state it is given whose failure came back as a known one
        (``exhausted_given``), its inputs and every object of that state: the same failure
        came back for the same ones, whatever was re-sampled in between."""
        if self.queries.precise(node):
            return frozenset(self.queries.relevant(node))
        if self.exhausted_given and node.known_failure:
            return frozenset(self.queries.given(node))
        return None

    def _unexplained(self, tree: Tree, node: Node, first: StreamCost) -> bool:
        """Whether the node's children, none of them alive, failed more often than the
        predictions explain: each failed child (or dead end below) counts as a failure of the
        node's query (:func:`dead_after` of its prediction). A child that died exhausted (its
        one-answer streams below said false: with ``exhausted_dead``) failed as often as the
        predictions of the queries down to its failure say: with a placement predicted sure but
        its collision tests doubtful, many placements may die before the node above is to blame."""
        children = node.children
        if not self.exhausted_dead or not any(
            tree[c].exhausted and tree[c].success for c in children
        ):
            return len(children) >= self._threshold_of(node, first)
        if len(children) < DEAD_END_MIN:
            return False
        doubt = 0.0
        for c in children:
            child = tree[c]
            chance = first.p_s
            if child.success and child.exhausted:
                chance = self._survival(tree, child, first.p_s)
            doubt += math.log(max(1.0 - min(max(chance, P_FLOOR), 1.0), P_FLOOR))
        return doubt < math.log(DEAD_END_DOUBT)

    def _survival(self, tree: Tree, child: Node, p_s: float) -> float:
        """The predicted chance that ``child`` (made with chance ``p_s``) got past the queries
        below it down to its failure: the product of their predictions along the way (kept
        once computed: a dead child's subtree grows no more)."""
        found = self._survivals.get(child.id)
        if found is not None:
            return found
        chance = p_s
        current = child
        while current.children:
            predicted = self.queries.first(current)
            if predicted is not None:
                chance *= predicted.p_s
            failed = [c for c in current.children if not tree[c].success]
            current = tree[failed[0]] if failed else tree[current.children[0]]
        if child.dead:
            self._survivals[child.id] = chance
        return chance

    # --- marks -------------------------------------------------------------------------------

    def _set_source(
        self, tree: Tree, source: _Source, node: Node, reason: frozenset[str] | None
    ) -> None:
        """Mark ``node`` (and its ancestors up to the one that bound part of ``reason``) as a
        dead end for ``source``; None: ``source`` marks nothing any more."""
        old = self._chains.get(source)
        if (old[0] if old else None) == reason:
            return
        touched: list[int] = []
        if old is not None:
            for n in old[1]:
                del self._marks[n][source]
                touched.append(n)
            del self._chains[source]
        if reason is not None:
            chain = _chain(tree, node, reason)
            self._chains[source] = (reason, chain)
            for n in chain:
                self._marks.setdefault(n, {})[source] = reason
                touched.append(n)
        for n in dict.fromkeys(touched):
            self._settle(tree, tree[n])

    def _settle(self, tree: Tree, node: Node) -> None:
        """The node's reason from its marks; its parent hears of any change."""
        marks = self._marks.get(node.id)
        now = frozenset().union(*marks.values()) if marks else None
        if not marks:
            self._marks.pop(node.id, None)
        before = self.reasons.get(node.id)
        if now == before:
            return
        if now is None:
            del self.reasons[node.id]
        else:
            self.reasons[node.id] = now
        if (before is None) != (now is None):
            self._changed ^= {node.id}
        parent = node.parent
        if parent is None or parent == ROOT:
            return
        if node.success and (before is None) != (now is None):
            self._live[parent] += -1 if now is not None else 1
        outputs = set(node.outputs)
        below = self._below.setdefault(parent, Counter())
        if before is not None:
            below.subtract(n for n in before if n not in outputs)
        if now is not None:
            below.update(n for n in now if n not in outputs)
        for name in [n for n, k in below.items() if k <= 0]:
            del below[name]
        self._push(parent)


def _chain(tree: Tree, node: Node, reason: Iterable[str]) -> list[int]:
    """``node`` and its ancestors up to the first that bound part of ``reason`` (not the plan's
    node at depth 0): the nodes a dead end for ``reason`` at ``node`` makes dead ends too."""
    reason = set(reason)
    current = node
    chain = [current.id]
    while not (set(current.outputs) & reason) and current.parent is not None:
        parent = tree[current.parent]
        if parent.depth == 0 or parent.id == ROOT:
            break
        chain.append(parent.id)
        current = parent
    return chain

"""What failed queries teach the learned search, apart from the policy that reads it.

- **Dead ends** (``dead_ends``): a node whose next query has failed, or led only to dead ends,
  more often in a row than its prediction explains (:func:`planner.search.costs.dead_after`).
  Its reason is the objects those failures depend on; if the node's own outputs are not among
  them, re-sampling them cannot help, so its parent is a dead end too, and so on up to the node
  that bound something the failures depend on (backjumping). A dead end counts as a failed
  attempt of its parent's query.
- **Shared culprits** (``shared_culprits``): a query that keeps failing while a later choice it
  depends on varies is blamed on the earlier choices every failure shared (the same query is
  then never asked twice, so nothing else ties the failures together).

Both are kept up to date as the tree grows: a refresh costs what its new nodes change, not the
whole tree (the search's own seconds per node stay flat as the tree grows). A node is a dead end
while anything marks it: its own failures, or a dead end below it whose reason it did not bind,
or a shared culprit. Its reason is the union of its marks' reasons, so backjumping stops at the
nearest node that bound anything a failure below depends on.
"""

from __future__ import annotations

import heapq
import json
from collections import Counter
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from planner.search.costs import StreamCost, dead_after
from planner.search.tree import ROOT, Node, Tree

SHARED_MIN = 3  # failures under varied later choices before the earlier ones they share are blamed

_Source = tuple[str, int]  # ("own", node): its own failures; ("shared", node): a shared culprit


class NodeQueries(Protocol):
    """What the evidence reads of a node that queries: its next query's prediction (None while
    the node is not predicted) and the objects that query's outcome depends on (its inputs and
    the objects of the fluent facts that matter)."""

    def first(self, node: Node) -> StreamCost | None: ...

    def relevant(self, node: Node) -> set[str]: ...


@dataclass
class _Aggregate:
    """The members of a group that agree on the values bound up to one depth."""

    members: list[int] = field(default_factory=list)
    failing: int = 0  # members whose query never succeeded
    children: int = 0  # attempts made from the members
    queries: Counter[tuple[str, ...]] = field(default_factory=Counter)  # their whole queries


@dataclass
class _Group:
    """The nodes that make one stream's query of one plan (one depth of it), for shared culprits:
    the depths that bound the values their query depends on, and per depth the members that
    agree on the values bound up to it."""

    names: tuple[str, ...] = ()  # the values the query depends on, sorted
    bound_at: tuple[int, ...] = ()  # the depth that bound each (0: the problem's own)
    cuts: tuple[int, ...] = ()  # depths to cut at, deepest first (the query's own left out)
    members: set[int] = field(default_factory=set)
    failing: set[int] = field(default_factory=set)
    latest: list[int] = field(default_factory=list)  # max-heap (negated) of failing members
    by_cut: dict[int, dict[tuple[str, ...], _Aggregate]] = field(default_factory=dict)
    blamed: tuple[int, tuple[str, ...]] | None = None  # the (cut, values) blamed last
    marked: int = 0  # how many of the blamed aggregate's members carry its mark


@dataclass
class Evidence:
    """Dead ends as of the last :meth:`refresh` (see the module)."""

    queries: NodeQueries
    encode: Callable[[Any], Any]
    initial_values: Mapping[str, Any]
    dead_ends: bool = True  # dead_ends
    shared_culprits: bool = True  # shared_culprits
    use_prior: bool = True  # dead_end_prior: a foreseen dead end is dead sooner
    # Per dead node: its reason (the union of its marks' reasons).
    reasons: dict[int, frozenset[str]] = field(default_factory=dict)
    _seen: int = 0
    _marks: dict[int, dict[_Source, frozenset[str]]] = field(default_factory=dict)
    _chains: dict[_Source, tuple[frozenset[str], list[int]]] = field(default_factory=dict)
    _live: Counter[int] = field(default_factory=Counter)  # per node: children alive
    _ok: Counter[int] = field(default_factory=Counter)  # per node: children that succeeded
    _below: dict[int, Counter[str]] = field(default_factory=dict)  # dead children's reasons
    _threshold: dict[int, int] = field(default_factory=dict)
    _groups: dict[tuple[int, int], _Group] = field(default_factory=dict)
    _stale: set[tuple[int, int]] = field(default_factory=set)
    _keys: dict[int, tuple[tuple[str, ...], list[tuple[str, ...]]]] = field(default_factory=dict)
    _changed: set[int] = field(default_factory=set)
    _queue: list[int] = field(default_factory=list)
    _queued: set[int] = field(default_factory=set)

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
                self._ok[parent] += 1
            self._push(parent)
            if self.shared_culprits:
                self._join(tree, tree[parent], node)
        for key in sorted(self._stale):
            self._blame(tree, self._groups[key])
        self._stale.clear()
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
            prior = first.p_prior if self.use_prior else None
            found = self._threshold[node.id] = dead_after(first.p_s, p_prior=prior)
        return found

    def _evaluate(self, tree: Tree, node: Node) -> None:
        """Whether the node's own failures make it a dead end, and why."""
        reason: frozenset[str] | None = None
        first = self.queries.first(node) if node.success and node.depth > 0 else None
        if (
            first is not None
            and node.children
            and not self._live[node.id]
            and len(node.children) >= self._threshold_of(node, first)
        ):
            below = self._below.get(node.id)
            reason = frozenset(self.queries.relevant(node)) | frozenset(below or ())
        self._set_source(tree, ("own", node.id), node, reason)

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

    # --- shared culprits ---------------------------------------------------------------------

    def _join(self, tree: Tree, maker: Node, child: Node) -> None:
        """Count ``child`` as an attempt of ``maker``'s query in its group."""
        if not maker.success or maker.depth == 0 or self.queries.first(maker) is None:
            return
        key = (maker.plan_index, maker.depth)
        group = self._groups.get(key)
        if maker.id not in self._keys:
            whole, cuts, group = self._signature(tree, maker, group)
            self._groups[key] = group
            self._keys[maker.id] = (whole, cuts)
            group.members.add(maker.id)
            group.failing.add(maker.id)
            heapq.heappush(group.latest, -maker.id)
            for cut, values in zip(group.cuts, cuts, strict=True):
                agg = group.by_cut.setdefault(cut, {}).setdefault(values, _Aggregate())
                agg.members.append(maker.id)
                agg.failing += 1
                agg.queries[whole] += 1
        assert group is not None
        whole, cuts = self._keys[maker.id]
        stopped = child.success and self._ok[maker.id] == 1  # its first success, just counted
        if stopped:
            group.failing.discard(maker.id)
        for cut, values in zip(group.cuts, cuts, strict=True):
            agg = group.by_cut[cut][values]
            agg.children += 1
            if stopped:
                agg.failing -= 1
        self._stale.add(key)

    def _signature(
        self, tree: Tree, node: Node, group: _Group | None
    ) -> tuple[tuple[str, ...], list[tuple[str, ...]], _Group]:
        """The encoded values ``node``'s query depends on (equal values compare equal), and
        those bound up to each of its group's cuts; the group itself if it is new."""
        values = dict(self.initial_values)
        bound_at: dict[str, int] = {}
        for i in tree.path(node.id):
            for name, value in tree[i].outputs.items():
                values[name] = value
                bound_at[name] = tree[i].depth
        if group is None:
            names = tuple(sorted(n for n in self.queries.relevant(node) if n in values))
            depths = tuple(bound_at.get(n, 0) for n in names)
            group = _Group(names, depths, tuple(sorted(set(depths), reverse=True)[1:]))
        encoded = tuple(
            json.dumps(self.encode(values[n]), sort_keys=True, default=str) if n in values else ""
            for n in group.names
        )
        cuts = [
            tuple(v for v, d in zip(encoded, group.bound_at, strict=True) if d <= cut)
            for cut in group.cuts
        ]
        return encoded, cuts, group

    def _blame(self, tree: Tree, group: _Group) -> None:
        """Take the latest member whose query failed every time it was made, and the values it
        depends on; from the deepest choice up, drop the values bound last until the members
        agreeing on the rest have failed at least :data:`SHARED_MIN` times (and as often as
        ``dead_after`` asks) with no success among them, and differ in what was dropped. Those
        members are dead ends because of the values kept, and the search backs up to the last
        of them."""
        while group.latest and -group.latest[0] not in group.failing:
            heapq.heappop(group.latest)
        found: tuple[int, tuple[str, ...]] | None = None
        if len(group.failing) >= SHARED_MIN and group.latest:
            latest = tree[-group.latest[0]]
            first = self.queries.first(latest)
            assert first is not None
            need = max(SHARED_MIN, self._threshold_of(latest, first))
            for cut, values in zip(group.cuts, self._keys[latest.id][1], strict=True):
                agg = group.by_cut[cut][values]
                if agg.failing != len(agg.members):
                    break  # a success shares these values: so would every shallower cut's
                if agg.children < need or len(agg.queries) < 2:
                    continue  # too few failures, or the same query each time
                found = (cut, values)
                break
        if found != group.blamed:
            if group.blamed is not None:
                for m in group.by_cut[group.blamed[0]][group.blamed[1]].members:
                    self._set_source(tree, ("shared", m), tree[m], None)
            group.blamed, group.marked = found, 0
        if found is None:
            return
        cut, _ = found
        reason = frozenset(n for n, d in zip(group.names, group.bound_at, strict=True) if d <= cut)
        members = group.by_cut[cut][found[1]].members
        for m in members[group.marked :]:
            self._set_source(tree, ("shared", m), tree[m], reason)
        group.marked = len(members)


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

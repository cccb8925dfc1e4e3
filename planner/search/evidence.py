"""What failed queries teach the learned search, apart from the policy that reads it.

- **Outcomes of a query** (``attempt_posterior``, ``pooled_evidence``): how often a node's next
  query succeeded and failed from it; pooled, over every node that makes the same query (one
  identity, :func:`planner.search.queries.query_identity`), so a failure seen anywhere counts.
- **Dead ends** (``dead_ends``): a node whose next query has failed, or led only to dead ends,
  more often in a row than its prediction explains (:func:`planner.search.costs.dead_after`).
  Its reason is the objects those failures depend on; if the node's own outputs are not among
  them, re-sampling them cannot help, so its parent is a dead end too, and so on up to the node
  that bound something the failures depend on (backjumping). A dead end counts as a failed
  attempt of its parent's query.
- **Shared culprits** (``shared_culprits``): a query that keeps failing while a later choice it
  depends on varies is blamed on the earlier choices every failure shared (the same query is
  then never asked twice, so its identity alone cannot pool it).

:class:`Evidence` recomputes all of it at each refresh from the tree and from what the policy
knows of each node (:class:`NodeQueries`); it holds no policy state.
"""

from __future__ import annotations

import bisect
import heapq
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from planner.search.costs import P_MAX, P_MIN, StreamCost, dead_after
from planner.search.tree import ROOT, Node, Tree

SHARED_MIN = 3  # failures under varied later choices before the earlier ones they share are blamed
MAX_ROUNDS = 64  # rounds of dead ends failing their parents' queries (a fixpoint comes first)


class NodeQueries(Protocol):
    """What the evidence reads of a node that queries: the identity of its next query (None
    while an input is unbound), that query's prediction, and the objects its outcome depends
    on (its inputs and the objects of the facts of its identity)."""

    def key(self, node: Node) -> str | None: ...

    def first(self, node: Node) -> StreamCost | None: ...

    def relevant(self, node: Node) -> set[str]: ...


@dataclass
class Evidence:
    """Outcomes and dead ends as of the last :meth:`refresh` (see the module)."""

    queries: NodeQueries
    encode: Callable[[Any], Any]
    initial_values: Mapping[str, Any]
    pooled: bool = True  # pooled_evidence
    dead_ends: bool = True  # dead_ends
    shared_culprits: bool = True  # shared_culprits
    use_prior: bool = True  # dead_end_prior: a foreseen dead end is dead sooner
    p_min: float = P_MIN
    p_max: float = P_MAX
    groups: dict[str, list[int]] = field(default_factory=dict)  # identity -> nodes that make it
    counts: dict[str, tuple[int, int]] = field(default_factory=dict)  # identity -> ok, failed
    dead: set[int] = field(default_factory=set)
    _sigs: dict[int, tuple[dict[str, str], dict[str, int]]] = field(default_factory=dict)
    # What refreshes keep up to date: nodes seen, the deepest success below each node, nodes
    # whose children all failed, queries with a failed attempt, the nodes of each stream of
    # each plan that query from it (and which of those groups changed), each group's culprits.
    _seen: int = 0
    _deepest: dict[int, int] = field(default_factory=dict)
    _failing: set[int] = field(default_factory=set)
    _failed_keys: set[str] = field(default_factory=set)
    _members: dict[tuple[int, int], list[int]] = field(default_factory=dict)
    _member_set: set[int] = field(default_factory=set)
    _stale_groups: set[tuple[int, int]] = field(default_factory=set)
    _culprits: dict[tuple[int, int], list[tuple[Node, set[str]]]] = field(default_factory=dict)
    # Per query identity: its attempts that failed (with the least depth among them) and those
    # that succeeded; per node: how many failures in a row make it a dead end.
    _attempts_failed: dict[str, list[int]] = field(default_factory=dict)
    _failed_depth: dict[str, int] = field(default_factory=dict)
    _attempts_ok: dict[str, list[int]] = field(default_factory=dict)
    _threshold: dict[int, int] = field(default_factory=dict)
    _keys: dict[int, str] = field(default_factory=dict)  # node -> its next query's identity

    def add_maker(self, key: str, node: int) -> None:
        """``node``'s children are attempts of the query ``key``."""
        self.groups.setdefault(key, []).append(node)

    def outcomes(self, tree: Tree, node: Node | None, key: str | None) -> tuple[int, int] | None:
        """(ok, failed) attempts of query ``key`` as ``node``'s next query (``node`` None: a
        query further ahead). Pooled: over every node that makes it; else ``node``'s own
        attempts only (none for a query further ahead). A dead end is a failed attempt."""
        if self.pooled:
            return self.counts.get(key) if key is not None else None
        if node is None or not node.children:
            return None
        ok = sum(1 for c in node.children if tree[c].success and c not in self.dead)
        return ok, len(node.children) - ok

    @property
    def any(self) -> bool:
        """Whether any outcome is known (nothing to update otherwise)."""
        return bool(self.counts) if self.pooled else True

    def refresh(self, tree: Tree) -> set[str]:
        """Dead ends, then the outcomes of every query made (outcomes only, never measured
        seconds: the same seed makes the same search); returns the queries whose outcomes
        changed. Incremental: what the tree's new nodes change is updated, the rest kept."""
        new = tree.nodes[max(self._seen, 1) :]
        self._seen = len(tree.nodes)
        touched: set[int] = set()  # nodes with new children: their queries' outcomes changed
        for node in new:
            self._grow(tree, node)
            if node.parent is not None:
                touched.add(node.parent)
        before = self.dead
        self.dead = self._dead_ends(tree, touched) if self.dead_ends else set()
        for node_id in before ^ self.dead:
            parent = tree[node_id].parent
            if parent is not None:
                touched.add(parent)
        changed: set[str] = set()
        for key in {k for n in touched if (k := self._maker_key(tree, n)) is not None}:
            ok = failed = 0
            for n in self.groups.get(key, ()):
                for c in tree[n].children:
                    if tree[c].success and c not in self.dead:
                        ok += 1
                    else:
                        failed += 1
            now = (ok, failed) if ok or failed else None
            if now != self.counts.get(key):
                changed.add(key)
                if now is None:
                    del self.counts[key]
                else:
                    self.counts[key] = now
        return changed

    def _maker_key(self, tree: Tree, node_id: int) -> str | None:
        """The identity of the query ``node_id``'s children are attempts of (None: none)."""
        if node_id == ROOT:
            return None
        found = self._keys.get(node_id)
        if found is None:
            found = self.queries.key(tree[node_id])
            if found is not None:  # known once the node is predicted, and fixed from then on
                self._keys[node_id] = found
        return found

    def _grow(self, tree: Tree, node: Node) -> None:
        """Take in a new node: the deepest success below each ancestor, which nodes have only
        failed children, which queries have a failed attempt, which groups changed."""
        depth = node.depth if node.success else -1
        self._deepest[node.id] = max(self._deepest.get(node.id, -1), depth)
        current = node.parent
        while current is not None and self._deepest.get(current, -1) < depth:
            self._deepest[current] = depth
            current = tree[current].parent
        parent = node.parent
        if parent is None or parent == ROOT:
            return
        if node.success:
            self._failing.discard(parent)
        elif not any(tree[c].success for c in tree[parent].children):
            self._failing.add(parent)
        key = self._maker_key(tree, parent)
        if key is not None:
            if node.success:
                self._attempts_ok.setdefault(key, []).append(node.id)
            else:
                self._failed_keys.add(key)
                self._attempts_failed.setdefault(key, []).append(node.id)
                depth_now = self._failed_depth.get(key)
                if depth_now is None or node.depth < depth_now:
                    self._failed_depth[key] = node.depth
        maker = tree[parent]
        if maker.success and maker.depth > 0 and self.queries.first(maker) is not None:
            group = (maker.plan_index, maker.depth)
            members = self._members.setdefault(group, [])
            if maker.id not in self._member_set:
                self._member_set.add(maker.id)
                bisect.insort(members, maker.id)
            self._stale_groups.add(group)

    # --- dead ends ---------------------------------------------------------------------------

    def _dead_after(self, cost: StreamCost) -> int:
        prior = cost.p_prior if self.use_prior else None
        return dead_after(cost.p_s, p_prior=prior, p_min=self.p_min, p_max=self.p_max)

    def _threshold_of(self, node: Node, first: StreamCost) -> int:
        found = self._threshold.get(node.id)
        if found is None:
            found = self._threshold[node.id] = self._dead_after(first)
        return found

    def _dead_ends(self, tree: Tree, touched: set[int]) -> set[int]:
        """Nodes whose every continuation is taken to fail (see the module), to a fixpoint: a
        new dead end fails its parent's query, which may make the parent one. A fresh attempt
        elsewhere that has not yet reached the failing depth does not stop the pooling. Only
        nodes with no live child can be dead ends: those whose children all failed, and the
        parents of dead ends."""
        dead: dict[int, set[str]] = {}  # node -> the objects its failures depend on
        origin: dict[int, int] = {}  # dead node -> depth of the failures behind it
        shared = self._shared_culprits(tree) if self.shared_culprits else []
        for _ in range(MAX_ROUNDS):  # new dead ends fail their parents' queries: pool again
            pooled = self._pooled_failures(tree, dead, origin) if self.pooled else {}
            before = len(dead), sum(len(r) for r in dead.values())
            for node, reason in shared:
                if dead.get(node.id) == reason:
                    continue
                depth = min(origin.get(c, tree[c].depth) for c in node.children)
                _mark(tree, dead, origin, node, reason, depth)
            parents = {tree[d].parent for d in dead} - {None, ROOT}
            heap = [-n for n in self._failing | parents if n is not None]
            heapq.heapify(heap)
            queued = {-h for h in heap}
            while heap:
                node = tree[-heapq.heappop(heap)]
                if node.id in dead or not node.success or node.depth == 0:
                    continue
                first = self.queries.first(node)
                if first is None or not node.children:
                    continue  # complete, or not queried from yet
                if any(tree[c].success and c not in dead for c in node.children):
                    continue
                key = self._maker_key(tree, node.id)
                failures = max(len(node.children), pooled.get(key, 0) if key is not None else 0)
                if failures < self._threshold_of(node, first):
                    continue
                reason = self.queries.relevant(node)
                depth = min(origin.get(c, tree[c].depth) for c in node.children)
                for c in node.children:
                    if c in dead:
                        reason |= dead[c] - set(tree[c].outputs)
                for marked in _mark(tree, dead, origin, node, reason, depth):
                    parent = tree[marked].parent
                    if parent is not None and parent not in queued:
                        queued.add(parent)
                        heapq.heappush(heap, -parent)
            if (len(dead), sum(len(r) for r in dead.values())) == before:
                break
        return set(dead)

    def _pooled_failures(
        self, tree: Tree, dead: Mapping[int, set[str]], origin: Mapping[int, int]
    ) -> dict[str, int]:
        """Per query identity: how often it has failed, or led only to a dead end, over every
        node that made it; left out while an attempt that is not a dead end got past the
        depth where those failures happened. Only queries with a failed attempt or a dead end
        among their attempts can have any."""
        keys = set(self._failed_keys)
        for d in dead:
            key = self._maker_key(tree, tree[d].parent or ROOT)
            if key is not None:
                keys.add(key)
        out: dict[str, int] = {}
        deepest = self._deepest
        for key in keys:
            failed = self._attempts_failed.get(key, ())
            ok = self._attempts_ok.get(key, ())
            dead_ok = [c for c in ok if c in dead]
            if not failed and not dead_ok:
                continue
            depths = [origin.get(c, tree[c].depth) for c in dead_ok]
            if failed:
                depths.append(self._failed_depth[key])
            depth = min(depths)
            if not any(c not in dead and deepest.get(c, -1) >= depth for c in ok):
                out[key] = len(failed) + len(dead_ok)
        return out

    def _signature(self, tree: Tree, node: Node) -> tuple[dict[str, str], dict[str, int]]:
        """The values of the objects ``node``'s next query depends on, encoded so that equal
        values compare equal, and the depth that bound each (0: the problem's own objects)."""
        cached = self._sigs.get(node.id)
        if cached is not None:
            return cached
        values = dict(self.initial_values)
        bound_at: dict[str, int] = {}
        for i in tree.path(node.id):
            for name, value in tree[i].outputs.items():
                values[name] = value
                bound_at[name] = tree[i].depth
        sig = {
            name: json.dumps(self.encode(values[name]), sort_keys=True, default=str)
            for name in sorted(self.queries.relevant(node))
            if name in values
        }
        cached = (sig, {name: bound_at.get(name, 0) for name in sig})
        self._sigs[node.id] = cached
        return cached

    def _shared_culprits(self, tree: Tree) -> list[tuple[Node, set[str]]]:
        """Per stream of a plan: take the latest node whose query there failed every time it
        was made, and the values that query depended on; from the deepest choice up, drop the
        values bound last until the nodes whose query agrees on the rest have failed at least
        :data:`SHARED_MIN` times (and as often as ``dead_after`` asks) with no success among
        them, and differ in what was dropped. Those nodes are dead ends because of the values
        kept, and the search backs up to the last of them. A group of nodes (one stream of one
        plan) is looked at again only when one of them has new children."""
        for group in self._stale_groups:
            self._culprits[group] = self._group_culprits(tree, self._members[group])
        self._stale_groups.clear()
        out: list[tuple[Node, set[str]]] = []
        for group in sorted(self._members, key=lambda g: self._members[g][0]):
            out += self._culprits.get(group, [])
        return out

    def _group_culprits(self, tree: Tree, member_ids: list[int]) -> list[tuple[Node, set[str]]]:
        makers = [tree[m] for m in member_ids]

        def failed(n: Node) -> bool:  # the query itself failed, every time it was made here
            return not any(tree[c].success for c in n.children)

        failing = [n for n in makers if failed(n)]
        if len(failing) < SHARED_MIN:
            return []
        latest = failing[-1]
        sig, bound_at = self._signature(tree, latest)
        first = self.queries.first(latest)
        assert first is not None
        need = max(SHARED_MIN, self._dead_after(first))
        depths = sorted(set(bound_at.values()), reverse=True)
        for cut in depths[1:]:  # the deepest cut is the query's identity: pooled already
            kept = {n: v for n, v in sig.items() if bound_at[n] <= cut}
            agree = [m for m in makers if self._agrees(tree, m, kept)]
            if not all(failed(m) for m in agree):
                break  # a success shares these values: so would every shallower cut's
            failures = sum(len(m.children) for m in agree)
            if failures < need:
                continue
            if len({tuple(self._signature(tree, m)[0].items()) for m in agree}) < 2:
                continue  # the same query each time: its identity pools it
            reason = set(kept)
            return [(m, reason) for m in agree]
        return []

    def _agrees(self, tree: Tree, node: Node, kept: Mapping[str, str]) -> bool:
        sig = self._signature(tree, node)[0]
        return all(sig.get(n) == v for n, v in kept.items())


def _mark(
    tree: Tree,
    dead: dict[int, set[str]],
    origin: dict[int, int],
    node: Node,
    reason: set[str],
    depth: int,
) -> list[int]:
    """Take ``node`` for a dead end because of ``reason`` (the objects its failures, at
    ``depth``, depend on), and its ancestors up to the one that bound one of them; returns the
    nodes marked."""
    current = node
    dead[current.id] = reason
    origin[current.id] = depth
    marked = [current.id]
    while not (set(current.outputs) & reason) and current.parent is not None:
        parent = tree[current.parent]
        if parent.depth == 0 or parent.id == ROOT:
            break
        dead[parent.id] = reason
        origin[parent.id] = depth
        marked.append(parent.id)
        current = parent
    return marked

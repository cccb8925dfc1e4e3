"""The learned policy (Bradley & Roy): UCT over the expected remaining cost of a stream plan.

A node's value is -Q, Q the expected seconds still to spend on its plan: the execution
seconds of the trajectories bound on its path, plus Eq. 4: for each remaining stream,
R_S + R_M + (1 - P_S) / P_S * R_F, predicted by per-stream models from the stream's inputs
(zero and masked where not bound yet) and the scene. "Query this stream again"
is scored by the same formula, so there is no progressive-widening rule. The models are reached
through the :class:`Predictor` protocol, so this module needs no torch.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from planner.abstract.skeleton import AbstractPlan
from planner.pddl.structs import Atom
from planner.search.reuse import query_identity, reusable_streams
from planner.search.tree import ROOT, Node, Tree

P_MIN = 0.02  # P_S is clamped here: a stream never looks hopeless (Eq. 1 divides by it)
P_MAX = 0.98  # ... nor certain, once it has failed (or led only to dead ends) from a node
INFEASIBLE_PRIOR = 0.3  # least chance that a binding makes its next stream impossible
INFEASIBLE_MAX = 0.95  # most chance of it, before trying (1 - P_S when the model is doubtful)
ITERATION_S = 0.05  # seconds of search (descent, predictions, events) around each query
P_FLOOR = 1e-6  # lowest success chance after failures (keeps Eq. 1 finite)
DEAD_END_MAX = 0.95  # most chance that a query not yet made is a dead end
DEAD_END_DOUBT = 0.1  # a run of failures less likely than this under P_S means a dead end
DEAD_END_MIN = 2  # failures in a row before any node is taken for a dead end
PRIOR_CHILDREN = 0.5  # how many observed children the model's guess of a new one weighs
SHARED_MIN = 3  # failures under varied later choices before the earlier ones they share are blamed


@dataclass(frozen=True)
class StreamCost:
    """Predicted outcome and costs of one stream query (seconds)."""

    p_s: float
    r_s: float
    r_f: float
    r_m: float
    p_prior: float | None = None  # the stream's success rate over all its training queries

    @property
    def expected(self) -> float:
        """Eq. 1: expected seconds to get one success, execution included."""
        p = min(max(self.p_s, P_MIN), 1.0)
        return self.r_s + self.r_m + (1.0 - p) / p * self.r_f

    @property
    def dead_end(self) -> float:
        """Chance that the query fails whatever is retried here: the part of the predicted
        failure beyond the stream's usual rate, which comes from this query's inputs and scene
        (a stove already crowded, a pose out of reach) rather than from chance. 0 without a
        prior rate."""
        if self.p_prior is None or self.p_prior <= 0.0:
            return 0.0
        p = min(max(self.p_s, P_MIN), 1.0)
        return min(max(1.0 - p / self.p_prior, 0.0), DEAD_END_MAX)


def remaining_cost(costs: Sequence[StreamCost]) -> float:
    """Eq. 4: expected seconds for the rest of a stream plan."""
    return sum(c.expected for c in costs)


def with_dead_ends(cost: float, feasible: float) -> float:
    """Eq. 4 when the rest of the plan is feasible from here with chance ``feasible`` (the
    product of 1 - dead-end chance over its streams): a dead end means choosing again here and
    paying for the rest again, so the expected cost is ``cost / feasible`` (Eq. 1 one level
    up)."""
    return cost / max(feasible, 1.0 - DEAD_END_MAX)


def after_attempts(cost: StreamCost, successes: int, failures: int) -> float:
    """Eq. 1 for a node's next stream once it has been queried from that node.

    A success proves the binding feasible: the success chance becomes a Beta posterior around
    the prediction (weight 2). Failures only: the binding may make the stream impossible
    (prior ``1 - P_S``, between :data:`INFEASIBLE_PRIOR` and :data:`INFEASIBLE_MAX`); each
    failure makes that likelier, so the expected cost
    of insisting grows without bound, and the search backs up to re-sample an ancestor once
    insisting costs more than redoing the streams in between. Every failure also costs
    :data:`ITERATION_S` of search around it.
    """
    if successes == 0 and failures == 0:
        return cost.expected
    p = min(max(cost.p_s, P_MIN), 1.0)
    if successes > 0:
        p_eff = (2.0 * p + successes) / (2.0 + successes + failures)
    else:
        # A stream the model expects to fail is likelier to be impossible from here.
        p = min(p, P_MAX)
        infeasible = min(max(INFEASIBLE_PRIOR, 1.0 - p), INFEASIBLE_MAX)
        feasible = (1.0 - infeasible) * (1.0 - p) ** failures
        p_eff = p * feasible / (feasible + infeasible)
    p_eff = max(p_eff, P_FLOOR)
    return cost.r_s + cost.r_m + (1.0 - p_eff) / p_eff * (cost.r_f + ITERATION_S)


def dead_after(p_s: float, *, p_prior: float | None = None, doubt: float = DEAD_END_DOUBT) -> int:
    """Failures in a row after which a query predicted to succeed with ``p_s`` is taken for a
    dead end, never fewer than :data:`DEAD_END_MIN`. Whichever comes first:

    - the run of failures is less likely than ``doubt`` under the prediction: the least n with
      (1 - p_s)^n < ``doubt`` (3 for IK's 0.65, 11 for 0.2). The models are over-confident
      where success is chance: a placement predicted at 0.98 fails when its try lands where a
      block already stands, and taking that one failure for a dead end threw away a fully bound
      stove (kitchen-4 seed 1000: the search left a plan bound to its last placement for
      another plan, 51 s of motions);
    - the model foresaw the dead end and the failures confirm it: with ``p_prior`` (the
      stream's usual rate), a prediction below it is read as a dead end with chance
      ``D = 1 - p_s / p_prior`` and otherwise as the usual rate (:attr:`StreamCost.dead_end`);
      the least n after which the query is still feasible with chance below ``doubt``. A
      placement predicted at 0.03 on a full stove (usual 0.91) is dead after 2 failures, not
      the 76 the first rule asks (kitchen-4 seed 1003 failed 60 placements at 1a9d360)."""
    p = min(max(p_s, P_MIN), P_MAX)
    n = max(DEAD_END_MIN, math.ceil(math.log(doubt) / math.log(1.0 - p)))
    dead = StreamCost(p_s, 0.0, 0.0, 0.0, p_prior=p_prior).dead_end
    if dead <= 0.0 or p_prior is None:
        return n
    miss = 1.0 - min(max(p_prior, P_MIN), P_MAX)  # a failure, when the query is feasible
    for k in range(DEAD_END_MIN, n):
        feasible = (1.0 - dead) * miss**k
        if feasible / (dead + feasible) < doubt:
            return k
    return n


def stream_rows(
    plan: AbstractPlan,
    states: Sequence[frozenset[Atom]],
    values: Mapping[str, Any],
    *,
    encode: Callable[[Any], Any],
    fluents: frozenset[str],
    static_context: Mapping[str, Any],
    start: int = 0,
    only: Collection[int] | None = None,
) -> list[tuple[str, list[Any | None], dict[str, Any]]]:
    """The model rows of ``plan``'s streams from ``start`` on (of those in ``only``, if
    given): stream, encoded inputs (None while unbound) and the context (fluent facts, their
    bound values, the scene's static facts), as the models were trained on them. A row reads
    only the values of :func:`row_names`."""
    rows = []
    for i in range(start, len(plan.stream_plan)):
        if only is not None and i not in only:
            continue
        inst = plan.stream_plan[i]
        inputs = [encode(values[n]) if n in values else None for n in inst.inputs]
        facts = sorted(a for a in states[i] if a.predicate in fluents)
        names = {x for a in facts for x in a.args}
        context = {
            **static_context,
            "facts": [[a.predicate, *a.args] for a in facts],
            "values": {
                n: encode(values[n])
                for n in sorted(names)
                if n in values and not isinstance(values[n], str)
            },
        }
        rows.append((inst.stream, inputs, context))
    return rows


def row_names(
    plan: AbstractPlan, states: Sequence[frozenset[Atom]], fluents: frozenset[str]
) -> list[frozenset[str]]:
    """Per stream of ``plan``: the objects whose values its model row reads (its inputs and the
    arguments of its context's fluent facts). A row none of whose objects a new binding names
    is the same row as before that binding."""
    return [
        frozenset(inst.inputs)
        | frozenset(x for a in states[i] if a.predicate in fluents for x in a.args)
        for i, inst in enumerate(plan.stream_plan)
    ]


# A stream's row as the search keeps it: (identity key, prediction, reuse identity).
_Entry = tuple[str | None, StreamCost, str | None]


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
    evidence_ignore: frozenset[str] = frozenset()  # fluents left out of a query's identity
    static_context: Mapping[str, Any] = field(default_factory=dict)  # in every row's context
    _q: dict[int, float] = field(default_factory=dict)  # Eq. 4 before any attempt
    _bound: dict[int, float] = field(default_factory=dict)  # execution seconds bound so far
    _terms: dict[int, list[tuple[str | None, StreamCost]]] = field(default_factory=dict)
    _groups: dict[str, list[int]] = field(default_factory=dict)  # query -> nodes that make it
    _evidence: dict[str, tuple[int, int]] = field(default_factory=dict)  # ok, failed
    _est: dict[int, float] = field(default_factory=dict)  # lowest Q in each node's subtree
    _fresh: dict[int, float] = field(default_factory=dict)  # predicted Q of a new child
    _dead: set[int] = field(default_factory=set)  # dead ends, as of the last refresh
    _scale: float = 0.0
    # Results the search will reuse (planner/search/reuse.py): per node, the identity of each
    # stream ahead where it can be known (None otherwise); identity -> execution seconds of
    # its first success; nodes scanned for successes so far.
    _idents: dict[int, list[str | None]] = field(default_factory=dict)
    _known: dict[str, float] = field(default_factory=dict)
    _scanned: int = 0
    _reusable: list[list[bool]] = field(default_factory=list)
    # Per node that queries: the values its next query depends on (encoded, comparable) and the
    # depth that bound each (0: the problem's own objects).
    _sigs: dict[int, tuple[dict[str, str], dict[str, int]]] = field(default_factory=dict)
    # Per node predicted: (identity key, prediction, reuse identity) of each stream from its
    # depth on; a child's rows that its new binding leaves alone are taken from here.
    _entries: dict[int, list[_Entry]] = field(default_factory=dict)
    _names: list[list[frozenset[str]]] = field(default_factory=list)  # row_names per plan

    # --- Q of a node -------------------------------------------------------------------------

    def _rows(
        self,
        plan_index: int,
        depth: int,
        values: Mapping[str, Any],
        only: Collection[int] | None = None,
    ) -> list[tuple[str, list[Any | None], dict[str, Any]]]:
        return stream_rows(
            self.skeletons[plan_index],
            self.states[plan_index],
            values,
            encode=self.encode,
            fluents=self.fluents,
            static_context=self.static_context,
            start=depth,
            only=only,
        )

    def _stale(self, tree: Tree, node: Node, pending: Collection[int]) -> list[int] | None:
        """The streams (from the node's depth on) whose rows differ from its parent's, or None
        when the parent's rows are neither predicted nor ``pending`` in this batch. The child
        binds one more stream; the rows of the others read nothing it bound unless
        :func:`row_names` says so."""
        if node.parent is None or (node.parent not in self._entries and node.parent not in pending):
            return None
        parent = tree[node.parent]
        if parent.plan_index != node.plan_index or node.depth != parent.depth + 1:
            return None
        if not self._names:
            self._names = [
                row_names(p, st, self.fluents)
                for p, st in zip(self.skeletons, self.states, strict=True)
            ]
        names = self._names[node.plan_index]
        new = set(node.outputs)
        return [i for i in range(node.depth, len(names)) if names[i] & new]

    def _key(self, row: tuple[str, list[Any | None], dict[str, Any]]) -> str | None:
        """A query's identity: stream, inputs and the state that matters; None while an input
        is unbound."""
        stream, inputs, context = row
        if any(v is None for v in inputs):
            return None
        facts = [f for f in context["facts"] if f[0] not in self.evidence_ignore]
        names = {x for f in facts for x in f[1:]}
        values = {n: v for n, v in context["values"].items() if n in names}
        return json.dumps([stream, inputs, facts, values], sort_keys=True, default=str)

    def _predict(self, tree: Tree, nodes: Sequence[Node]) -> None:
        """Eq. 4 predictions for nodes that have none yet, in one batch."""
        todo = [n for n in nodes if n.id not in self._q]
        if not todo:
            return
        # Only the rows a node's new binding changed are built and predicted, in one batch; the
        # rest are its parent's, predicted before or earlier in this batch (parents come first).
        # A kitchen-8 plan has 72 streams, and a binding changes the rows of a few of them.
        if not self._reusable:
            self._reusable = [
                reusable_streams(p, st, self.fluents)
                for p, st in zip(self.skeletons, self.states, strict=True)
            ]
        rows: list[tuple[str, list[Any | None], dict[str, Any]]] = []
        reads: list[bool] = []  # per row: may its query's result be reused (reusable_streams)
        slots: dict[int, list[int | _Entry]] = {}  # per node: a row of this batch, or an entry
        todo = sorted(todo, key=lambda n: n.id)
        for node in todo:
            stale = self._stale(tree, node, slots.keys())
            reusable = self._reusable[node.plan_index]
            values = {**self.initial_values, **tree.bindings(node.id)}
            fresh = range(node.depth, len(reusable)) if stale is None else stale
            at = dict(zip(fresh, range(len(rows), len(rows) + len(fresh)), strict=True))
            rows += self._rows(
                node.plan_index, node.depth, values, None if stale is None else stale
            )
            reads += [reusable[i] for i in fresh]
            parent: Sequence[int | _Entry] = ()
            if stale is not None and node.parent is not None:
                parent = slots[node.parent] if node.parent in slots else self._entries[node.parent]
            slots[node.id] = [
                at[i] if i in at else parent[i - node.depth + 1]
                for i in range(node.depth, len(reusable))
            ]
        costs = self.predictor.predict_rows(rows) if rows else []
        made: dict[int, _Entry] = {}

        def entry(slot: int | _Entry) -> _Entry:
            if not isinstance(slot, int):
                return slot
            if slot not in made:
                row = rows[slot]
                ok = reads[slot] and all(v is not None for v in row[1])
                made[slot] = (self._key(row), costs[slot], query_identity(*row) if ok else None)
            return made[slot]

        for node in todo:
            entries = [entry(slot) for slot in slots[node.id]]
            self._entries[node.id] = entries
            keys = [key for key, _, _ in entries]
            ours = [cost for _, cost, _ in entries]
            self._terms[node.id] = list(zip(keys, ours, strict=True))
            self._idents[node.id] = [ident for _, _, ident in entries]
            if keys and keys[0] is not None:  # the node's children are attempts of this query
                self._groups.setdefault(keys[0], []).append(node.id)
            self._bound[node.id] = sum(tree[i].execution_s for i in tree.path(node.id))
            self._settle(node)
            if ours and self.on_prediction is not None:
                self.on_prediction(node, ours[0], self._q[node.id])

    def _settle(self, node: Node) -> None:
        """Eq. 4 for the node and for a new child of it, with the results the search will
        reuse counted at their execution seconds only."""
        terms = self._terms[node.id]
        idents = self._idents[node.id]
        total, feasible = self._remaining(terms, idents, first=not node.children, evidence=False)
        self._q[node.id] = self._bound[node.id] + with_dead_ends(total, feasible)
        if terms:  # a child binds the next stream: its execution and the rest remain
            rest, _ = self._remaining(terms[1:], idents[1:], first=True, evidence=False)
            rest_feasible = math.prod(1.0 - c.dead_end for _, c in terms[1:])
            self._fresh[node.id] = (
                self._bound[node.id] + terms[0][1].r_m + with_dead_ends(rest, rest_feasible)
            )

    def _remaining(
        self,
        terms: Sequence[tuple[str | None, StreamCost]],
        idents: Sequence[str | None],
        *,
        first: bool,
        evidence: bool,
    ) -> tuple[float, float]:
        """Eq. 4 over ``terms`` (and the chance that none is a dead end). A term the search
        will answer with an earlier result costs that result's execution seconds (the first
        term only when ``first``: a node that has queried already asks its sampler for a new
        sample). With ``evidence``, a term whose query was made elsewhere is updated by its
        outcomes (:func:`after_attempts`)."""
        total, feasible = 0.0, 1.0
        for j, ((key, cost), ident) in enumerate(zip(terms, idents, strict=True)):
            known = self._known.get(ident) if ident is not None and (first or j) else None
            if known is not None:
                total += known
                continue
            seen = self._evidence.get(key) if evidence and key is not None else None
            if seen is None:
                total += cost.expected
                feasible *= 1.0 - cost.dead_end
            else:  # a success proves it feasible; failures only: after_attempts weighs them
                ok, failed = seen
                total += after_attempts(cost, ok, failed)
        return total, feasible

    def q(self, tree: Tree, node: Node) -> float:
        """Expected seconds still to spend on ``node``'s plan: executing the trajectories
        already bound on its path (planning time spent is sunk, but the robot has yet to run
        them, so a sibling with a shorter trajectory is cheaper), plus Eq. 4 over
        the predictions (made once per node), each term updated by the outcomes of the same
        query already made anywhere in the tree (same inputs, same relevant state; see
        :func:`after_attempts`), as counted at the last refresh, and calibrated by the children
        the node already has (:meth:`_calibration`)."""
        self._predict(tree, [node])
        shift = self._calibration(tree, node)
        if not self._evidence:
            return self._q[node.id] + shift
        total, feasible = self._remaining(
            self._terms[node.id], self._idents[node.id], first=not node.children, evidence=True
        )
        return self._bound[node.id] + with_dead_ends(total, feasible) + shift

    def _calibration(self, tree: Tree, node: Node) -> float:
        """How much worse (or better) the node's children came out than the models guessed for
        a child before seeing one, shrunk towards 0 by :data:`PRIOR_CHILDREN`.

        Predicted with an input masked, a stream's cost is an average over what that input
        could be; once bound, it is the cost for this binding. The two need not agree: a move
        whose end is not sampled yet is predicted as the average move (7.2 s for moves that
        take 12.2 s), and a placement's chance of leaving room for the next block is high
        until the placement is made. Without this, querying again from a node looks cheaper
        than every child it has made, however many it makes: kitchen-4 seed 1027 re-sampled
        the same three blocks' grasps, IK and motions for 300 s in the hope of shorter moves."""
        fresh = self._fresh.get(node.id)
        if fresh is None:
            return 0.0
        kids = [tree[c] for c in node.children if tree[c].success and c not in self._dead]
        if not kids:
            return 0.0
        self._predict(tree, kids)
        surprise = sum(self._q[c.id] - fresh for c in kids)
        return surprise / (len(kids) + PRIOR_CHILDREN)

    def _refresh(self, tree: Tree) -> None:
        """Count the outcomes of every query made, then estimate every node: the lowest Q in
        its subtree, dead ends left out (progress counts; a dead end below raises its Q until
        another branch is cheaper). Children come after their parents, so one pass from the
        last id does it."""
        self._predict(tree, [n for n in tree.nodes[1:] if n.success])
        self._learn_results(tree)
        dead = self._dead_ends(tree)
        self._dead = dead
        # Outcomes only, never seconds measured: the same seed makes the same search.
        evidence: dict[str, tuple[int, int]] = {}
        for key, makers in self._groups.items():
            ok = failed = 0
            for n in makers:
                for c in tree[n].children:
                    if tree[c].success and c not in dead:
                        ok += 1
                    else:
                        failed += 1
            if ok or failed:
                evidence[key] = (ok, failed)
        self._evidence = evidence
        est: dict[int, float] = {}
        for node in reversed(tree.nodes[1:]):
            if not node.success:
                continue
            best = self.q(tree, node)
            if node.id in dead:  # every continuation is taken to fail: going on costs 1 / 0.05 x
                est[node.id] = with_dead_ends(best, 0.0)
                continue
            for c in node.children:  # a dead end's subtree no longer vouches for its parent
                if c in est and c not in dead and est[c] < best:
                    best = est[c]
            est[node.id] = best
        self._est = est

    def _learn_results(self, tree: Tree) -> None:
        """Note the first success of each reusable query made since the last refresh, and
        settle again the nodes whose streams ahead include it."""
        fresh: set[str] = set()
        for node in tree.nodes[max(self._scanned, 1) :]:
            if not node.success or node.parent is None:
                continue
            idents = self._idents.get(node.parent)
            ident = idents[0] if idents else None
            if ident is not None and ident not in self._known:
                self._known[ident] = node.execution_s
                fresh.add(ident)
        self._scanned = len(tree.nodes)
        if not fresh:
            return
        for node_id, idents in self._idents.items():
            if any(i in fresh for i in idents if i is not None):
                self._settle(tree[node_id])

    def _relevant(self, node: Node) -> set[str]:
        """Objects the outcome of ``node``'s next query depends on: its inputs and the objects of
        the state facts that make up its identity (see :meth:`_key`)."""
        inst = self.skeletons[node.plan_index].stream_plan[node.depth]
        facts = self.states[node.plan_index][node.depth]
        out = set(inst.inputs)
        for a in facts:
            if a.predicate in self.fluents and a.predicate not in self.evidence_ignore:
                out.update(a.args)
        return out

    def _dead_ends(self, tree: Tree) -> set[int]:
        """Nodes whose every continuation is taken to fail. A node is a dead end when its next
        query has failed, or led only to dead ends, more often in a row than its prediction
        explains (:func:`dead_after`), counting the same query made from other nodes (same
        inputs, same relevant state: :meth:`_key`) unless one of them got past the failures.
        Its reason is the objects those failures depend on; if the node's own outputs are not
        among them, re-sampling them cannot help, so its parent is a dead end too, and so on
        up to the node that bound something the failures depend on (backjumping). A dead end
        counts as a failed attempt of its parent's query: a placement that always succeeds but
        leaves no room for what comes next stops looking cheap to re-sample (seed 1012: one
        block in the middle of the stove; the search re-placed the next block 84 times without
        ever going back to it).

        Pooling matters when the query that fails comes after choices it does not read
        (kitchen-4 seed 1000: the last block's stove placement failed once under each of 13
        new grasps, IK solutions and motions of that block, and the crowded stove was never
        blamed). A fresh attempt elsewhere that has not yet reached the failing depth does not
        stop the pooling (seed 1025, cheap streams first: every re-sampled grasp of the third
        block made a new node placing it on the stove, whose one unexplored child kept the
        crowded stove from ever being blamed; 521 failed placements in 300 s)."""
        deepest = self._deepest(tree)
        dead: dict[int, set[str]] = {}  # node -> the objects its failures depend on
        origin: dict[int, int] = {}  # dead node -> depth of the failures behind it
        shared = self._shared_culprits(tree)  # reads only query outcomes: once per refresh
        for _ in range(8):  # new dead ends fail their parents' queries: pool again
            pooled = self._pooled_failures(tree, dead, origin, deepest)
            before = len(dead), sum(len(r) for r in dead.values())
            for node, reason in shared:
                if dead.get(node.id) == reason:
                    continue
                depth = min(origin.get(c, tree[c].depth) for c in node.children)
                self._mark(tree, dead, origin, node, reason, depth)
            for node in reversed(tree.nodes[1:]):
                if node.id in dead or not node.success or node.depth == 0:
                    continue
                terms = self._terms.get(node.id)
                if not terms or not node.children:
                    continue  # complete, or not queried from yet
                if any(tree[c].success and c not in dead for c in node.children):
                    continue
                key = terms[0][0]
                failures = max(len(node.children), pooled.get(key, 0) if key is not None else 0)
                first = terms[0][1]
                if failures < dead_after(first.p_s, p_prior=first.p_prior):
                    continue
                reason = self._relevant(node)
                depth = min(origin.get(c, tree[c].depth) for c in node.children)
                for c in node.children:
                    if c in dead:
                        reason |= dead[c] - set(tree[c].outputs)
                self._mark(tree, dead, origin, node, reason, depth)
            if (len(dead), sum(len(r) for r in dead.values())) == before:
                break
        return set(dead)

    @staticmethod
    def _mark(
        tree: Tree,
        dead: dict[int, set[str]],
        origin: dict[int, int],
        node: Node,
        reason: set[str],
        depth: int,
    ) -> None:
        """Take ``node`` for a dead end because of ``reason`` (the objects its failures, at
        ``depth``, depend on), and its ancestors up to the one that bound one of them."""
        current = node
        dead[current.id] = reason
        origin[current.id] = depth
        while not (set(current.outputs) & reason) and current.parent is not None:
            parent = tree[current.parent]
            if parent.depth == 0 or parent.id == ROOT:
                break
            dead[parent.id] = reason
            origin[parent.id] = depth
            current = parent

    def _signature(self, tree: Tree, node: Node) -> tuple[dict[str, str], dict[str, int]]:
        """The values of the objects ``node``'s next query depends on (:meth:`_relevant`),
        encoded so that equal values compare equal, and the depth that bound each."""
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
            for name in sorted(self._relevant(node))
            if name in values
        }
        cached = (sig, {name: bound_at.get(name, 0) for name in sig})
        self._sigs[node.id] = cached
        return cached

    def _shared_culprits(self, tree: Tree) -> list[tuple[Node, set[str]]]:
        """Queries that keep failing while a later choice they depend on varies, blamed on the
        earlier choices every failure shared.

        Pooling by identity (:meth:`_pooled_failures`) needs the same query to fail again, but
        the search may never ask it twice: after one failure, re-sampling higher up looks
        cheaper, and each re-sample changes an input of the failing query. Kitchen-4 seed 1009
        (96 IK base poses): the last block's stove placement failed 99 times, each under a
        different placement of the block before it, while the two first blocks' stove places,
        which left no room, were never re-sampled; the run timed out. So, per stream of a plan:
        take the latest node whose query there failed every time it was made, and the values
        that query depended on; from the deepest choice up, drop the values bound last
        until the nodes whose query agrees on the rest have failed at least
        :data:`SHARED_MIN` times (and as often as :func:`dead_after` asks) with no success
        among them. Those nodes are dead ends because of the values kept, and the search backs
        up to the last of them."""
        groups: dict[tuple[int, int], list[Node]] = {}
        for node in tree.nodes[1:]:
            if node.success and node.depth > 0 and node.children and self._terms.get(node.id):
                groups.setdefault((node.plan_index, node.depth), []).append(node)
        out: list[tuple[Node, set[str]]] = []

        def failed(n: Node) -> bool:  # the query itself failed, every time it was made here
            return not any(tree[c].success for c in n.children)

        for makers in groups.values():
            failing = [n for n in makers if failed(n)]
            if len(failing) < SHARED_MIN:
                continue
            latest = failing[-1]
            sig, bound_at = self._signature(tree, latest)
            first = self._terms[latest.id][0][1]
            need = max(SHARED_MIN, dead_after(first.p_s, p_prior=first.p_prior))
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
                out += [(m, reason) for m in agree]
                break
        return out

    def _agrees(self, tree: Tree, node: Node, kept: Mapping[str, str]) -> bool:
        sig = self._signature(tree, node)[0]
        return all(sig.get(n) == v for n, v in kept.items())

    @staticmethod
    def _deepest(tree: Tree) -> dict[int, int]:
        """Per node, the depth of the deepest success in its subtree (itself included)."""
        deepest: dict[int, int] = {}
        for node in reversed(tree.nodes[1:]):
            mine = node.depth if node.success else -1
            deepest[node.id] = max(mine, deepest.get(node.id, -1))
            if node.parent is not None:
                deepest[node.parent] = max(deepest.get(node.parent, -1), deepest[node.id])
        return deepest

    def _pooled_failures(
        self,
        tree: Tree,
        dead: Mapping[int, set[str]],
        origin: Mapping[int, int],
        deepest: Mapping[int, int],
    ) -> dict[str, int]:
        """Per query identity: how often it has failed, or led only to a dead end, over every
        node that made it; left out while an attempt that is not a dead end got past the
        depth where those failures happened."""
        out: dict[str, int] = {}
        for key, makers in self._groups.items():
            children = [c for n in makers for c in tree[n].children]
            bad = [c for c in children if not tree[c].success or c in dead]
            if not bad:
                continue
            depth = min(origin.get(c, tree[c].depth) for c in bad)
            if not any(
                tree[c].success and c not in dead and deepest.get(c, -1) >= depth for c in children
            ):
                out[key] = len(bad)
        return out

    def _estimate(self, tree: Tree, node: Node) -> float:
        """The lowest Q in the node's subtree (as of the last refresh)."""
        found = self._est.get(node.id)
        return found if found is not None else self.q(tree, node)

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
        self._refresh(tree)
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
        best = max(
            self._value(self._estimate(tree, c)) + self._bonus(c.visits, node.visits) for c in live
        )
        return again > best

    def pick_child(self, tree: Tree, node: Node) -> Node:
        return max(
            tree.live_children(node.id),
            key=lambda c: self._value(self._estimate(tree, c)) + self._bonus(c.visits, node.visits),
        )

    def leaf_value(self, leaf: Node, plan: AbstractPlan) -> float:
        """1 for a bound plan, 0 otherwise (the choices read Q, refreshed every iteration)."""
        return 1.0 if leaf.success and leaf.depth == len(plan.stream_plan) else 0.0

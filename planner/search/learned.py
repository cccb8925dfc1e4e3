"""The learned policy (Bradley & Roy): UCT over the expected remaining cost of a stream plan.

**The paper's algorithm** (planner ``paper``, :meth:`LearnedConfig.paper`): a node's value is
-Q, Q the expected seconds still to spend on its plan, Eq. 4 (:mod:`planner.search.costs`): for
each remaining stream, ``R_S + R_M + (1 - P_S) / P_S * R_F``, predicted by per-stream models
from the stream's inputs (zero and masked where not bound yet) and the scene. Selection is UCT on
-Q, and "query this stream again" is one more action scored by the same formula (the node's own
Q), so there is no progressive-widening rule; the stream plans keep their own order.

**The additions** (planner ``learned``, :class:`LearnedConfig`'s defaults): each is one field of
:class:`LearnedConfig`, switched off by name (``tamp bench --planners
learned,learned:shared_culprits=off``); its docstring says what it does and what it measured.
What failed queries teach (outcomes pooled by query identity, dead ends, shared culprits) lives
in :mod:`planner.search.evidence`. The models are reached through the :class:`Predictor`
protocol, so this module needs no torch.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any, Protocol

from planner.abstract.skeleton import AbstractPlan
from planner.pddl.structs import Atom
from planner.search.costs import (
    DEAD_END_MAX,
    INFEASIBLE_MAX,
    INFEASIBLE_PRIOR,
    ITERATION_S,
    P_FLOOR,
    P_MAX,
    P_MIN,
    StreamCost,
    after_attempts,
    dead_after,
    dead_end_chance,
    expected,
    remaining_cost,
    with_dead_ends,
)
from planner.search.evidence import Evidence
from planner.search.queries import query_context, query_identity
from planner.search.reuse import reusable_streams
from planner.search.tree import ROOT, Node, Tree

__all__ = [
    "DEAD_END_MAX",
    "INFEASIBLE_MAX",
    "INFEASIBLE_PRIOR",
    "ITERATION_S",
    "P_MAX",
    "P_MIN",
    "LearnedConfig",
    "LearnedPolicy",
    "Predictor",
    "StreamCost",
    "after_attempts",
    "dead_after",
    "remaining_cost",
    "row_names",
    "stream_rows",
    "with_dead_ends",
]

PRIOR_CHILDREN = 0.5  # calibration: how many observed children the model's guess weighs

Row = tuple[str, list[Any | None], dict[str, Any]]  # stream, encoded inputs, context


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
) -> list[Row]:
    """The model rows of ``plan``'s streams from ``start`` on (of those in ``only``, if
    given): stream, encoded inputs (None while unbound) and the query's context
    (:func:`planner.search.queries.query_context`), as the models were trained on them. A row
    reads only the values of :func:`row_names`."""
    rows = []
    for i in range(start, len(plan.stream_plan)):
        if only is not None and i not in only:
            continue
        inst = plan.stream_plan[i]
        inputs = [encode(values[n]) if n in values else None for n in inst.inputs]
        context = query_context(
            states[i], values, fluents=fluents, static_context=static_context, encode=encode
        )
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


# A stream's row as the search keeps it: (evidence identity, prediction, reuse identity).
_Entry = tuple[str | None, StreamCost, str | None]


class Predictor(Protocol):
    """Batched predictions: one (stream, encoded inputs or None, context) per row."""

    def predict_rows(
        self, rows: Sequence[tuple[str, Sequence[Any | None], Mapping[str, Any]]]
    ) -> list[StreamCost]: ...


@dataclass(frozen=True)
class LearnedConfig:
    """The learned planner's parts. All off (:meth:`paper`) is the paper's planner; the
    defaults are the planner ``learned``. Each field's docstring: what it does, why, what it
    measured (docs/BENCHMARKS.md, *The learned search's parts*)."""

    c_explore: float = 0.05
    """UCT exploration weight on values normalised to (0, 1] by the best plan's Q."""

    p_clamp: bool = True
    """Clamp P_S to [0.02, 0.98] in Eq. 1 and in the attempts' posterior (off: only a floor of
    1e-6, Eq. 1 divides by P_S). A model's near-zero P_S otherwise makes one stream's Eq. 1
    dwarf every other term of its plan, and a near-one P_S never doubts a binding that keeps
    failing.

    Measured (off against on, paired, docs/BENCHMARKS.md): no measurable effect: planning 14%
    more (16% less to 50% more) on tabletop-4, 2% less (18% less to 13% more) on kitchen-4."""

    bound_execution: bool = True
    """Q counts the execution seconds of the trajectories already bound on the node's path
    (planning time spent is sunk, but the robot has yet to run them), so of two siblings the
    one with the shorter trajectory is cheaper. Off: Q is Eq. 4 over the streams left.

    Measured (off against on, paired, docs/BENCHMARKS.md): no measurable effect: planning 10%
    more (14% less to 40% more) on tabletop-4, 4% more (15% less to 26% more) on kitchen-4, where
    the model order binds every motion last."""

    reuse_in_q: bool = True
    """A stream the search will answer with an identical earlier query's result
    (planner/search/reuse.py) costs only that result's execution seconds in Eq. 4.

    Measured (off against on, paired, docs/BENCHMARKS.md): no measurable effect: planning 2% more
    (22% less to 36% more) on tabletop-4, 13% more (12% less to 45% more) on kitchen-4."""

    dead_end_prior: bool = True
    """A prediction below the stream's usual success rate is read as a chance that the query
    is a dead end (the part of the failure beyond chance: a crowded region, a pose out of
    reach); Eq. 4 is then paid 1 / (chance the rest is feasible) times, and such a query is
    taken for a dead end after fewer failures.

    Measured (off against on, paired, docs/BENCHMARKS.md): helps on tabletop-4: planning 47% more
    without it (8% to 109% more); kitchen-4 6% less (34% less to 26% more)."""

    attempt_posterior: bool = True
    """Once a node's next query has been made from it, its Eq. 1 reads the outcomes: a success
    makes P_S a Beta posterior around the prediction (weight 2); failures only make it likelier
    that the binding cannot succeed (prior 0.3 to 0.95), so insisting grows costlier with each
    failure (each also costs 0.05 s of search) until re-sampling an ancestor is cheaper. Off:
    querying again costs the prediction's Eq. 1 however often it has failed.

    Measured (off against on, paired, docs/BENCHMARKS.md): helps on neither: planning 9% less
    without it on tabletop-4 (34% less to 28% more), 20% less on kitchen-4 (40% less to 22%
    more), where its plans execute 16% longer (1% to 31%)."""

    pooled_evidence: bool = True
    """The outcomes of a query are pooled over every node that makes the same query (same
    stream, inputs and relevant state), in Eq. 4's terms and in the dead ends; off: a node
    learns only from its own attempts. Needs attempt_posterior (or dead_ends) to matter.

    Measured (off against on, paired, docs/BENCHMARKS.md): helps on neither: planning 4% more
    without it on tabletop-4 (20% less to 41% more), 5% less on kitchen-4 (27% less to 33% more),
    where its plans execute 17% longer (3% to 30%)."""

    dead_ends: bool = True
    """A node whose next query failed (or led only to dead ends) more often than its
    prediction explains is a dead end: it and its ancestors up to the one that bound something
    the failures depend on are priced as if every continuation fails (backjumping), and a dead
    end counts as a failed attempt of its parent's query.

    Measured (off against on, paired, docs/BENCHMARKS.md): helps on tabletop-4: without it
    planning 335% more (194% to 522% more) with 5 timeouts in 40; on kitchen-4 85% more (11% less
    to 231% more) with 1 timeout in 10."""

    shared_culprits: bool = True
    """A query that keeps failing while a later choice it depends on varies is blamed on the
    earlier choices every failure shared (needs dead_ends): otherwise each failure has its own
    identity and nothing pools them, and the search re-samples the choice nearest the
    failure for ever.

    Measured (off against on, paired, docs/BENCHMARKS.md): costs on tabletop-4: planning 39% less
    without it (22% to 49% less); kitchen-4 85% more without it (10% less to 236% more), with 1
    timeout in 10 that every other variant solves."""

    calibration: bool = True
    """Querying a node again is shifted by how much worse (or better) its children came out
    than the model guessed for a child before seeing one: a stream predicted with an input
    masked is an average over what that input could be, and without this a node whose
    children all came out worse than that average keeps looking cheaper than every one of
    them.

    Measured (off against on, paired, docs/BENCHMARKS.md): helps on neither: planning 12% less
    without it on tabletop-4 (31% less to 17% more), 6% less on kitchen-4 (30% less to 31% more)."""

    subtree_min: bool = True
    """A node is estimated by the lowest Q in its subtree, dead ends left out (progress along
    a plan counts); off: by its own Q.

    Measured (off against on, paired, docs/BENCHMARKS.md): helps on tabletop-4: planning 62% more
    without it (15% to 142% more); kitchen-4 20% less (45% less to 20% more)."""

    model_order: bool = True
    """Each stream plan is reordered before the search by the model's predictions: cheap tests
    likely to fail first, never before the streams whose outputs they read
    (planner/search/order.py); off: the plan's own order (``--order`` overrides either way).

    Measured (off against on, paired, docs/BENCHMARKS.md): no measurable effect: planning 3% more
    without it on tabletop-4 (27% less to 53% more), 50% more on kitchen-4 (22% less to 169%
    more)."""

    @classmethod
    def paper(cls) -> LearnedConfig:
        """The paper's planner: every addition off."""
        return cls(**{f.name: False for f in fields(cls) if f.type in (bool, "bool")})

    @classmethod
    def parts(cls) -> tuple[str, ...]:
        """The names of the additions (the boolean fields)."""
        return tuple(f.name for f in fields(cls) if f.type in (bool, "bool"))

    def with_settings(self, text: str) -> LearnedConfig:
        """This config with ``field=value`` settings separated by ``:`` (``on``/``off`` for a
        part, a number for ``c_explore``); a bad name or value raises ValueError naming it."""
        out = self
        for item in (t for t in text.split(":") if t):
            name, sep, raw = item.partition("=")
            known = {f.name for f in fields(self)}
            if not sep or name not in known:
                raise ValueError(
                    f"planner setting {item!r}: expected FIELD=VALUE with FIELD one of "
                    f"{', '.join(sorted(known))}"
                )
            value: bool | float
            if name == "c_explore":
                try:
                    value = float(raw)
                except ValueError:
                    raise ValueError(f"c_explore={raw!r}: expected a number") from None
                if not 0.0 <= value <= 10.0:
                    raise ValueError(f"c_explore must be between 0 and 10, got {value}")
            elif raw in ("on", "true", "1"):
                value = True
            elif raw in ("off", "false", "0"):
                value = False
            else:
                raise ValueError(f"{name}={raw!r}: expected on or off")
            out = replace(out, **{name: value})  # type: ignore[arg-type]  # checked above
        return out

    @property
    def p_min(self) -> float:
        return P_MIN if self.p_clamp else P_FLOOR

    @property
    def p_max(self) -> float:
        return P_MAX if self.p_clamp else 1.0


class _Queries:
    """What the evidence reads of the policy's predictions (planner.search.evidence)."""

    def __init__(self, policy: LearnedPolicy) -> None:
        self.policy = policy

    def key(self, node: Node) -> str | None:
        terms = self.policy._terms.get(node.id)
        return terms[0][0] if terms else None

    def first(self, node: Node) -> StreamCost | None:
        terms = self.policy._terms.get(node.id)
        return terms[0][1] if terms else None

    def relevant(self, node: Node) -> set[str]:
        return self.policy._relevant(node)


@dataclass
class LearnedPolicy:
    """UCT with value -Q (normalised to (0, 1] by the best plan's Q) and no widening rule; the
    parts of :class:`LearnedConfig` switched as it says."""

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
    _est: dict[int, float] = field(default_factory=dict)  # each node's estimate (subtree_min)
    _fresh: dict[int, float] = field(default_factory=dict)  # predicted Q of a new child
    _scale: float = 0.0
    _evidence: Evidence | None = None
    # Results the search will reuse (planner/search/reuse.py): per node, the identity of each
    # stream ahead where it can be known (None otherwise); identity -> execution seconds of
    # its first success; nodes scanned for successes so far.
    _idents: dict[int, list[str | None]] = field(default_factory=dict)
    _known: dict[str, float] = field(default_factory=dict)
    _scanned: int = 0
    _reusable: list[list[bool]] = field(default_factory=list)
    # Per node predicted: (identity, prediction, reuse identity) of each stream from its depth
    # on; a child's rows that its new binding leaves alone are taken from here.
    _entries: dict[int, list[_Entry]] = field(default_factory=dict)
    _names: list[list[frozenset[str]]] = field(default_factory=list)  # row_names per plan
    # Incremental estimates: each node's Q as of the last refresh, the nodes whose Q or estimate
    # may have changed since, the nodes that read each query's outcomes or each reuse identity,
    # and how many nodes the refreshes have seen.
    _qmemo: dict[int, float] = field(default_factory=dict)
    _dirty: set[int] = field(default_factory=set)
    _by_key: dict[str, set[int]] = field(default_factory=dict)
    _by_ident: dict[str, set[int]] = field(default_factory=dict)
    _seen: int = 0
    _any: bool = False  # whether any outcome was known at the last refresh
    _relevant_at: dict[tuple[int, int], frozenset[str]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        c = self.config
        self._evidence = Evidence(
            _Queries(self),
            self.encode,
            self.initial_values,
            pooled=c.pooled_evidence,
            dead_ends=c.dead_ends,
            shared_culprits=c.shared_culprits,
            use_prior=c.dead_end_prior,
            p_min=c.p_min,
            p_max=c.p_max,
        )

    @property
    def evidence(self) -> Evidence:
        assert self._evidence is not None
        return self._evidence

    @property
    def dead(self) -> set[int]:
        """The nodes taken for dead ends, as of the last refresh."""
        return self.evidence.dead

    # --- Q of a node -------------------------------------------------------------------------

    def _rows(
        self,
        plan_index: int,
        depth: int,
        values: Mapping[str, Any],
        only: Collection[int] | None = None,
    ) -> list[Row]:
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

    def _key(self, row: Row) -> str | None:
        """A query's evidence identity: stream, inputs and the state that matters
        (:func:`planner.search.queries.query_identity` without ``evidence_ignore``); None while
        an input is unbound."""
        stream, inputs, context = row
        if any(v is None for v in inputs):
            return None
        return query_identity(stream, inputs, context, ignore=self.evidence_ignore)

    def _predict(self, tree: Tree, nodes: Sequence[Node]) -> None:
        """Eq. 4 predictions for nodes that have none yet, in one batch."""
        todo = [n for n in nodes if n.id not in self._q]
        if not todo:
            return
        # Only the rows a node's new binding changed are built and predicted, in one batch; the
        # rest are its parent's, predicted before or earlier in this batch (parents come first).
        if not self._reusable:
            self._reusable = [
                reusable_streams(p, st, self.fluents)
                for p, st in zip(self.skeletons, self.states, strict=True)
            ]
        rows: list[Row] = []
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
            for key in {k for k in keys if k is not None}:
                self._by_key.setdefault(key, set()).add(node.id)
            for ident in {i for _, _, i in entries if i is not None}:
                self._by_ident.setdefault(ident, set()).add(node.id)
            if keys and keys[0] is not None:  # the node's children are attempts of this query
                self.evidence.add_maker(keys[0], node.id)
            if self.config.bound_execution:
                self._bound[node.id] = sum(tree[i].execution_s for i in tree.path(node.id))
            else:
                self._bound[node.id] = 0.0
            self._settle(node)
            if ours and self.on_prediction is not None:
                self.on_prediction(node, ours[0], self._q[node.id])

    def _feasible(self, costs: Sequence[StreamCost]) -> float:
        """The chance that none of ``costs`` is a dead end (dead_end_prior; 1 without it)."""
        if not self.config.dead_end_prior:
            return 1.0
        return math.prod(1.0 - dead_end_chance(c, p_min=self.config.p_min) for c in costs)

    def _settle(self, node: Node) -> None:
        """Eq. 4 for the node and for a new child of it, with the results the search will
        reuse counted at their execution seconds only."""
        terms = self._terms[node.id]
        idents = self._idents[node.id]
        total, feasible = self._remaining(terms, idents, first=not node.children, node=None)
        self._q[node.id] = self._bound[node.id] + with_dead_ends(total, feasible)
        if terms:  # a child binds the next stream: its execution and the rest remain
            rest, _ = self._remaining(terms[1:], idents[1:], first=True, node=None)
            rest_feasible = self._feasible([c for _, c in terms[1:]])
            r_m = terms[0][1].r_m if self.config.bound_execution else 0.0
            self._fresh[node.id] = self._bound[node.id] + r_m + with_dead_ends(rest, rest_feasible)

    def _remaining(
        self,
        terms: Sequence[tuple[str | None, StreamCost]],
        idents: Sequence[str | None],
        *,
        first: bool,
        node: Node | None,
        tree: Tree | None = None,
    ) -> tuple[float, float]:
        """Eq. 4 over ``terms`` (and the chance that none is a dead end). A term the search
        will answer with an earlier result costs that result's execution seconds (reuse_in_q;
        the first term only when ``first``: a node that has queried already asks its sampler
        for a new sample). With ``node`` (and attempt_posterior), a term whose query was made
        is updated by its outcomes (:func:`after_attempts`; pooled_evidence: made anywhere)."""
        c = self.config
        total, feasible = 0.0, 1.0
        for j, ((key, cost), ident) in enumerate(zip(terms, idents, strict=True)):
            known = None
            if c.reuse_in_q and ident is not None and (first or j):
                known = self._known.get(ident)
            if known is not None:
                total += known
                continue
            seen = None
            if node is not None and tree is not None and c.attempt_posterior:
                seen = self.evidence.outcomes(tree, node if j == 0 else None, key)
            if seen is None:
                total += expected(cost, p_min=c.p_min)
                if c.dead_end_prior:
                    feasible *= 1.0 - dead_end_chance(cost, p_min=c.p_min)
            else:  # a success proves it feasible; failures only: after_attempts weighs them
                ok, failed = seen
                total += after_attempts(cost, ok, failed, p_min=c.p_min, p_max=c.p_max)
        return total, feasible

    def q(self, tree: Tree, node: Node) -> float:
        """Expected seconds still to spend on ``node``'s plan: the execution of the
        trajectories already bound on its path (bound_execution), plus Eq. 4 over the
        predictions (made once per node), each term updated by the outcomes of the same query
        already made (attempt_posterior, pooled_evidence), as counted at the last refresh, and
        calibrated by the children the node already has (calibration). Remembered until
        something it reads changes (:meth:`_refresh` finds what)."""
        memo = self._qmemo.get(node.id)
        if memo is not None and node.id not in self._dirty:
            return memo
        value = self._q_now(tree, node)
        self._qmemo[node.id] = value
        return value

    def _q_now(self, tree: Tree, node: Node) -> float:
        self._predict(tree, [node])
        shift = self._calibration(tree, node) if self.config.calibration else 0.0
        if not self.config.attempt_posterior or not self.evidence.any:
            return self._q[node.id] + shift
        total, feasible = self._remaining(
            self._terms[node.id],
            self._idents[node.id],
            first=not node.children,
            node=node,
            tree=tree,
        )
        return self._bound[node.id] + with_dead_ends(total, feasible) + shift

    def _calibration(self, tree: Tree, node: Node) -> float:
        """How much worse (or better) the node's children came out than the models guessed for
        a child before seeing one, shrunk towards 0 by :data:`PRIOR_CHILDREN` (see
        :attr:`LearnedConfig.calibration`)."""
        fresh = self._fresh.get(node.id)
        if fresh is None:
            return 0.0
        dead = self.dead
        kids = [tree[c] for c in node.children if tree[c].success and c not in dead]
        if not kids:
            return 0.0
        self._predict(tree, kids)
        surprise = sum(self._q[c.id] - fresh for c in kids)
        return surprise / (len(kids) + PRIOR_CHILDREN)

    def _refresh(self, tree: Tree) -> None:
        """Count the outcomes of every query made and find the dead ends
        (:class:`~planner.search.evidence.Evidence`), then estimate every node: the lowest Q in
        its subtree, dead ends left out (subtree_min; progress counts, and a dead end below
        raises its Q until another branch is cheaper).

        Incremental: only the nodes something changed for since the last refresh are
        estimated again (new nodes and their parents, nodes that read a query whose outcomes
        changed or a result newly reusable, nodes that became or stopped being dead ends and
        their parents), then their ancestors while their estimates change. Children come after
        their parents, so one pass down the ids does it."""
        dirty = self._dirty
        new = tree.nodes[max(self._seen, 1) :]
        self._seen = len(tree.nodes)
        self._predict(tree, [n for n in new if n.success])
        for node in new:
            dirty.add(node.id)
            if node.parent is not None:
                dirty.add(node.parent)
        if self.config.reuse_in_q:
            for node_id in self._learn_results(tree):
                dirty.add(node_id)
                parent = tree[node_id].parent
                if parent is not None:
                    dirty.add(parent)
        before_dead = self.dead
        changed = self.evidence.refresh(tree)
        dead = self.dead
        for node_id in before_dead ^ dead:
            dirty.add(node_id)
            parent = tree[node_id].parent
            if parent is not None:
                dirty.add(parent)
        for key in changed:
            dirty.update(self._by_key.get(key, ()))
        if self.evidence.any != self._any:
            self._any = self.evidence.any
            dirty.update(n.id for n in tree.nodes[1:])
        est = self._est
        todo = sorted(dirty, reverse=True)
        queued = set(todo)
        heap = [-n for n in todo]
        heapq.heapify(heap)
        while heap:
            node = tree[-heapq.heappop(heap)]
            queued.discard(node.id)
            if not node.success or node.id == ROOT:
                continue
            old = est.get(node.id)
            best = self.q(tree, node)
            dirty.discard(node.id)
            if node.id in dead:  # every continuation is taken to fail: going on costs 1 / 0.05 x
                best = with_dead_ends(best, 0.0)
            elif self.config.subtree_min:
                for c in node.children:  # a dead end's subtree no longer vouches for its parent
                    if c in est and c not in dead and est[c] < best:
                        best = est[c]
            est[node.id] = best
            parent = node.parent
            if best != old and parent is not None and parent != ROOT and parent not in queued:
                queued.add(parent)
                heapq.heappush(heap, -parent)
        dirty.clear()

    def _learn_results(self, tree: Tree) -> list[int]:
        """Note the first success of each reusable query made since the last refresh, and
        settle again the nodes whose streams ahead include it; returns those nodes."""
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
        touched = sorted({n for i in fresh for n in self._by_ident.get(i, ())})
        for node_id in touched:
            self._settle(tree[node_id])
        return touched

    def _relevant(self, node: Node) -> set[str]:
        """Objects the outcome of ``node``'s next query depends on: its inputs and the objects of
        the state facts that make up its identity (see :meth:`_key`); a fresh set each call."""
        where = (node.plan_index, node.depth)
        found = self._relevant_at.get(where)
        if found is None:
            inst = self.skeletons[node.plan_index].stream_plan[node.depth]
            facts = self.states[node.plan_index][node.depth]
            out = set(inst.inputs)
            for a in facts:
                if a.predicate in self.fluents and a.predicate not in self.evidence_ignore:
                    out.update(a.args)
            found = self._relevant_at[where] = frozenset(out)
        return set(found)

    def _estimate(self, tree: Tree, node: Node) -> float:
        """The node's estimate as of the last refresh (its Q before the first)."""
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

    def observe(self, tree: Tree, nodes: Sequence[Node]) -> None:
        """Predict the nodes a rollout made, in one batch, so every node carries a prediction
        (and a ``model_prediction`` event) even when the search ends with that rollout."""
        self._predict(tree, [n for n in nodes if n.success])

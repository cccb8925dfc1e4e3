"""The learned policy (Bradley & Roy): UCT over the expected remaining cost of a stream plan.

**The paper's algorithm** (planner ``paper``, :meth:`LearnedConfig.paper`): a node's value is
-Q, Q the expected seconds still to spend on its plan, Eq. 4 (:mod:`planner.search.costs`): for
each remaining stream, ``R_S + R_M + (1 - P_S) / P_S * R_F``, predicted by per-stream models
from the stream's inputs (zero and masked where not bound yet) and the scene. Selection is UCT on
-Q, and "query this stream again" is one more action scored by the same formula (the node's own
Q), so there is no progressive-widening rule; the stream plans keep their own order.

**The additions** (planner ``learned``, :class:`LearnedConfig`'s defaults): each is one field of
:class:`LearnedConfig`, switched off by name (``tamp bench --planners
learned,learned:dead_ends=off``); its docstring says what it does and what it measured.
What failed queries teach (dead ends) lives in :mod:`planner.search.evidence`.
The models are reached through the :class:`Predictor` protocol, so this module needs no torch.

A node's Q is predicted once, when it is made (only the rows its binding changed are predicted
again); what changes afterwards is which nodes are dead ends and, with ``subtree_min``, the
lowest Q below each node. Both are kept up to date incrementally, so the search's own seconds
per node do not grow with the tree.
"""

from __future__ import annotations

import bisect
import heapq
import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any, Protocol

from planner.abstract.skeleton import AbstractPlan
from planner.pddl.structs import Atom
from planner.search.baseline import (
    BaselineConfig,
    failure_value,
    should_widen,
    success_value,
    ucb,
)
from planner.search.costs import (
    DEAD_END_MAX,
    StreamCost,
    dead_after,
    dead_end_cost,
    remaining_cost,
)
from planner.search.evidence import Evidence
from planner.search.queries import query_context, remembered
from planner.search.tree import ROOT, Node, Tree

__all__ = [
    "DEAD_END_MAX",
    "LearnedConfig",
    "LearnedPolicy",
    "Predictor",
    "StreamCost",
    "dead_after",
    "dead_end_cost",
    "remaining_cost",
    "row_names",
    "stream_rows",
    "trusted_streams",
]

Row = tuple[str, list[Any | None], dict[str, Any]]  # stream, encoded inputs, context
_RootKey = tuple[str, tuple[str | None, ...], frozenset[Atom]]  # LearnedPolicy._root_key


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
    reads only the values of :func:`row_names`. Rows queried in one state share one context
    object (read it, do not change it): the featurizer computes a context's state part once."""
    rows = []
    contexts: dict[int, dict[str, Any]] = {}  # per state object of the plan
    for i in range(start, len(plan.stream_plan)):
        if only is not None and i not in only:
            continue
        inst = plan.stream_plan[i]
        inputs = [encode(values[n]) if n in values else None for n in inst.inputs]
        context = contexts.get(id(states[i]))
        if context is None:
            context = query_context(
                states[i], values, fluents=fluents, static_context=static_context, encode=encode
            )
            contexts[id(states[i])] = context
        rows.append((inst.stream, inputs, context))
    return rows


def row_names(
    plan: AbstractPlan, states: Sequence[frozenset[Atom]], fluents: frozenset[str]
) -> list[frozenset[str]]:
    """Per stream of ``plan``: the objects whose values its model row reads (its inputs and the
    arguments of its context's fluent facts). A row none of whose objects a new binding names
    is the same row as before that binding."""
    read: dict[int, frozenset[str]] = {}  # per state object (a plan's streams share states)
    out = []
    for i, inst in enumerate(plan.stream_plan):
        state = states[i]
        names = read.get(id(state))
        if names is None:
            names = read[id(state)] = frozenset(
                x for a in state if a.predicate in fluents for x in a.args
            )
        out.append(frozenset(inst.inputs) | names)
    return out


class Predictor(Protocol):
    """Batched predictions: one (stream, encoded inputs or None, context) per row."""

    def predict_rows(
        self, rows: Sequence[tuple[str, Sequence[Any | None], Mapping[str, Any]]]
    ) -> list[StreamCost]: ...


def trusted_streams(predictor: Predictor) -> frozenset[str] | None:
    """The streams whose predictions a search may trust (``LearnedConfig.trust``), as the
    predictor says (its ``trusted()``: a trained model's validation, none for priors); None
    (trust all) for a predictor that does not say."""
    said = getattr(predictor, "trusted", None)
    return None if said is None else said()


EXPLORE_STREAMS = 36  # plans longer than this explore less (LearnedConfig.explore_by_length)


@dataclass(frozen=True)
class LearnedConfig:
    """The learned planner's parts. All off (:meth:`paper`) is the paper's planner; the
    defaults are the planner ``learned``. Each field's docstring: what it does, why, what it
    measured (docs/BENCHMARKS.md, *Planners compared*)."""

    c_explore: float = 0.05
    """UCT exploration weight on values normalised to (0, 1] by the best plan's Q."""

    explore_by_length: bool = True
    """In a stream plan longer than ``EXPLORE_STREAMS`` streams the exploration weight shrinks
    in proportion: ``c_explore * EXPLORE_STREAMS / n``. Binding one more stream gains about one
    stream's share of the plan's value, so the longer the plan, the smaller the differences the
    bonus competes with: at 0.05 (set on kitchen-4's 36 streams) kitchen-20 (180) and -24 (216)
    re-drew their first placements over and over (2,064 new branches at depths 0 to 29 in one
    timed-out kitchen-20 run), and at 0.01 (this rule's weight at 180 streams) both solved.
    Plans of up to 36 streams (kitchen-4, panda-4, PDDLStream's 2-D scenes) keep 0.05; panda-6
    (48) gets 0.0375, kitchen-8 (72) 0.025. Off: ``c_explore`` at every length.

    Measured: docs/BENCHMARKS.md, *Exploration weight: kitchen-20 and kitchen-24*."""

    dead_ends: bool = True
    """A node whose next query failed (or led only to dead ends) more often than its
    prediction explains is a dead end: it and its ancestors up to the one that bound something
    the failures depend on are priced as if every continuation fails (backjumping), and a dead
    end counts as a failed attempt of its parent's query.

    Measured (off against on, paired, docs/BENCHMARKS.md): helps on tabletop-4 (a73daea, 40
    seeds): without it 8 timeouts in 40 and planning 1325% more (745% to 1931% more); not
    measurable on kitchen-4 (13d3942, 40 seeds: total 1.6% more, 1.1% less to 4.9% more) nor
    on kitchen-8 (f794838, 40 seeds: total 1.1% more, 1.0% less to 4.7% more)."""

    subtree_min: bool = True
    """A node is estimated by the lowest Q in its subtree, dead ends left out (progress along
    a plan counts); off: by its own Q.

    Measured (off against on, paired, docs/BENCHMARKS.md): helps on tabletop-4 (a73daea, 40
    seeds): planning 105% more without it (63% to 156% more); helps on kitchen-8 (f794838, 40
    seeds): total 8.2% more without it (1.4% to 15.4% more), its plans executing 7.0% longer
    (1.0% to 13.3% longer); on kitchen-4 (13d3942, 40 seeds) plans execute 5.0% longer
    without it (0.4% to 10.4% longer)."""

    model_order: bool = True
    """Each stream plan is reordered before the search by the model's predictions: cheap tests
    likely to fail first, never before the streams whose outputs they read
    (planner/search/order.py); off: the plan's own order (``--order`` overrides either way).

    Measured (off against on, paired, docs/BENCHMARKS.md): helps on kitchen-8 (13d3942, 40
    seeds): without it 2 timeouts in 40, total 27.6% more (11.8% to 47.0% more), planning 124%
    more, plans executing 10.4% longer (4.1% to 16.9% longer); helps on kitchen-4 (13d3942, 40
    seeds): total 14.2% more without it (2.4% to 29.7% more); not measurable on tabletop-4
    (a73daea: planning 5% more, 7% less to 19% more)."""

    exhaustion: bool = True
    """A node whose stream said it will find nothing more for its inputs (an ended generator, a
    PDDLStream ``from_fn`` or ``from_list_fn`` that gave what it had) is not queried again, and
    a plan whose nodes are all exhausted is not chosen again (planner/search/mcts.py). Not a
    part of the policy but the stream's own word: on for every tree search, the baseline's and
    the paper's too; off queries such a node again and again (each query a failure).

    Measured (off against on, paired): on pickplace-4 (e6d5278, 8 seeds, a table since
    superseded) off asked 982 IK queries to on's 281, 821 of them failures, at no measurable
    cost in time."""

    plans_by_estimate: bool = True
    """The stream plan to go down is the one with the best estimate, without UCT's exploration
    bonus among plans (ties to the top-k planner's order); below a plan's node the bonus stays.
    Off: UCT at the root too, as the paper. Why: the k plans of a long problem are mostly the
    same plan in other orders, predicted alike, so the bonus sends the search down each of them
    once before it goes back to one it has started; where a query fails now and then (an IK
    hemmed in by a block), every plan's rollout ends at such a failure and the progress made
    on one plan is left for the next. Plans are still left by evidence: a dead end below a plan
    raises its estimate.

    Measured (off against on, paired, docs/BENCHMARKS.md): helps on the Panda: panda-10 (40
    seeds) total 7.8% more without it (3.7% to 12.0% more), planning 41% more, its plans
    executing 5.2% longer; panda-12 (40 seeds) total 6.1% more (1.9% to 11.6% more); one
    panda-10 seed's 1,058 queries become 102. Not measurable on panda-6 (40 seeds), kitchen-8
    (30 seeds: total 0.1% more, 4.3% less to 4.9% more), kitchen-12 (10 seeds: 4.2% less,
    15.8% less to 8.1% more) or tabletop-4 (40 seeds). What it gives up: a plan whose rollouts
    keep failing far down is left only once its failures make dead ends (kitchen-12 seed 1008
    planned 332 s with it, 142 s without)."""

    trust: bool = True
    """The search trusts a stream's predictions only where the model showed, on the runs it
    held out, that it tells that stream's outcomes apart better than the stream's average (its
    validation log loss of ``P_S`` below its prior's; ``tamp train`` prints both). Priors are
    never trusted. A choice that no trusted prediction informs (at a node none of whose
    remaining streams is trusted: every child is then estimated alike but for how far it got)
    follows the baseline's rules instead: query again when the node's visits exceed eTAMP's
    widening bound, descend by UCB on what the rollouts below reached; and with no trusted
    stream at all (priors only, a model that learned nothing) the stream plans are opened and
    chosen as the baseline does. A model file without validation figures is trusted
    throughout. Why: on a domain it has never seen, estimates that cannot tell bindings apart
    turned the search depth-first (it went where it had got furthest, with little exploration)
    and ranked stream plans by their length instead of the top-k planner's cost.

    Measured: docs/BENCHMARKS.md, *Published PDDLStream examples*: on priors (nothing
    trusted) ``learned`` solved what the baseline solved on all seven pick_place_2d scenes;
    off against on was measured at 951652e (the grid example's test), not on the benchmarks."""

    exhausted_dead: bool = True
    """With ``dead_ends``: a node whose stream said it has nothing more for its inputs (an
    exhausted PDDLStream function, test or list) and that has nothing live below it is a dead
    end at once, its reason what its failed queries and the dead ends below it depend on, where
    that is known (the stream's sampler reads its inputs and declared fluents, not the whole
    state: a guessed reason backjumps too far); and
    the node above counts each such child as a failure as likely as the predictions of the
    queries down to where it died say (a placement predicted sure whose collision tests are
    doubtful may die many times before the placement it collides with is to blame). So a
    placement that left no room for the next block is backjumped from. Off: an exhausted node
    is left alone (never queried again) but counts as a live success for the node above,
    which keeps re-sampling below a choice that left no room (the issue's 4,429 placements).

    Measured on pickplace-4 at c7acaa6 (158 and 262 queries with it, as with the part off,
    where counting each death as a failure of the sure placement made 1,682 and 699); not
    measured on the current benchmarks."""

    exhausted_given: bool = True
    """With ``exhausted_dead``: a node whose sampler reads the whole state it is given (bound
    with context, as the kitchen's and the Panda's IK are) and whose query came back as a
    known failure (``TreeSearch.memo_exhausted``: the same inputs in the same state failed
    before and said they will) is a dead end too, its reason its inputs and every object of
    that state, not the part a domain's ``evidence_ignore`` keeps. The memory keys on those
    objects, so the failure's return proves that whatever was re-sampled since, below the
    node that bound one of them, did not matter: the search backjumps there. A stream plan
    samples the placements before the IK that picks the first block, so the IK failure a grasp
    caused sat below twenty-odd placements the state at the failure does not hold. A first
    failure is left alone, as before: the guess of what it depends on is the domain's.
    Off: the node above sees a failure its prediction explains (``known_failures``), and the
    search re-draws whatever lies between (kitchen-24 seed 1000: the same 20 stove placements
    14,855 times, the same known failure below 9,728 times, no solution in 1800 s).

    Measured: docs/BENCHMARKS.md, *Known failures backjump*: kitchen-24 seed 1000 solved in
    34 s of planning; panda-6 and kitchen-8, 10 seeds each, identical trials. The first form
    of the rule, a dead end at the first exhausted failure, cost panda-6 5.3% of total time
    (0.1% to 13.3%): the domain's guess stands there."""

    doubt_plans: bool = True
    """A stream plan that relies on a stream instance the search doubts (the same instance of
    the optimistic task, over every plan and node, asked often with no success, or proved
    false: planner/search/mcts.py ``feedback``) is estimated as a dead end, and a fresh
    skeleton is asked for when every open plan is (the new one plans around what failed,
    planner/abstract/source.py). Off: a plan's estimate reads only its own nodes, which a
    failing instance fed fresh samples leaves low (the search resamples a pose that leaves no
    room, again and again).

    Measured (off against on, paired, docs/BENCHMARKS.md, *Published PDDLStream examples*):
    off, pickplace-blocked-3 is solved in none of 20 seeds (20 of 20 on); on the tight regions
    it costs (off takes 10% less total time at 4 and 6 blocks, 37% less at 8, where a clearance
    test that fails often but not always is doubted)."""

    known_failures: bool = True
    """A node whose next query the search answered as a known failure (the same stream and
    inputs found nothing before and said it will not: ``Node.known_failure``) is predicted to
    fail (``P_S`` 0), so the node above does not count its death against its own query: a
    list of grasps that starts again at the two that never reach is asked on to the third.
    Off: the model's prediction stands (a sure IK made each such death look like bad luck of
    the node above, which was backjumped from after two, and every fresh branch began with the
    same two grasps).

    Measured: docs/BENCHMARKS.md, *Published PDDLStream examples*."""

    @classmethod
    def paper(cls) -> LearnedConfig:
        """The paper's policy: every addition off (exhaustion, the streams' contract, stays).

        The planner ``paper`` runs it on the loop every tree search here shares, which is not
        the paper's: identical answers reused (``TreeSearch(reuse=True)``), a test or a known
        failure not asked twice, skeletons on demand. A paired benchmark then compares the
        policies alone, not a motion cache (docs/learning.md, *The learned policy*)."""
        off = {f.name: False for f in fields(cls) if f.type in (bool, "bool")}
        return cls(**{**off, "exhaustion": True})

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


class _Queries:
    """What the evidence reads of the policy's predictions (planner.search.evidence)."""

    def __init__(self, policy: LearnedPolicy) -> None:
        self.policy = policy

    def first(self, node: Node) -> StreamCost | None:
        entries = self.policy._entries.get(node.id)
        if not entries:
            return None
        first = entries[0]
        if node.known_failure and self.policy.config.known_failures:
            return StreamCost(0.0, first.r_s, first.r_f, first.r_m)  # LearnedConfig
        return first

    def relevant(self, node: Node) -> set[str]:
        return self.policy._relevant(node)

    def precise(self, node: Node) -> bool:
        return self.policy._precise(node)

    def given(self, node: Node) -> set[str]:
        return self.policy._given(node)


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
    evidence_ignore: frozenset[str] = frozenset()  # fluents a failure does not depend on
    # Per stream, the fluents its sampler can read (its declared :fluents); a stream not named
    # here reads the whole state (a sampler given the context). A PDDLStream stream with no
    # :fluents reads only its inputs, so its failures depend on nothing else.
    reads: Mapping[str, frozenset[str]] = field(default_factory=dict)
    # The streams whose predictions the search trusts (LearnedConfig.trust); None: all.
    trusted: frozenset[str] | None = None
    baseline: BaselineConfig = field(default_factory=BaselineConfig)  # for untrusted choices
    static_context: Mapping[str, Any] = field(default_factory=dict)  # in every row's context
    _q: dict[int, float] = field(default_factory=dict)  # Eq. 4 of each predicted node
    # Per node predicted: the prediction of each stream from its depth on; a child's rows that
    # its new binding leaves alone are taken from its parent's.
    _entries: dict[int, list[StreamCost]] = field(default_factory=dict)
    _est: dict[int, float] = field(default_factory=dict)  # each node's estimate (subtree_min)
    _scale: float = 0.0
    _evidence: Evidence | None = None
    # Per plan: for each object, the streams whose rows read it (row_names), in order.
    _readers: list[dict[str, list[int]]] = field(default_factory=list)
    _seen: int = 0  # nodes the refreshes have taken in
    _relevant_at: dict[tuple[int, int], frozenset[str]] = field(default_factory=dict)
    _given_at: dict[tuple[int, int], frozenset[str]] = field(default_factory=dict)
    _root_costs: dict[_RootKey, StreamCost] = field(default_factory=dict)  # rows of plan nodes
    _fluent_state: dict[int, tuple[frozenset[Atom], frozenset[Atom]]] = field(
        default_factory=dict
    )  # per state object: its fluent facts (one object for equal sets: keys compare by identity)
    _fluent_sets: dict[frozenset[Atom], frozenset[Atom]] = field(default_factory=dict)
    _informed_at: dict[tuple[int, int], bool] = field(default_factory=dict)
    _trusting: tuple[int, bool] | None = None  # (plans seen, whether any stream is trusted)
    _doubted: frozenset[tuple[str, tuple[str, ...]]] = frozenset()  # instances the search doubts
    _doubted_plans: dict[int, bool] = field(default_factory=dict)  # per plan: relies on one

    def __post_init__(self) -> None:
        c = self.config
        self.encode = remembered(self.encode)
        self._evidence = Evidence(
            _Queries(self),
            dead_ends=c.dead_ends,
            exhausted_dead=c.exhausted_dead,
            exhausted_given=c.exhausted_given,
        )

    @property
    def evidence(self) -> Evidence:
        assert self._evidence is not None
        return self._evidence

    @property
    def dead(self) -> Mapping[int, frozenset[str]]:
        """The nodes taken for dead ends (with the objects their failures depend on), as of the
        last refresh."""
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
        while len(self._readers) < len(self.skeletons):  # plans may come during the search
            index = len(self._readers)
            readers: dict[str, list[int]] = {}
            plan_names = row_names(self.skeletons[index], self.states[index], self.fluents)
            for i, names in enumerate(plan_names):
                for name in names:
                    readers.setdefault(name, []).append(i)
            self._readers.append(readers)
        readers = self._readers[node.plan_index]
        outputs = list(node.outputs)
        if len(outputs) == 1:
            found = readers.get(outputs[0], [])
            return found[bisect.bisect_left(found, node.depth) :]
        stale = {i for name in outputs for i in readers.get(name, ()) if i >= node.depth}
        return sorted(stale)

    def _predict(self, tree: Tree, nodes: Sequence[Node]) -> None:
        """Eq. 4 predictions for nodes that have none yet, in one batch."""
        todo = sorted((n for n in nodes if n.id not in self._q), key=lambda n: n.id)
        if not todo:
            return
        # Only the rows a node's new binding changed are built and predicted, in one batch; the
        # rest are its parent's, predicted before or earlier in this batch (parents come first).
        # A stream plan's own node binds nothing: its rows are those of the initial values, and
        # stream plans share most of them (the same stream, inputs and state): each such row is
        # predicted once.
        rows: list[Row] = []
        slots: dict[int, list[int | StreamCost]] = {}  # per node: a row of this batch, or a cost
        opened: dict[_RootKey, int] = {}  # a plan node's row in this batch, by what it reads
        for node in todo:
            stale = self._stale(tree, node, slots.keys())
            count = len(self.skeletons[node.plan_index].stream_plan)
            fresh: Sequence[int] = range(node.depth, count) if stale is None else stale
            known: dict[int, int | StreamCost] = {}
            if node.parent == ROOT:
                new: list[int] = []
                for i in fresh:
                    key = self._root_key(node.plan_index, i)
                    if key in self._root_costs:
                        known[i] = self._root_costs[key]
                    elif key in opened:
                        known[i] = opened[key]
                    else:
                        opened[key] = len(rows) + len(new)
                        new.append(i)
                fresh = new
            at: dict[int, int | StreamCost] = dict(
                zip(fresh, range(len(rows), len(rows) + len(fresh)), strict=True)
            )
            at.update(known)
            if fresh:
                values = {**self.initial_values, **tree.bindings(node.id)}
                rows += self._rows(node.plan_index, node.depth, values, fresh)
            parent: Sequence[int | StreamCost] = ()
            if stale is not None and node.parent is not None:
                parent = slots[node.parent] if node.parent in slots else self._entries[node.parent]
            slots[node.id] = [
                at[i] if i in at else parent[i - node.depth + 1] for i in range(node.depth, count)
            ]
        costs = self.predictor.predict_rows(rows) if rows else []
        for key, index in opened.items():
            self._root_costs[key] = costs[index]
        for node in todo:
            entries = [costs[s] if isinstance(s, int) else s for s in slots[node.id]]
            self._entries[node.id] = entries
            self._q[node.id] = remaining_cost(entries)
            if entries and self.on_prediction is not None:
                self.on_prediction(node, entries[0], self._q[node.id])

    def _root_key(self, plan_index: int, i: int) -> _RootKey:
        """What stream ``i`` of a plan reads before anything is bound: the stream, which of its
        inputs have initial values, and the fluent facts of its state."""
        inst = self.skeletons[plan_index].stream_plan[i]
        state = self.states[plan_index][i]
        facts = self._fluent_state.get(id(state))
        if facts is None or facts[0] is not state:
            fluent = frozenset(a for a in state if a.predicate in self.fluents)
            facts = (state, self._fluent_sets.setdefault(fluent, fluent))
            self._fluent_state[id(state)] = facts
        inputs = tuple(n if n in self.initial_values else None for n in inst.inputs)
        return inst.stream, inputs, facts[1]

    def q(self, tree: Tree, node: Node) -> float:
        """Expected seconds still to spend on ``node``'s plan: Eq. 4 over the predictions of its
        remaining streams, made once when the node is first seen."""
        found = self._q.get(node.id)
        if found is None:
            self._predict(tree, [node])
            found = self._q[node.id]
        return found

    def _refresh(self, tree: Tree) -> None:
        """Take in the nodes made since the last refresh, find the dead ends they make or undo
        (:class:`~planner.search.evidence.Evidence`), then estimate the nodes whose estimate
        may have changed: a dead end is priced as if every continuation fails; with
        subtree_min, a node is estimated by the lowest Q in its subtree, dead ends left out
        (progress counts, and a dead end below raises its estimate until another branch is
        cheaper).

        Incremental: new nodes and their parents, and nodes that became or stopped being dead
        ends and their parents, are estimated again, then their ancestors while their estimates
        change. Children come after their parents, so one pass up the ids does it."""
        new = tree.nodes[max(self._seen, 1) :]
        self._seen = len(tree.nodes)
        self._predict(tree, [n for n in new if n.success])
        dirty: set[int] = set()
        for node in new:
            dirty.add(node.id)
            if node.parent is not None:
                dirty.add(node.parent)
        for node_id in self.evidence.refresh(tree):
            dirty.add(node_id)
            parent = tree[node_id].parent
            if parent is not None:
                dirty.add(parent)
        dead = self.dead
        est = self._est
        queued = set(dirty)
        heap = [-n for n in dirty]
        heapq.heapify(heap)
        while heap:
            node = tree[-heapq.heappop(heap)]
            queued.discard(node.id)
            if not node.success or node.id == ROOT:
                continue
            old = est.get(node.id)
            best = self.q(tree, node)
            if node.id in dead:  # every continuation is taken to fail
                best = dead_end_cost(best)
            elif self.config.subtree_min:
                for c in node.children:  # a dead end's subtree no longer vouches for its parent
                    if c in est and c not in dead and est[c] < best:
                        best = est[c]
            est[node.id] = best
            parent = node.parent
            if best != old and parent is not None and parent != ROOT and parent not in queued:
                queued.add(parent)
                heapq.heappush(heap, -parent)

    def _relevant(self, node: Node) -> set[str]:
        """Objects the outcome of ``node``'s next query depends on: its inputs and the objects of
        the fluent facts of its context that its sampler can read (``reads``), but for
        ``evidence_ignore``'s; a fresh set each call."""
        where = (node.plan_index, node.depth)
        found = self._relevant_at.get(where)
        if found is None:
            inst = self.skeletons[node.plan_index].stream_plan[node.depth]
            facts = self.states[node.plan_index][node.depth]
            readable = self.reads.get(inst.stream, self.fluents)
            out = set(inst.inputs)
            for a in facts:
                if a.predicate in readable and a.predicate not in self.evidence_ignore:
                    out.update(a.args)
            found = self._relevant_at[where] = frozenset(out)
        return set(found)

    def _given(self, node: Node) -> set[str]:
        """Objects ``node``'s next query is given: its inputs and the objects of every fluent
        fact of its state (what :func:`planner.search.queries.query_context` records); a fresh
        set each call."""
        where = (node.plan_index, node.depth)
        found = self._given_at.get(where)
        if found is None:
            inst = self.skeletons[node.plan_index].stream_plan[node.depth]
            out = set(inst.inputs)
            for a in self.states[node.plan_index][node.depth]:
                if a.predicate in self.fluents:
                    out.update(a.args)
            found = self._given_at[where] = frozenset(out)
        return set(found)

    def _precise(self, node: Node) -> bool:
        """Whether what ``node``'s next query depends on is known (its sampler reads its
        inputs and declared fluents only, ``reads``), not the whole state it is given."""
        inst = self.skeletons[node.plan_index].stream_plan[node.depth]
        return inst.stream in self.reads

    def _estimate(self, tree: Tree, node: Node) -> float:
        """The node's estimate as of the last refresh (its Q before the first); a plan's node
        priced as a dead end while its plan relies on a doubted instance (``doubt_plans``)."""
        found = self._est.get(node.id)
        value = found if found is not None else self.q(tree, node)
        if node.parent == ROOT and self._doubted and self._relies_on_doubt(node.plan_index):
            return dead_end_cost(value)
        return value

    def _relies_on_doubt(self, plan_index: int) -> bool:
        found = self._doubted_plans.get(plan_index)
        if found is None:
            stream_plan = self.skeletons[plan_index].stream_plan
            found = any((s.stream, s.inputs) in self._doubted for s in stream_plan)
            self._doubted_plans[plan_index] = found
        return found

    def doubts(self, instances: frozenset[tuple[str, tuple[str, ...]]]) -> None:
        """The search doubts these stream instances now (read only with ``doubt_plans``)."""
        if self.config.doubt_plans:
            self._doubted = instances
            self._doubted_plans.clear()

    def _value(self, q: float) -> float:
        return self._scale / (self._scale + q) if self._scale > 0 else 1.0 / (1.0 + q)

    def _bonus(self, visits: int, parent_visits: int, plan_index: int | None = None) -> float:
        """UCT's bonus in stream plan ``plan_index`` (None: the shortest plan's weight)."""
        return self._c(plan_index) * math.sqrt(math.log(parent_visits + 1) / (visits + 1))

    def _c(self, plan_index: int | None) -> float:
        """The exploration weight in a stream plan (``explore_by_length``)."""
        c = self.config.c_explore
        if not self.config.explore_by_length or not self.skeletons:
            return c
        if plan_index is None:
            n = min(len(p.stream_plan) for p in self.skeletons)
        else:
            n = len(self.skeletons[plan_index].stream_plan)
        return c * min(1.0, EXPLORE_STREAMS / max(n, 1))

    # --- trust (LearnedConfig.trust) -----------------------------------------------------------

    @property
    def trusting(self) -> bool:
        """Whether any stream of the plans has trusted predictions (always, with ``trust``
        off); worked out again only when plans are added."""
        if not self.config.trust or self.trusted is None:
            return True
        if self._trusting is None or self._trusting[0] != len(self.skeletons):
            trusted = self.trusted
            found = any(i.stream in trusted for p in self.skeletons for i in p.stream_plan)
            self._trusting = (len(self.skeletons), found)
        return self._trusting[1]

    def _informed(self, node: Node) -> bool:
        """Whether a trusted prediction informs the choice at ``node``: some stream from its
        depth on is trusted (always, with ``trust`` off)."""
        if not self.config.trust or self.trusted is None:
            return True
        where = (node.plan_index, node.depth)
        found = self._informed_at.get(where)
        if found is None:
            rest = self.skeletons[node.plan_index].stream_plan[node.depth :]
            found = self._informed_at[where] = any(i.stream in self.trusted for i in rest)
        return found

    def _ucb(self, tree: Tree, node: Node, parent: Node, c: float) -> float:
        return ucb(node.value, node.visits, parent.visits, c)

    # --- the Policy protocol -----------------------------------------------------------------

    def initial_plans(self, total: int) -> int:
        # every stream plan is scored from the start; untrusting, they open as the baseline's
        return total if self.trusting else 0

    def add_plan(self, tree: Tree, plans_added: int, plans_total: int) -> bool:
        if self.trusting:
            return plans_added < plans_total  # only if initial_plans left some closed
        if plans_added >= plans_total:
            return False
        root = tree[ROOT]
        return plans_added == 0 or root.visits > self.baseline.root_widen_k * plans_added**2

    def pick_plan(self, tree: Tree) -> Node:
        self._refresh(tree)
        root = tree[ROOT]
        plans = tree.live_children(ROOT)  # not the dead (exhausted) ones
        if not self.trusting:
            return max(plans, key=lambda n: self._ucb(tree, n, root, self.baseline.c_plan))
        if self._scale <= 0:
            self._scale = max(min(self.q(tree, p) for p in plans), 1e-3)
        if self.config.plans_by_estimate:  # max keeps the first of equals: the top-k order
            return max(plans, key=lambda n: self._value(self._estimate(tree, n)))
        return max(
            plans,
            key=lambda n: (
                self._value(self._estimate(tree, n))
                + self._bonus(n.visits, root.visits, n.plan_index)
            ),
        )

    def ask_more(self, tree: Tree, plans_open: int, asked: int, ask_s: float) -> bool:
        """Ask the skeleton source for another stream plan when a fresh one is estimated better
        than every open plan: a fresh plan at the lowest Q any plan had when it was opened
        (before anything was bound), plus the seconds a request takes; the open plans at their
        estimates (progress lowers one, dead ends raise it). Without ``plans_by_estimate``
        each side gets UCT's bonus too, the fresh plan's by the requests made. Trusting no
        stream (``trust``), the baseline's widening rule at the root."""
        self._refresh(tree)
        if not self.trusting:
            return tree[ROOT].visits > self.baseline.root_widen_k * plans_open**2
        plans = tree.live_children(ROOT)
        if not plans:
            return True
        fresh = min(self.q(tree, tree[c]) for c in tree[ROOT].children) + ask_s
        if self._scale <= 0:
            self._scale = max(min(self.q(tree, p) for p in plans), 1e-3)
        root = tree[ROOT]
        bonus = not self.config.plans_by_estimate
        best = max(
            self._value(self._estimate(tree, p))
            + (self._bonus(p.visits, root.visits, p.plan_index) * bonus)
            for p in plans
        )
        new = self._value(fresh) + (self._bonus(asked, root.visits) if bonus else 0.0)
        return new > best

    def plans_added(
        self,
        skeletons: Sequence[AbstractPlan],
        states: Sequence[Sequence[frozenset[Atom]]],
    ) -> None:
        """Read the search's stream plans anew (a request brought more)."""
        self.skeletons = skeletons
        self.states = states

    def expand(self, tree: Tree, node: Node) -> bool:
        live = tree.live_children(node.id)
        if not live:
            return True
        if not self._informed(node):
            return should_widen(node.visits, len(node.children), self.baseline.widen_k)
        plan = node.plan_index
        again = self._value(self.q(tree, node)) + self._bonus(len(node.children), node.visits, plan)
        best = max(
            self._value(self._estimate(tree, c)) + self._bonus(c.visits, node.visits, plan)
            for c in live
        )
        return again > best

    def pick_child(self, tree: Tree, node: Node) -> Node:
        if not self._informed(node):
            return max(
                tree.live_children(node.id),
                key=lambda c: self._ucb(tree, c, node, self.baseline.c_node),
            )
        return max(
            tree.live_children(node.id),
            key=lambda c: (
                self._value(self._estimate(tree, c))
                + self._bonus(c.visits, node.visits, node.plan_index)
            ),
        )

    def leaf_value(self, leaf: Node, plan: AbstractPlan) -> float:
        """The baseline's values (a bound plan 1 and more, a failure by how far it got): the
        estimates read Q, refreshed every iteration; choices no trusted prediction informs read
        these, as the baseline does."""
        depth = len(plan.stream_plan)
        if leaf.success and leaf.depth == depth:
            return success_value([1.0] * len(plan.actions), self.baseline)
        return failure_value(leaf.depth - 1, depth, self.baseline)

    def observe(self, tree: Tree, nodes: Sequence[Node]) -> None:
        """Predict the nodes a rollout made, in one batch, so every node carries a prediction
        (and a ``model_prediction`` event) even when the search ends with that rollout."""
        self._predict(tree, [n for n in nodes if n.success])

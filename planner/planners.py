"""Planners by name: each binds the abstract plans of a task to real values, reporting through
events. One registry (:data:`PLANNERS`, :func:`get_planner`), as the top-k backends have.

- ``baseline``: eTAMP's progressive-widening tree search (Ren et al.);
- ``paper``: Bradley & Roy's policy: UCT on -Q (Eq. 4 from the per-stream models), "query
  again" as one more action, the stream plans' own order, none of ``learned``'s parts. Not
  exactly the paper's planner: it runs on the loop every tree search here shares
  (:meth:`_TreeSearchPlanner.solve`), which reuses identical answers (``reuse=True``), asks no
  test or known failure twice, leaves exhausted streams alone and takes skeletons on demand,
  so that a paired benchmark compares the policies alone (docs/learning.md, *The learned
  policy*, says why);
- ``learned``: the paper's planner with the additions measured to pay
  (:class:`~planner.search.learned.LearnedConfig`), the best configuration;
- ``sequential``: binds each skeleton's streams in order, with retries and restarts (the
  simplest thing that works, kept as a reference).

A learned planner uses the domain's trained model, or, without one, per-stream priors (success
rates and mean costs of recorded queries, or uniform figures), which it says in one warning
line. A **variant** changes parts of ``paper`` or ``learned`` by name:
``learned:dead_ends=off``, ``paper:dead_ends=on:c_explore=0.1`` (:func:`get_planner`).

A planner gets a :class:`PlanningTask` (the problem, its abstract plans, the stream runtime) and
returns a :class:`PlannerOutcome`; :func:`planner.api.solve` does the rest (top-k, events, the
result).
"""

from __future__ import annotations

import logging
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, ClassVar, Protocol

from planner.abstract.errors import PlannerTimeoutError
from planner.abstract.instantiate import StreamInstance
from planner.abstract.skeleton import AbstractPlan
from planner.abstract.source import SKELETON_SOURCES, Feedback, SkeletonSource
from planner.domains.spec import LoadedDomain
from planner.events import Emitter, SkeletonsAdded
from planner.pddl.structs import Atom, Problem
from planner.plans import execution_seconds
from planner.search.baseline import BaselineConfig
from planner.search.binding import (
    BoundPlan,
    bind_sequentially,
    plan_cost,
    shared_states,
    stream_contexts,
)
from planner.search.bounds import SearchBounds
from planner.search.feedback import InstanceRecords
from planner.search.learned import (
    LearnedConfig,
    LearnedPolicy,
    Predictor,
    StreamCost,
    stream_rows,
    trusted_streams,
)
from planner.search.mcts import BaselinePolicy, Policy, TreeSearch, context_json
from planner.search.order import order_streams, seconds_per_failure
from planner.search.queries import remembered
from planner.search.tree import Node
from planner.status import SearchStatus
from planner.streams.adapters import StreamContext
from planner.streams.runtime import QueryResult, StreamRuntime
from planner.trace import NodeEvents

log = logging.getLogger(__name__)

ORDERS = ("auto", "plan", "model")  # how a tree search orders each stream plan's streams
# A run's model named so runs on per-stream priors, as if its domain shipped no model.
PRIORS = "priors"


class PlannerConfig(Protocol):
    """What a planner reads of its run's config (:class:`planner.api.RunConfig` is one)."""

    @property
    def order(self) -> str:
        """One of :data:`ORDERS`."""
        ...

    @property
    def model(self) -> str | None:
        """The model file; None: the domain's own, else priors; :data:`PRIORS`: priors."""
        ...

    @property
    def planner(self) -> str:
        """The planner spec (:func:`get_planner`), which may set ``model=priors``."""
        ...

    @property
    def priors_db(self) -> str | None:
        """The store whose recorded queries give the priors when there is no model."""
        ...

    @property
    def c_explore(self) -> float | None:
        """A learned planner's UCT exploration weight; None: its parts' own."""
        ...

    @property
    def attempts(self) -> int:
        """Sequential only: queries of one stream before a restart."""
        ...

    @property
    def restarts(self) -> int:
        """Sequential only: restarts of one skeleton before the next."""
        ...


@dataclass
class PlanningTask:
    """What a planner binds: the problem, its abstract plans (and the symbolic state at each of
    their streams), the values of the problem's objects and the seeded samplers."""

    loaded: LoadedDomain
    problem: Problem
    plans: tuple[AbstractPlan, ...]
    initial: dict[str, Any]  # object name -> value (a name stands for itself)
    topk_s: float  # seconds the skeleton source took for the first plans
    static_context: dict[str, Any] = field(default_factory=dict)
    states: list[list[frozenset[Atom]]] = field(default_factory=list)
    runtime: StreamRuntime | None = None  # set once the plans are reported, before solve()
    # Where more plans come from during the search (None: the plans above are all there is),
    # and how many to ask for: the first batch's size times ``growth`` per request made.
    source: SkeletonSource | None = None
    batch: int = 10
    growth: float = 2.0
    doubt_after: int = 8  # a stream instance queried this often with no success is doubted
    # The domain's encoder, once per value object, shared by the search, its events and the
    # learned policy (planner.search.queries.remembered).
    encode: Callable[[Any], Any] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.encode = remembered(self.loaded.encode)

    @property
    def fluents(self) -> frozenset[str]:
        return self.loaded.fluents

    @property
    def samplers(self) -> StreamRuntime:
        if self.runtime is None:
            raise RuntimeError("the task's stream runtime is not bound yet")
        return self.runtime


@dataclass(frozen=True)
class PlannerOutcome:
    """How a planner ended, and what it made."""

    status: SearchStatus
    bound: BoundPlan | None
    execution_s: float | None  # trajectory seconds of the bound plan
    oracle_s: float | None  # top-k + successful queries on the solution branch
    queries: list[QueryResult]  # queries a sampler answered, in order
    nodes: int  # tree nodes (tree searches) or skeletons tried (sequential)
    reused: int = 0  # successes taken from an identical earlier query (not in ``queries``)
    search_cpu_s: float | None = None  # the search thread's CPU outside queries (tree searches)
    ended_by: str | None = None  # the count bound that ended it (SearchBounds.reached)


@dataclass(frozen=True)
class Budget:
    """When to stop: the run's start and deadline (perf_counter seconds), its bounds on queries
    and iterations (:mod:`planner.search.bounds`) and who may stop it."""

    start: float
    deadline: float
    progress: Callable[[str], None] | None = None
    should_stop: Callable[[], bool] | None = None
    bounds: SearchBounds = field(default_factory=SearchBounds)


class Planner(ABC):
    """A planner: :meth:`prepare` may reorder the task's stream plans before they are reported,
    :meth:`solve` binds them."""

    name: ClassVar[str]
    uses_model: ClassVar[bool] = False  # loads a cost model (to search with or to order by)

    def __init__(self, config: PlannerConfig) -> None:
        self.config = config

    def prepare(self, task: PlanningTask) -> PlanningTask:
        return task

    @abstractmethod
    def solve(self, task: PlanningTask, emitter: Emitter, budget: Budget) -> PlannerOutcome: ...


# --- models ------------------------------------------------------------------------------------


def load_predictor(config: PlannerConfig, loaded: LoadedDomain) -> Predictor:
    """The cost model of a run: ``config.model``, else the domain's shipped model, else per-stream
    priors (from the queries recorded in ``config.priors_db``, uniform without), with a warning.
    A planner spec's ``model=priors`` or ``model=FILE`` (``config.planner``) takes precedence."""
    chosen = get_planner(config.planner).model or config.model
    path = loaded.spec.model if chosen is None else chosen
    if path is not None and path != PRIORS:
        from planner.learning.predictor import ModelPredictor

        return ModelPredictor.load(Path(path), domain=loaded)
    from planner.learning.priors import Prior, PriorPredictor, priors_from_store

    priors: dict[str, Prior] = {}
    source = "no recorded queries: uniform priors"
    if config.priors_db is not None and Path(config.priors_db).is_file():
        priors, queries = priors_from_store(Path(config.priors_db), loaded.name)
        if queries:
            source = f"priors from {queries} queries recorded in {config.priors_db}"
    if chosen == PRIORS:
        log.info("model %r: the learned search runs on per-stream priors (%s)", PRIORS, source)
    else:
        log.warning(
            "no model for domain %r: the learned search runs on per-stream priors (%s); "
            "tamp train makes a model from recorded runs",
            loaded.name,
            source,
        )
    return PriorPredictor(priors)


def model_order(task: PlanningTask, predictor: Predictor) -> PlanningTask:
    """The task with every stream plan reordered by the model (:func:`ordered_by_model`)."""
    task.plans, task.states = ordered_by_model(task, task.plans, task.states, predictor)
    return task


def ordered_by_model(
    task: PlanningTask,
    plans: Sequence[AbstractPlan],
    states: Sequence[Sequence[frozenset[Atom]]],
    predictor: Predictor,
) -> tuple[tuple[AbstractPlan, ...], list[list[frozenset[Atom]]]]:
    """Every stream plan reordered by the model's predictions before anything is bound
    (:mod:`planner.search.order`), in one batch.

    Nothing is bound yet, so a row is fixed by its stream instance and the fluent facts of its
    state: the k plans share most of them (kitchen-4: 500 distinct of 1,826 rows, kitchen-8:
    819 of 3,600), and each distinct row is built and predicted once."""
    keys: dict[tuple[Any, frozenset[Atom]], int] = {}
    fluents = task.fluents
    spans: list[list[int]] = []
    rows: list[tuple[str, list[Any | None], dict[str, Any]]] = []
    for plan, plan_states in zip(plans, states, strict=True):
        span = []
        for i, inst in enumerate(plan.stream_plan):
            key = (inst, frozenset(a for a in plan_states[i] if a.predicate in fluents))
            if key not in keys:
                keys[key] = len(rows)
                rows += stream_rows(
                    plan,
                    plan_states,
                    task.initial,
                    encode=task.encode,
                    fluents=fluents,
                    static_context=task.static_context,
                    start=i,
                    only=(i,),
                )
            span.append(keys[key])
        spans.append(span)
    costs = predictor.predict_rows(rows) if rows else []
    out_plans: list[AbstractPlan] = []
    out_states: list[list[frozenset[Atom]]] = []
    unread: Mapping[str, Collection[str]] = task.loaded.spec.unread
    for plan, plan_states, span in zip(plans, states, spans, strict=True):
        scores = [seconds_per_failure(costs[j]) for j in span]
        ordered, ordered_states = order_streams(plan, plan_states, task.fluents, scores, unread)
        out_plans.append(ordered)
        out_states.append(ordered_states)
    return tuple(out_plans), out_states


# --- the tree searches -------------------------------------------------------------------------


class _TreeSearchPlanner(Planner):
    """A tree search over stream bindings; subclasses give the policy."""

    def __init__(self, config: PlannerConfig) -> None:
        super().__init__(config)
        self.predictor: Predictor | None = None
        self._seen_states: dict[frozenset[Atom], frozenset[Atom]] = {}

    @property
    def order(self) -> str:
        return "plan" if self.config.order == "auto" else self.config.order

    def prepare(self, task: PlanningTask) -> PlanningTask:
        if self.uses_model or self.order == "model":
            self.predictor = load_predictor(self.config, task.loaded)
        task.plans, task.states = self.prepare_plans(task, task.plans)
        return task

    def prepare_plans(
        self, task: PlanningTask, plans: Sequence[AbstractPlan]
    ) -> tuple[tuple[AbstractPlan, ...], list[list[frozenset[Atom]]]]:
        """Stream plans as the search reads them: each stream's symbolic state (one object
        per distinct state, across every batch), in the model's stream order where the
        planner orders by model."""
        states = [stream_contexts(p, task.loaded.domain, task.problem) for p in plans]
        states = shared_states(states, self._seen_states)
        if self.predictor is not None and self.order == "model":
            return ordered_by_model(task, plans, states, self.predictor)
        return tuple(plans), states

    def policy(self, task: PlanningTask, emitter: Emitter) -> Policy:
        return BaselinePolicy(BaselineConfig())

    @property
    def exhaustion(self) -> bool:
        """Whether an exhausted stream's node is left alone (LearnedConfig.exhaustion)."""
        return True

    def solve(self, task: PlanningTask, emitter: Emitter, budget: Budget) -> PlannerOutcome:
        feed = None
        if task.source is not None:
            feed = SourceFeed(task, self.prepare_plans, emitter, budget)
        fluent_streams = frozenset(s.name for s in task.loaded.streams.streams if s.fluents)
        search = TreeSearch(
            list(task.plans),
            task.states,
            task.initial,
            task.samplers,
            self.policy(task, emitter),
            emitter=emitter,
            encode=task.encode,
            describe=task.loaded.codec.label,
            progress=budget.progress or (lambda _m: None),
            should_stop=budget.should_stop,
            fluents=task.fluents,
            static_context=task.static_context,
            reuse=True,
            exhaustion=self.exhaustion,
            feed=feed,
            fluent_streams=fluent_streams,
            doubt_after=task.doubt_after,
        )
        outcome = search.run(deadline=budget.deadline, start=budget.start, bounds=budget.bounds)
        queries = [r for _, r in outcome.queries if not r.reused]
        reused = sum(1 for _, r in outcome.queries if r.reused)
        bound = None
        execution_s = oracle_s = None
        if outcome.solved and outcome.plan_index is not None:
            skeleton = search.skeletons[outcome.plan_index]
            values = {**task.initial, **outcome.values}
            cost = plan_cost(skeleton, task.loaded.domain, task.problem, values, task.runtime)
            bound = BoundPlan(skeleton, values, cost)
            branch = set(search.tree.path(outcome.node_id or 0))
            execution_s = sum(r.execution_s for n, r in outcome.queries if n in branch)
            oracle_s = skeleton_seconds(task) + outcome.oracle_query_s
        return PlannerOutcome(
            outcome.status,
            bound,
            execution_s,
            oracle_s,
            queries,
            len(search.tree),
            reused,
            outcome.search_cpu_s,
            outcome.ended_by,
        )


class BaselinePlanner(_TreeSearchPlanner):
    name = "baseline"


class LearnedPlanner(_TreeSearchPlanner):
    """The learned tree search with the parts of its :class:`LearnedConfig`."""

    name = "learned"
    uses_model = True

    def __init__(self, config: PlannerConfig, parts: LearnedConfig | None = None) -> None:
        super().__init__(config)
        parts = parts if parts is not None else LearnedConfig()
        if config.c_explore is not None:
            parts = replace(parts, c_explore=config.c_explore)
        self.parts = parts

    @property
    def order(self) -> str:
        if self.config.order != "auto":
            return self.config.order
        return "model" if self.parts.model_order else "plan"

    @property
    def exhaustion(self) -> bool:
        return self.parts.exhaustion

    def policy(self, task: PlanningTask, emitter: Emitter) -> Policy:
        assert self.predictor is not None  # prepare() loaded it

        events = NodeEvents(emitter, encode=task.loaded.encode)

        def report(node: Node, first: StreamCost, q: float) -> None:
            events.predicted(
                node.id, p_s=first.p_s, r_s=first.r_s, r_f=first.r_f, r_m=first.r_m, q=q
            )

        return LearnedPolicy(
            self.predictor,
            task.plans,
            task.states,
            task.initial,
            task.encode,
            task.fluents,
            self.parts,
            on_prediction=report,
            evidence_ignore=frozenset(task.loaded.spec.evidence_ignore),
            static_context=task.static_context,
            reads=task.samplers.state_reads(),
            trusted=trusted_streams(self.predictor),
        )


# --- skeletons on demand ---------------------------------------------------------------------


def plan_summaries(plans: Sequence[AbstractPlan]) -> list[dict[str, Any]]:
    """The abstract plans as an ``abstract_plans_found`` event carries them."""
    return [
        {
            "index": i,
            "cost": p.cost,
            "actions": [str(a) for a in p.actions],
            "streams": [str(s) for s in p.stream_plan],
        }
        for i, p in enumerate(plans)
    ]


def skeleton_seconds(task: PlanningTask) -> float:
    """Wall seconds the run's skeleton source worked (every batch), or the first plans'."""
    if task.source is not None:
        return task.source.seconds.get("total", task.topk_s)
    return task.topk_s


class SourceFeed:
    """The search's :class:`~planner.search.mcts.SkeletonFeed`: asks the task's skeleton source
    for more (each batch ``growth`` times the last), prepares what comes as the planner
    prepared the first plans, and reports it as a ``skeletons_added`` event."""

    def __init__(
        self,
        task: PlanningTask,
        prepare: Callable[
            [PlanningTask, Sequence[AbstractPlan]],
            tuple[tuple[AbstractPlan, ...], list[list[frozenset[Atom]]]],
        ],
        emitter: Emitter,
        budget: Budget,
    ) -> None:
        assert task.source is not None
        self.task = task
        self.source = task.source
        self.prepare = prepare
        self.emitter = emitter
        self.budget = budget
        self.count = len(task.plans)
        self.batch = float(task.batch)

    @property
    def requests(self) -> int:
        return self.source.requests

    @property
    def seconds(self) -> float:
        return self.source.seconds.get("total", 0.0)

    def exhausted_for(self, feedback: Feedback) -> bool:
        return self.source.exhausted_for(feedback)

    def more(
        self, reason: str, feedback: Feedback
    ) -> list[tuple[AbstractPlan, list[frozenset[Atom]]]]:
        self.batch *= self.task.growth
        n = max(1, min(round(self.batch), MAX_BATCH))
        remaining = self.budget.deadline - time.perf_counter()
        self.source.timeout_s = max(remaining, 1.0)
        if self.budget.progress is not None:
            self.budget.progress(f"asking for {n} more skeletons ({reason})")
        try:
            batch = self.source.request(n, feedback)
        except PlannerTimeoutError:
            log.info("the skeleton source ran out of the run's time")
            return []
        plans, states = self.prepare(self.task, batch.plans)
        summaries = plan_summaries(plans)
        for entry in summaries:
            entry["index"] += self.count
        self.emitter.emit(
            SkeletonsAdded,
            plans=summaries,
            seconds=batch.seconds,
            reason=reason,
            learned=feedback.lines(),
        )
        self.count += len(plans)
        log.info(
            "%d more skeletons (%s) in %.2f s, %d facts fed back",
            len(plans),
            reason,
            batch.seconds,
            len(feedback.false) + len(feedback.doubted),
        )
        return list(zip(plans, states, strict=True))


MAX_BATCH = 400  # skeletons in one request at most, however often the search asked


# --- the sequential binder ---------------------------------------------------------------------


class SequentialPlanner(Planner):
    """Binds each skeleton in turn (:func:`~planner.search.binding.bind_sequentially`). Its
    iterations (``Budget.bounds``) are the skeletons it tried; the budget is checked before
    every query, so a run stops within a skeleton too."""

    name = "sequential"

    def solve(self, task: PlanningTask, emitter: Emitter, budget: Budget) -> PlannerOutcome:
        plans = list(task.plans)
        recorder = _SequentialRecorder(emitter, task, budget.start, plans)
        queries: list[QueryResult] = []
        bound: BoundPlan | None = None
        tried = 0
        answered = 0  # queries so far, those of the skeleton being bound included
        ended_by: str | None = None
        fluent_streams = frozenset(s.name for s in task.loaded.streams.streams if s.fluents)
        records = InstanceRecords(doubt_after=task.doubt_after, fluent_streams=fluent_streams)
        feed = None
        if task.source is not None:
            feed = SourceFeed(task, lambda _t, p: (tuple(p), [[] for _ in p]), emitter, budget)

        def observe(
            restart: int,
            i: int,
            inst: StreamInstance,
            inputs: tuple[Any, ...],
            context: StreamContext,
            result: QueryResult,
        ) -> None:
            nonlocal answered
            answered += 1
            records.record(inst, result)
            recorder.queried(restart, i, inst, inputs, context, result)

        def spent() -> bool:
            return (
                time.perf_counter() > budget.deadline
                or budget.bounds.queries_reached(answered)
                or (budget.should_stop is not None and budget.should_stop())
            )

        index = 0
        while True:
            if time.perf_counter() > budget.deadline:
                break
            if budget.should_stop is not None and budget.should_stop():
                return PlannerOutcome("cancelled", None, None, None, queries, tried)
            ended_by = budget.bounds.reached(answered, tried)
            if ended_by is not None:
                break
            if index == len(plans):  # every skeleton tried: more, planned on what failed
                feedback = records.feedback()
                if feed is not None and not feed.exhausted_for(feedback):
                    plans += [p for p, _ in feed.more("all tried", feedback)]
                    continue
                if not plans:  # no skeleton at all: nothing to bind, whatever the budget
                    return PlannerOutcome("failed", None, None, None, queries, tried)
                index = 0  # nothing new: another round over the skeletons, with new samples
            plan = plans[index]
            tried += 1
            recorder.open_plan(index)
            bound, made = bind_sequentially(
                plan,
                task.loaded.domain,
                task.problem,
                task.samplers,
                attempts=self.config.attempts,
                restarts=self.config.restarts,
                observe=observe,
                stop=spent,
            )
            queries += made
            index += 1
            if bound is not None:
                break
        execution_s = oracle_s = None
        if bound is not None:
            execution_s = execution_seconds(
                task.samplers, bound.skeleton.actions, bound.skeleton.stream_plan, bound.values
            )
            oracle_s = recorder.solved(execution_s, skeleton_seconds(task))
        status: SearchStatus = "solved" if bound is not None else "timeout"
        return PlannerOutcome(
            status, bound, execution_s, oracle_s, queries, tried, ended_by=ended_by
        )


class _SequentialRecorder:
    """Reports a sequential run as a tree, as the tree searches do: a node per skeleton tried
    under the root, under it each query's node, a success the parent of the next query (a
    restart starts again from the skeleton's node). So the dashboard shows the run and the
    store keeps every query as a training row."""

    def __init__(
        self, emitter: Emitter, task: PlanningTask, start: float, plans: Sequence[AbstractPlan]
    ) -> None:
        self.plans = plans  # the run's list: it grows as more skeletons come
        self.fluents = task.fluents
        self.static_context = task.static_context
        self.encode = task.loaded.encode
        self.report = NodeEvents(emitter, encode=self.encode, describe=task.loaded.codec.label)
        self.start = start
        self.next_id = 1  # 0 is the root
        self.plan_index = -1
        self.plan_node = 0
        self.restart = -1
        self.parent = 0
        self.chain: list[tuple[int, float]] = []  # (node, wall seconds) of this restart's successes

    def _new_id(self) -> int:
        node = self.next_id
        self.next_id += 1
        return node

    def open_plan(self, index: int) -> None:
        self.plan_index, self.restart, self.chain = index, -1, []
        self.plan_node = self._new_id()
        self.report.plan_opened(self.plan_node, index, len(self.plans[index].stream_plan))

    def queried(
        self,
        restart: int,
        i: int,
        inst: StreamInstance,
        inputs: tuple[Any, ...],
        context: StreamContext,
        result: QueryResult,
    ) -> None:
        if restart != self.restart:
            self.restart, self.parent, self.chain = restart, self.plan_node, []
        node = self._new_id()
        self.report.queried(
            node_id=node,
            parent_id=self.parent,
            plan_index=self.plan_index,
            depth=i + 1,
            inst=inst,
            inputs=inputs,
            context=context_json(context, self.fluents, self.static_context, self.encode),
            result=result,
        )
        if result.success:
            self.parent = node
            self.chain.append((node, result.wall_s))

    def solved(self, execution_s: float, skeleton_s: float) -> float:
        """Reports the solution (the last success); returns its oracle seconds."""
        oracle = skeleton_s + sum(wall for _, wall in self.chain)
        self.report.solved(
            self.parent,
            self.plan_index,
            planning_s=time.perf_counter() - self.start,
            execution_s=execution_s,
            oracle_s=oracle,
        )
        return oracle


# --- the registry ------------------------------------------------------------------------------


@dataclass(frozen=True)
class PlannerSpec:
    """A planner by name, with a learned planner's parts; call it with a run's config."""

    name: str  # as given: "learned:dead_ends=off"
    kind: type[Planner]
    parts: LearnedConfig | None = None  # the learned planners' configuration
    skeletons: str | None = None  # "skeletons=kstar": the run's skeleton source, any planner
    # "model=priors" or "model=FILE": a learned planner on per-stream priors or on that model
    # file whatever model the run names, so one paired benchmark can hold the learned search
    # with two models, or with its model and without
    model: str | None = None

    @property
    def uses_model(self) -> bool:
        return self.kind.uses_model

    @property
    def default_order(self) -> str:
        if self.parts is not None:
            return "model" if self.parts.model_order else "plan"
        return "plan"

    def __call__(self, config: PlannerConfig) -> Planner:
        if self.kind is LearnedPlanner:
            return LearnedPlanner(config, self.parts)
        return self.kind(config)


# name -> (planner class, its parts): "paper" and "learned" are one class, two configurations.
_NAMED: dict[str, tuple[type[Planner], Callable[[], LearnedConfig] | None]] = {
    "baseline": (BaselinePlanner, None),
    "paper": (LearnedPlanner, LearnedConfig.paper),
    "learned": (LearnedPlanner, LearnedConfig),
    "sequential": (SequentialPlanner, None),
}
PLANNERS: tuple[str, ...] = tuple(_NAMED)  # the named planners
DEFAULT_PLANNER = "baseline"


def get_planner(spec: str) -> PlannerSpec:
    """The planner ``spec`` names: a named planner, or a learned one's variant
    ``NAME:FIELD=VALUE[:FIELD=VALUE...]`` (the fields of :class:`LearnedConfig`); an unknown
    name or field lists the known ones."""
    name, _, settings = spec.partition(":")
    if name not in _NAMED:
        raise ValueError(f"unknown planner {name!r} (known: {', '.join(PLANNERS)})")
    kind, make = _NAMED[name]
    skeletons: str | None = None
    model: str | None = None
    rest = []
    for item in (t for t in settings.split(":") if t):
        key, _, value = item.partition("=")
        if key == "model":
            if not value or make is None:
                raise ValueError(
                    f"planner setting {item!r}: only paper and learned take "
                    f"model={PRIORS} or model=FILE"
                )
            model = value
        elif key != "skeletons":
            rest.append(item)
        elif value not in SKELETON_SOURCES:
            known = ", ".join(SKELETON_SOURCES)
            raise ValueError(f"planner setting {item!r}: unknown skeleton source (known: {known})")
        else:
            skeletons = value
    if make is None:
        if rest:
            raise ValueError(
                f"planner {name!r} has no parts to set (only paper and learned do; every "
                "planner takes skeletons=SOURCE)"
            )
        return PlannerSpec(spec, kind, skeletons=skeletons)
    return PlannerSpec(spec, kind, make().with_settings(":".join(rest)), skeletons, model)

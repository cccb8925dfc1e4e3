"""A planning run from a scene: abstract plans, then binding, then the result and its figures.

Planners (:data:`PLANNERS`): ``baseline`` is eTAMP's progressive-widening tree search;
``sequential`` binds each skeleton's streams in order (the simplest thing that can work, kept as
a reference). Every run reports through an event sink (:mod:`planner.events`).
"""

from __future__ import annotations

import logging
import time
import uuid
from collections import Counter
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from planner.abstract import AbstractConfig, plan_abstract
from planner.abstract.instantiate import StreamInstance
from planner.abstract.skeleton import AbstractPlan
from planner.domains import LoadedDomain, problem_for_scene
from planner.events import (
    AbstractPlansFound,
    Emitter,
    EventSink,
    FanOutSink,
    ListSink,
    ModelPrediction,
    NodeAdded,
    RunCancelled,
    RunFailed,
    RunFinished,
    RunStarted,
    SolutionFound,
    StreamQueried,
)
from planner.pddl.structs import Atom, Problem
from planner.search.baseline import BaselineConfig
from planner.search.binding import BoundPlan, bind_sequentially, plan_cost, stream_contexts
from planner.search.learned import LearnedPolicy, Predictor, StreamCost, stream_rows
from planner.search.mcts import BaselinePolicy, Policy, TreeSearch, context_json
from planner.search.order import order_streams, seconds_per_failure
from planner.search.tree import Node
from planner.streams.adapters import StreamContext
from planner.streams.runtime import QueryResult

if TYPE_CHECKING:
    from planner.store import RunStore

log = logging.getLogger(__name__)

PLANNERS = ("baseline", "learned", "sequential")  # known planner names
DEFAULT_PLANNER = "baseline"
DEFAULT_MODEL = Path(__file__).resolve().parent / "learning" / "models" / "kitchen.pt"
ORDERS = ("auto", "plan", "model")  # how a tree search orders each stream plan's streams


@dataclass(frozen=True)
class RunConfig:
    scene: str
    seed: int = 0  # draws the scene's random parts and seeds the samplers
    planner: str = DEFAULT_PLANNER  # one of PLANNERS
    k: int = 50  # skeletons asked of the top-k planner (the paper's k)
    budget_s: float = 300.0  # wall-clock budget of the run, top-k included
    attempts: int = 10  # sequential only: queries of one stream before a restart
    restarts: int = 3  # sequential only: restarts of one skeleton before the next
    model: str | None = None  # learned only: model file (default: the shipped kitchen model)
    c_explore: float | None = None  # learned only: UCT exploration weight (default: LearnedConfig)
    # Stream order of the tree searches: "plan" as the actions need them, "model" cheap
    # doubtful tests first by the model (planner/search/order.py), "auto" model for learned.
    order: str = "auto"

    def __post_init__(self) -> None:
        if self.planner not in PLANNERS:
            raise ValueError(f"unknown planner {self.planner!r} (known: {', '.join(PLANNERS)})")
        if not 0 < self.budget_s <= 86_400:
            raise ValueError(f"budget must be between 0 and 86400 s, got {self.budget_s}")
        if self.c_explore is not None and not 0.0 <= self.c_explore <= 10.0:
            raise ValueError(f"c_explore must be between 0 and 10, got {self.c_explore}")
        if self.k < 1 or self.attempts < 1 or self.restarts < 1:
            raise ValueError("k, attempts and restarts must be positive")
        if self.order not in ORDERS:
            raise ValueError(f"unknown stream order {self.order!r} (known: {', '.join(ORDERS)})")
        if self.planner == "sequential" and self.order == "model":
            raise ValueError("order 'model' is for the tree searches (baseline, learned)")

    @property
    def stream_order(self) -> str:
        """The order the run uses: "plan" or "model" ("auto" resolved by the planner)."""
        if self.order != "auto":
            return self.order
        return "model" if self.planner == "learned" else "plan"

    @property
    def uses_model(self) -> bool:
        """Whether the run loads a cost model (to search with, or to order streams)."""
        return self.planner == "learned" or (
            self.planner != "sequential" and self.stream_order == "model"
        )


def preload_libraries(config: RunConfig) -> None:
    """Import what ``config``'s planner needs before its clock starts.

    Libraries are process set-up for every planner, not planning: the baseline's (pybullet,
    OMPL, the top-k planner) come with this module, before any run, and a server imports
    each once. The model's (torch) were imported lazily inside the run, so a fresh process
    charged a learned run about 3 s of torch import (4.5 s under load) as planning. Reading
    the model file stays inside the clock.
    """
    if config.uses_model:
        import planner.learning.predictor  # noqa: F401


@dataclass(frozen=True)
class RunResult:
    run_id: str
    config: RunConfig
    status: str  # solved, timeout, failed, cancelled
    bound: BoundPlan | None
    planning_s: float  # wall seconds from start (top-k included) to the bound plan or the end
    topk_s: float
    execution_s: float | None  # trajectory seconds of the bound plan
    oracle_s: float | None  # top-k + successful queries on the solution branch
    queries: list[QueryResult] = field(repr=False)
    nodes: int = 0  # tree nodes (baseline) or skeletons tried (sequential)
    reused: int = 0  # successes taken from an identical earlier query (not in ``queries``)

    @property
    def solved(self) -> bool:
        return self.bound is not None

    def query_counts(self) -> Counter[tuple[str, bool]]:
        return Counter((q.stream, q.success) for q in self.queries)


def jsonable(value: Any) -> Any:
    """A value as JSON data: kitchen values through their codec, numbers as they are."""
    if value is None or isinstance(value, str | int | float | bool):
        return value
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    try:
        from planner.domains.kitchen.plan_io import encode

        return encode(value)
    except TypeError:
        return repr(value)


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


def run(
    config: RunConfig,
    *,
    sink: EventSink | None = None,
    run_id: str | None = None,
    progress: Callable[[str], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> tuple[RunResult, LoadedDomain, Problem]:
    """Plan ``config.scene``; every step is reported to ``sink``."""
    run_id = run_id or uuid.uuid4().hex
    emitter = Emitter(run_id, sink if sink is not None else ListSink())
    start = time.perf_counter()
    emitter.emit(
        RunStarted,
        scene=config.scene,
        seed=config.seed,
        planner=config.planner,
        config=asdict(config),
    )
    try:
        result, loaded, problem = _run(config, run_id, emitter, start, progress, should_stop)
    except KeyboardInterrupt:
        emitter.emit(RunCancelled, reason="interrupted by the user")
        raise
    except Exception as exc:
        emitter.emit(RunFailed, error=f"{type(exc).__name__}: {exc}")
        raise
    if result.status == "cancelled":
        emitter.emit(RunCancelled, reason="cancelled by the user")
        return result, loaded, problem
    emitter.emit(
        RunFinished,
        status=result.status,
        planning_s=result.planning_s,
        execution_s=result.execution_s,
        oracle_s=result.oracle_s,
        queries=len(result.queries),
        message="solved" if result.solved else f"no plan ({result.status})",
    )
    return result, loaded, problem


def _run(
    config: RunConfig,
    run_id: str,
    emitter: Emitter,
    start: float,
    progress: Callable[[str], None] | None,
    should_stop: Callable[[], bool] | None,
) -> tuple[RunResult, LoadedDomain, Problem]:
    say = progress or (lambda _m: None)
    loaded, problem = problem_for_scene(config.scene, seed=config.seed)
    # Stream-file functions (action costs) are valued by the samplers' runtime while planning.
    runtime = loaded.runtime(problem, seed=config.seed) if loaded.streams.functions else None
    abstract = plan_abstract(
        loaded.domain,
        loaded.streams,
        problem,
        AbstractConfig(k=config.k, diversity_ignore=loaded.spec.diversity_ignore),
        progress=say,
        functions=runtime,
    )
    topk_s = abstract.seconds["topk"]
    plans: tuple[AbstractPlan, ...] = abstract.plans
    initial: dict[str, Any] = {o.name: o.name for o in problem.objects}
    initial.update(problem.values)
    fluents = loaded.domain.fluent_predicates
    states: list[list[frozenset[Atom]]] = []
    predictor: Predictor | None = None
    if config.planner != "sequential":
        states = [stream_contexts(p, loaded.domain, problem) for p in plans]
        if config.uses_model:
            predictor = _load_predictor(config, loaded)
        if predictor is not None and config.stream_order == "model":
            plans, states = _model_order(
                predictor,
                plans,
                states,
                initial,
                fluents,
                loaded.static_context(problem),
                loaded.spec.unread,
            )
    emitter.emit(AbstractPlansFound, plans=plan_summaries(plans), seconds=abstract.seconds["total"])
    if runtime is None:
        runtime = loaded.runtime(problem, seed=config.seed)
    deadline = start + config.budget_s
    if config.planner == "sequential":
        recorder = _SequentialRecorder(
            emitter, plans, fluents, loaded.static_context(problem), start, topk_s
        )
        return _sequential(config, run_id, plans, loaded, problem, runtime, start, topk_s, recorder)
    policy: Policy
    if predictor is not None and config.planner == "learned":
        policy = _learned_policy(
            config, predictor, loaded, problem, plans, states, initial, fluents, emitter
        )
    else:
        policy = BaselinePolicy(BaselineConfig())
    search = TreeSearch(
        plans,
        states,
        initial,
        runtime,
        policy,
        emitter=emitter,
        encode=jsonable,
        progress=say,
        should_stop=should_stop,
        fluents=fluents,
        static_context=loaded.static_context(problem),
        reuse=True,
    )
    outcome = search.run(deadline=deadline, start=start)
    queries = [r for _, r in outcome.queries if not r.reused]
    reused = sum(1 for _, r in outcome.queries if r.reused)
    planning_s = time.perf_counter() - start
    bound = None
    execution_s = oracle_s = None
    if outcome.solved and outcome.plan_index is not None:
        skeleton = plans[outcome.plan_index]
        values = {**initial, **outcome.values}
        bound = BoundPlan(
            skeleton, values, plan_cost(skeleton, loaded.domain, problem, values, runtime)
        )
        branch = set(search.tree.path(outcome.node_id or 0))
        execution_s = sum(r.execution_s for n, r in outcome.queries if n in branch)
        oracle_s = topk_s + outcome.oracle_query_s
    result = RunResult(
        run_id,
        config,
        outcome.status,
        bound,
        planning_s,
        topk_s,
        execution_s,
        oracle_s,
        queries,
        len(search.tree),
        reused,
    )
    return result, loaded, problem


def _load_predictor(config: RunConfig, loaded: LoadedDomain) -> Predictor:
    from planner.learning.predictor import ModelPredictor

    return ModelPredictor.load(
        Path(config.model) if config.model else DEFAULT_MODEL, domain=loaded.spec.name
    )


def _model_order(
    predictor: Predictor,
    plans: tuple[AbstractPlan, ...],
    states: list[list[frozenset[Atom]]],
    initial: dict[str, Any],
    fluents: frozenset[str],
    static_context: Mapping[str, Any],
    unread: Mapping[str, Collection[str]],
) -> tuple[tuple[AbstractPlan, ...], list[list[frozenset[Atom]]]]:
    """Every stream plan reordered by the model's predictions before anything is bound
    (:mod:`planner.search.order`), in one batch."""
    spans: list[tuple[int, int]] = []
    rows: list[tuple[str, list[Any | None], dict[str, Any]]] = []
    for plan, plan_states in zip(plans, states, strict=True):
        mine = stream_rows(
            plan,
            plan_states,
            initial,
            encode=jsonable,
            fluents=fluents,
            static_context=static_context,
        )
        spans.append((len(rows), len(rows) + len(mine)))
        rows += mine
    costs = predictor.predict_rows(rows) if rows else []
    out_plans: list[AbstractPlan] = []
    out_states: list[list[frozenset[Atom]]] = []
    for plan, plan_states, (lo, hi) in zip(plans, states, spans, strict=True):
        scores = [seconds_per_failure(c) for c in costs[lo:hi]]
        ordered, ordered_states = order_streams(plan, plan_states, fluents, scores, unread)
        out_plans.append(ordered)
        out_states.append(ordered_states)
    return tuple(out_plans), out_states


def _learned_policy(
    config: RunConfig,
    predictor: Predictor,
    loaded: LoadedDomain,
    problem: Problem,
    plans: tuple[AbstractPlan, ...],
    states: list[list[frozenset[Atom]]],
    initial: dict[str, Any],
    fluents: frozenset[str],
    emitter: Emitter,
) -> Policy:
    def report(node: Node, first: StreamCost, q: float) -> None:
        emitter.emit(
            ModelPrediction,
            node_id=node.id,
            p_s=first.p_s,
            r_s=first.r_s,
            r_f=first.r_f,
            r_m=first.r_m,
            q=q,
        )

    from planner.search.learned import LearnedConfig

    config_ = LearnedConfig() if config.c_explore is None else LearnedConfig(config.c_explore)
    return LearnedPolicy(
        predictor,
        plans,
        states,
        initial,
        jsonable,
        fluents,
        config_,
        on_prediction=report,
        evidence_ignore=frozenset(loaded.spec.evidence_ignore),
        static_context=loaded.static_context(problem),
    )


def _sequential(
    config: RunConfig,
    run_id: str,
    plans: tuple[Any, ...],
    loaded: LoadedDomain,
    problem: Problem,
    runtime: Any,
    start: float,
    topk_s: float,
    recorder: _SequentialRecorder,
) -> tuple[RunResult, LoadedDomain, Problem]:
    queries: list[QueryResult] = []
    bound: BoundPlan | None = None
    tried = 0
    for index, plan in enumerate(plans):
        if time.perf_counter() - start > config.budget_s:
            break
        tried += 1
        recorder.open_plan(index)
        bound, made = bind_sequentially(
            plan,
            loaded.domain,
            problem,
            runtime,
            attempts=config.attempts,
            restarts=config.restarts,
            observe=recorder.queried,
        )
        queries += made
        if bound is not None:
            break
    execution_s = oracle_s = None
    if bound is not None:
        execution_s = sum(float(getattr(v, "seconds", 0.0)) for v in _trajectories(bound))
        oracle_s = recorder.solved(execution_s)
    status = "solved" if bound is not None else "timeout"
    planning_s = time.perf_counter() - start
    result = RunResult(
        run_id, config, status, bound, planning_s, topk_s, execution_s, oracle_s, queries, tried
    )
    return result, loaded, problem


class _SequentialRecorder:
    """Reports a sequential run as a tree, as the tree searches do: a node per skeleton tried
    under the root, under it each query's node, a success the parent of the next query (a
    restart starts again from the skeleton's node). So the dashboard shows the run and the
    store keeps every query as a training row."""

    def __init__(
        self,
        emitter: Emitter,
        plans: Sequence[AbstractPlan],
        fluents: frozenset[str],
        static_context: Mapping[str, Any],
        start: float,
        topk_s: float,
    ) -> None:
        self.emitter = emitter
        self.plans = plans
        self.fluents = fluents
        self.static_context = static_context
        self.start = start
        self.topk_s = topk_s
        self.next_id = 1  # 0 is the root
        self.plan_index = -1
        self.plan_node = 0
        self.restart = -1
        self.parent = 0
        self.chain: list[tuple[int, float]] = []  # (node, wall seconds) of this restart's successes

    def _add(self, parent: int, depth: int, stream: str | None, success: bool, **kw: Any) -> int:
        node = self.next_id
        self.next_id += 1
        self.emitter.emit(
            NodeAdded,
            node_id=node,
            parent_id=parent,
            plan_index=self.plan_index,
            depth=depth,
            stream=stream,
            success=success,
            **kw,
        )
        return node

    def open_plan(self, index: int) -> None:
        self.plan_index, self.restart, self.chain = index, -1, []
        plan = self.plans[index]
        label = f"plan {index} ({len(plan.stream_plan)} streams)"
        self.plan_node = self._add(0, 0, None, True, outputs=[], label=label)

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
        node = self.next_id
        self.emitter.emit(
            StreamQueried,
            node_id=node,
            stream=inst.stream,
            input_names=list(inst.inputs),
            inputs=[jsonable(v) for v in inputs],
            success=result.success,
            wall_s=result.wall_s,
            cpu_s=result.cpu_s,
            execution_s=result.execution_s,
            error=result.error,
            context=context_json(context, self.fluents, self.static_context, jsonable),
            reason=result.reason,
        )
        outputs = list(result.outputs) if result.outputs is not None else []
        label = f"{inst}" + ("" if result.success else " (failed)")
        self._add(
            self.parent,
            i + 1,
            inst.stream,
            result.success,
            outputs=[jsonable(v) for v in outputs],
            label=label,
            output_names=list(inst.outputs) if result.success else [],
        )
        if result.success:
            self.parent = node
            self.chain.append((node, result.wall_s))

    def solved(self, execution_s: float) -> float:
        """Reports the solution (the last success); returns its oracle seconds."""
        oracle = self.topk_s + sum(wall for _, wall in self.chain)
        self.emitter.emit(
            SolutionFound,
            node_id=self.parent,
            plan_index=self.plan_index,
            planning_s=time.perf_counter() - self.start,
            execution_s=execution_s,
            oracle_s=oracle,
        )
        return oracle


def _trajectories(bound: BoundPlan) -> list[Any]:
    used = {a for act in bound.skeleton.actions for a in act.args}
    return [v for k, v in bound.values.items() if k in used and hasattr(v, "segments")]


@dataclass(frozen=True)
class RecordedRun:
    """A run and what was stored about it: its final status, validation and plan file."""

    result: RunResult
    loaded: LoadedDomain
    problem: Problem
    status: str  # the stored status: the search's, or failed when the plan does not validate
    valid: bool | None  # None when there is no plan
    message: str
    plan: dict[str, Any] | None  # the bound plan file (kitchen) when solved
    record_s: float  # seconds the planner spent handing events to the store


def check_plan(
    result: RunResult, loaded: LoadedDomain, problem: Problem
) -> tuple[bool | None, str, dict[str, Any] | None]:
    """Validate a solved run's plan in simulation (kitchen) and build its plan file."""
    if result.bound is None:
        return None, f"no plan ({result.status})", None
    if loaded.spec.name != "kitchen":
        return True, "solved (validation in simulation is for the kitchen)", None
    from planner.domains.kitchen.plan_io import plan_to_dict
    from planner.domains.kitchen.validate import validate_plan

    report = validate_plan(result.bound.skeleton.actions, result.bound.values, problem)
    plan = plan_to_dict(
        scene=result.config.scene,
        seed=result.config.seed,
        actions=result.bound.skeleton.actions,
        values=result.bound.values,
    )
    return report.ok, report.message, plan


def record_run(
    config: RunConfig,
    store: RunStore,
    run_id: str,
    *,
    sinks: tuple[EventSink, ...] = (),
    progress: Callable[[str], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> RecordedRun:
    """Run ``config`` as the stored run ``run_id``: every event goes to the store (and to
    ``sinks``), the plan is validated, and the run is finished in the store however it ends.
    An exception or Ctrl-C finishes the run as failed / cancelled, keeps its events, and
    propagates."""
    from planner.store import StoreSink

    sink = _Tee(StoreSink(store, run_id), FanOutSink(*sinks))
    try:
        result, loaded, problem = run(
            config, sink=sink, run_id=run_id, progress=progress, should_stop=should_stop
        )
    except KeyboardInterrupt:
        sink.close()
        store.finish_run(run_id, "cancelled", message="interrupted by the user")
        raise
    except Exception as exc:
        sink.close()
        store.finish_run(run_id, "failed", message=f"{type(exc).__name__}: {exc}")
        raise
    sink.close()
    valid, message, plan = check_plan(result, loaded, problem)
    if result.status == "cancelled":
        message = "cancelled by the user"
    status = result.status if valid is not False else "failed"
    store.finish_run(
        run_id,
        status,
        planning_s=result.planning_s,
        execution_s=result.execution_s,
        oracle_s=result.oracle_s,
        queries=len(result.queries),
        message=message,
        plan=plan,
    )
    return RecordedRun(result, loaded, problem, status, valid, message, plan, sink.primary_s)


class _Tee:
    """The store first (its errors propagate: a run that cannot be recorded stops), then the
    listeners (isolated by a :class:`FanOutSink`)."""

    def __init__(self, primary: EventSink, listeners: FanOutSink) -> None:
        self.primary = primary
        self.listeners = listeners
        self.primary_s = 0.0  # seconds spent in the primary sink

    def emit(self, event: Any) -> None:
        t = time.perf_counter()
        self.primary.emit(event)
        self.primary_s += time.perf_counter() - t
        if self.listeners.sinks:
            self.listeners.emit(event)

    def close(self) -> None:
        t = time.perf_counter()
        try:
            self.primary.close()
        finally:
            self.primary_s += time.perf_counter() - t
            self.listeners.close()

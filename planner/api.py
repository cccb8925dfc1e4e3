"""The public Python API: plan a scene file or a :class:`~planner.pddl.Problem` with any planner.

    from planner.api import plan

    result = plan("examples/tabletop2d/scenes/tabletop-3.json", planner="baseline", seed=0)
    print(result.status, result.planning_s, result.valid, result.message)
    for action in result.actions:
        print(action)

:func:`plan` takes a scene (a name, a path, or a ``Problem`` with its domain), a planner name
(:data:`planner.planners.PLANNERS`) and its options, and returns a :class:`PlanResult`: status,
the bound plan, its figures and its validation. Every step of the run is reported to ``sink``
(any :class:`~planner.events.EventSink`: a list, the run store, a websocket). :func:`solve` is the
same on a :class:`RunConfig`; ``planner/runs.py`` (recorded runs), the CLI and the dashboard's
workers use it.
"""

from __future__ import annotations

import logging
import time
import uuid
from collections import Counter
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from planner.abstract import (
    DEFAULT_SOURCE,
    SKELETON_SOURCES,
    AbstractConfig,
    PlannerTimeoutError,
)
from planner.abstract.skeleton import GroundAction
from planner.domains import LoadedDomain, load_domain, problem_for_scene
from planner.domains.spec import PlanCheck
from planner.events import (
    AbstractPlansFound,
    Emitter,
    EventSink,
    ListSink,
    RunCancelled,
    RunFailed,
    RunFinished,
    RunStarted,
    SkeletonProgress,
)
from planner.pddl.structs import Problem
from planner.planners import (
    DEFAULT_PLANNER,
    ORDERS,
    PLANNERS,
    Budget,
    PlanningTask,
    get_planner,
    plan_summaries,
    skeleton_seconds,
)
from planner.plans import execution_note, plan_to_dict, validate
from planner.search.binding import BoundPlan
from planner.search.bounds import SearchBounds, check_bound, time_reached
from planner.status import SearchStatus
from planner.streams.runtime import QueryResult, StreamRuntime

log = logging.getLogger(__name__)

# Why a run that its caller stopped (``should_stop``) ended, unless ``stop_reason`` says otherwise.
CANCELLED_BY_USER = "cancelled by the user"

__all__ = [
    "CANCELLED_BY_USER",
    "DEFAULT_PLANNER",
    "PLANNERS",
    "PlanResult",
    "RunConfig",
    "RunResult",
    "plan",
    "solve",
]


MAX_BUDGET_S = 86_400.0  # the longest budget of a run (a day), wherever a run is asked for


@dataclass(frozen=True)
class RunConfig:
    """One run: what to plan, with which planner, how long. Every run is reproducible from its
    config (and the model file, when it names one).

    How long: ``budget_s`` seconds, and optionally ``max_queries`` stream queries a sampler
    answered and ``max_iterations`` search iterations (:mod:`planner.search.bounds`); the run
    stops at whichever it reaches first. The counts do not depend on the machine: the same run
    bounded by them stops at the same point on a laptop, on a cluster or on a busy machine."""

    scene: str  # scene name, path to a scene file, or the problem's name (plan(problem))
    seed: int = 0  # draws the scene's random parts and seeds the samplers
    planner: str = DEFAULT_PLANNER  # a named planner or a variant (planner.planners.get_planner)
    k: int = 50  # skeletons asked of the top-k planner (the paper's k)
    budget_s: float = 300.0  # wall-clock budget of the run, top-k included
    attempts: int = 10  # sequential only: queries of one stream before a restart
    restarts: int = 3  # sequential only: restarts of one skeleton before the next
    model: str | None = None  # model file (default: the domain's own; none: priors; "priors")
    c_explore: float | None = None  # learned only: UCT exploration weight (default: LearnedConfig)
    # Stream order of the tree searches: "plan" as the actions need them, "model" cheap
    # doubtful tests first by the model (planner/search/order.py), "auto" model for learned.
    order: str = "auto"
    domain: str | None = None  # the domain's name or folder; None: the scene file's "domain"
    # Learned with no model for the domain: per-stream priors from this store's queries.
    priors_db: str | None = None
    # Where skeletons come from (planner.abstract.source): "adaptive" (greedy searches, more
    # on demand, replanning on what the search proved) or a top-k planner ("kstar", "symk":
    # the k cheapest at once). A planner spec's "skeletons=..." overrides it.
    skeletons: str = DEFAULT_SOURCE
    # Bounds that do not depend on the machine (planner.search.bounds); None: unbounded. The
    # skeleton source's time counts against budget_s only.
    max_queries: int | None = None  # stream queries a sampler answered (no reused answer)
    max_iterations: int | None = None  # search iterations (sequential: skeletons tried)

    def __post_init__(self) -> None:
        spec = get_planner(self.planner)  # ValueError names what is unknown
        if not 0 < self.budget_s <= MAX_BUDGET_S:
            raise ValueError(
                f"budget must be between 0 and {MAX_BUDGET_S:.0f} s, got {self.budget_s}"
            )
        check_bound("max_queries", self.max_queries)
        check_bound("max_iterations", self.max_iterations)
        if self.c_explore is not None and not 0.0 <= self.c_explore <= 10.0:
            raise ValueError(f"c_explore must be between 0 and 10, got {self.c_explore}")
        if self.k < 1 or self.attempts < 1 or self.restarts < 1:
            raise ValueError("k, attempts and restarts must be positive")
        if self.order not in ORDERS:
            raise ValueError(f"unknown stream order {self.order!r} (known: {', '.join(ORDERS)})")
        if spec.name.startswith("sequential") and self.order == "model":
            raise ValueError("order 'model' is for the tree searches (baseline, paper, learned)")
        if self.skeletons not in SKELETON_SOURCES:
            known = ", ".join(SKELETON_SOURCES)
            raise ValueError(f"unknown skeleton source {self.skeletons!r} (known: {known})")

    @property
    def skeleton_source(self) -> str:
        """The skeleton source the run uses: its planner spec's, else its own field."""
        return get_planner(self.planner).skeletons or self.skeletons

    @property
    def stream_order(self) -> str:
        """The order the run uses: "plan" or "model" ("auto" resolved by the planner)."""
        if self.order != "auto":
            return self.order
        return get_planner(self.planner).default_order

    @property
    def bounds(self) -> SearchBounds:
        """The run's bounds besides its seconds."""
        return SearchBounds(self.max_queries, self.max_iterations)

    @property
    def uses_model(self) -> bool:
        """Whether the run loads a cost model (to search with, or to order streams)."""
        spec = get_planner(self.planner)
        return spec.uses_model or (spec.kind.name != "sequential" and self.stream_order == "model")


@dataclass(frozen=True)
class RunResult:
    run_id: str
    config: RunConfig
    status: SearchStatus
    bound: BoundPlan | None
    planning_s: float  # wall seconds from start (top-k included) to the bound plan or the end
    topk_s: float  # wall seconds of the skeleton source (every batch): the planning not searched
    execution_s: float | None  # trajectory seconds of the bound plan
    oracle_s: float | None  # top-k + successful queries on the solution branch
    queries: list[QueryResult] = field(repr=False)
    nodes: int = 0  # tree nodes (tree searches) or skeletons tried (sequential)
    reused: int = 0  # successes taken from an identical earlier query (not in ``queries``)
    # CPU seconds of the search's own thread outside the stream queries (tree searches only)
    search_cpu_s: float | None = None
    # Which bound ended a run that timed out: "time budget of 300 s reached", "query budget of
    # 500 reached", "iteration budget of 200 reached"; None for any other status.
    ended_by: str | None = None

    @property
    def solved(self) -> bool:
        return self.bound is not None

    def query_counts(self) -> Counter[tuple[str, bool]]:
        return Counter((q.stream, q.success) for q in self.queries)


@dataclass(frozen=True)
class PlanResult:
    """A run's result with its domain and problem, its plan's validation and its plan file."""

    result: RunResult
    loaded: LoadedDomain
    problem: Problem
    runtime: StreamRuntime | None = field(default=None, repr=False)
    valid: bool | None = None  # None: no plan, or not validated yet (check())
    message: str = ""  # the validation's message, or why there is no plan

    @property
    def status(self) -> SearchStatus:
        """The search's status, or failed when its plan does not validate."""
        return "failed" if self.valid is False else self.result.status

    @property
    def solved(self) -> bool:
        return self.result.solved

    @property
    def planning_s(self) -> float:
        return self.result.planning_s

    @property
    def execution_s(self) -> float | None:
        return self.result.execution_s

    @property
    def actions(self) -> tuple[GroundAction, ...]:
        """The bound plan's actions (empty when not solved)."""
        return () if self.result.bound is None else self.result.bound.skeleton.actions

    @property
    def values(self) -> dict[str, Any]:
        """The values of the plan's objects (empty when not solved)."""
        return {} if self.result.bound is None else dict(self.result.bound.values)

    def check(self) -> tuple[bool | None, str]:
        """``(valid, message)``: the domain's validator, or a fact-by-fact replay with the test
        streams asked again (:func:`planner.plans.validate`); ``None`` without a plan."""
        bound = self.result.bound
        if bound is None:
            return None, f"no plan ({self.result.ended_by or self.result.status})"
        if self.valid is not None:
            return self.valid, self.message
        report: PlanCheck = validate(
            self.loaded,
            self.problem,
            bound.skeleton.actions,
            bound.values,
            streams=bound.skeleton.stream_plan,
            runtime=self.runtime,
        )
        note = ""
        if report.ok and self.loaded.spec.validate is not None:  # the replay adds its own
            note = execution_note(self.loaded, self.execution_s)
        return report.ok, report.message + note

    def plan_file(self) -> dict[str, Any] | None:
        """The bound plan as a plan file's dict (:mod:`planner.plans`); None when not solved."""
        bound = self.result.bound
        if bound is None:
            return None
        return plan_to_dict(
            loaded=self.loaded,
            scene=self.result.config.scene,
            seed=self.result.config.seed,
            plan=bound.skeleton,
            values=bound.values,
            domain_path=self.loaded.reference,
        )


def plan(
    scene: str | Path | Problem,
    planner: str = DEFAULT_PLANNER,
    *,
    domain: str | Path | LoadedDomain | None = None,
    seed: int = 0,
    budget_s: float = 300.0,
    model: str | Path | None = None,
    sink: EventSink | None = None,
    progress: Callable[[str], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
    **options: Any,
) -> PlanResult:
    """Plan ``scene`` (a scene name or path, or a ``Problem`` of ``domain``) with ``planner``.

    ``options`` are the other :class:`RunConfig` fields (``k``, ``order``, ``c_explore``,
    ``attempts``, ``restarts``, ``priors_db``, ``max_queries``, ``max_iterations``); an unknown
    one raises ``TypeError``. Events go to ``sink`` (a fresh :class:`~planner.events.ListSink`
    when None).
    """
    names = {f.name for f in fields(RunConfig)} - {"scene", "seed", "planner", "budget_s"}
    unknown = sorted(set(options) - names)
    if unknown:
        raise TypeError(
            f"unknown option(s) {', '.join(unknown)} (known: {', '.join(sorted(names))})"
        )
    loaded: LoadedDomain | None = None
    if isinstance(domain, LoadedDomain):
        loaded = domain
    elif domain is not None:
        loaded = load_domain(domain)
    problem: Problem | None = None
    if isinstance(scene, Problem):
        if loaded is None:
            raise ValueError("plan(problem) needs domain= (the problem's domain)")
        problem = scene
        scene_ref = scene.name
    else:
        scene_ref = str(scene)
    domain_ref = None
    if loaded is not None and loaded.reference is not None:
        domain_ref = loaded.reference
    elif isinstance(domain, str):
        domain_ref = domain
    config = RunConfig(
        scene=scene_ref,
        seed=seed,
        planner=planner,
        budget_s=budget_s,
        model=None if model is None else str(model),
        domain=domain_ref,
        **options,
    )
    return solve(
        config,
        problem=problem,
        loaded=loaded,
        sink=sink,
        progress=progress,
        should_stop=should_stop,
    )


def solve(
    config: RunConfig,
    *,
    problem: Problem | None = None,
    loaded: LoadedDomain | None = None,
    sink: EventSink | None = None,
    run_id: str | None = None,
    progress: Callable[[str], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
    stop_reason: Callable[[], str] | None = None,
) -> PlanResult:
    """Run ``config`` (on ``problem`` when given, else on its scene); every step is reported to
    ``sink``. A run ends with ``run_finished`` (its plan validated and its plan file in it),
    ``run_cancelled`` or ``run_failed`` (then the exception propagates).

    ``should_stop`` is asked between search steps; a run it stopped is cancelled, for the
    reason ``stop_reason`` gives when asked then (default :data:`CANCELLED_BY_USER`): the
    ``run_cancelled`` event's and the result's ``message``."""
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
        out = _solve(config, problem, loaded, run_id, emitter, start, progress, should_stop)
    except KeyboardInterrupt:
        emitter.emit(RunCancelled, reason="interrupted by the user")
        raise
    except Exception as exc:
        emitter.emit(RunFailed, error=f"{type(exc).__name__}: {exc}")
        raise
    result = out.result
    if result.status == "cancelled":
        reason = stop_reason() if stop_reason is not None else CANCELLED_BY_USER
        emitter.emit(RunCancelled, reason=reason)
        return replace(out, message=reason)
    try:  # after the planning clock stopped: the plan is validated before the run ends
        valid, message = out.check()
        plan = out.plan_file()
    except Exception as exc:
        emitter.emit(RunFailed, error=f"validating the plan: {type(exc).__name__}: {exc}")
        raise
    out = replace(out, valid=valid, message=message)
    emitter.emit(
        RunFinished,
        status=out.status,
        planning_s=result.planning_s,
        execution_s=result.execution_s,
        oracle_s=result.oracle_s,
        queries=len(result.queries),
        message=message,
        valid=valid,
        plan=plan,
        search_cpu_s=result.search_cpu_s,
        skeleton_s=result.topk_s,
    )
    return out


def _solve(
    config: RunConfig,
    problem: Problem | None,
    loaded: LoadedDomain | None,
    run_id: str,
    emitter: Emitter,
    start: float,
    progress: Callable[[str], None] | None,
    should_stop: Callable[[], bool] | None,
) -> PlanResult:
    if problem is None:
        loaded, problem = problem_for_scene(
            config.scene, seed=config.seed, domain=loaded if loaded is not None else config.domain
        )
    elif loaded is None:
        raise ValueError("a problem needs its domain")
    # Stream-file functions (action costs) are valued by the samplers' runtime while planning;
    # without them the runtime is made once the plans are found.
    runtime = loaded.runtime(problem, seed=config.seed) if loaded.streams.functions else None
    abstract = AbstractConfig(
        k=config.k,
        backend=config.skeleton_source,
        diversity_ignore=loaded.spec.diversity_ignore,
        timeout_s=config.budget_s,
    )
    say = progress or (lambda _m: None)

    def word(phase: str, message: str, seconds: float) -> None:
        emitter.emit(SkeletonProgress, phase=phase, message=message, seconds=seconds)
        say(message)

    source = abstract.source(
        loaded.domain, loaded.streams, problem, functions=runtime, progress=word
    )
    first_n = min(config.k, abstract.first_batch) if abstract.adaptive else config.k
    try:
        first = source.request(first_n)
    except PlannerTimeoutError:  # the budget ran out before the first skeleton
        elapsed = time.perf_counter() - start
        timeout = RunResult(
            run_id,
            config,
            "timeout",
            None,
            elapsed,
            elapsed,
            None,
            None,
            [],
            ended_by=time_reached(config.budget_s) + " before the first skeleton",
        )
        return PlanResult(timeout, loaded, problem)
    initial: dict[str, Any] = {o.name: o.name for o in problem.objects}
    initial.update(problem.values)
    planner = get_planner(config.planner)(config)
    task = PlanningTask(
        loaded,
        problem,
        first.plans,
        initial,
        topk_s=first.seconds,
        static_context=loaded.static_context(problem),
        source=source,
        batch=len(first.plans) or abstract.first_batch,
        growth=abstract.batch_growth,
    )
    task = planner.prepare(task)
    # The samplers' world is made before the plans are reported, so what follows the report is
    # the search alone (its own seconds and its queries'; docs/BENCHMARKS.md splits them).
    task.runtime = runtime if runtime is not None else loaded.runtime(problem, seed=config.seed)
    emitter.emit(AbstractPlansFound, plans=plan_summaries(task.plans), seconds=first.seconds)
    budget = Budget(start, start + config.budget_s, progress, should_stop, config.bounds)
    outcome = planner.solve(task, emitter, budget)
    ended_by = outcome.ended_by
    if outcome.status == "timeout" and ended_by is None:
        ended_by = time_reached(config.budget_s)
    result = RunResult(
        run_id,
        config,
        outcome.status,
        outcome.bound,
        time.perf_counter() - start,
        skeleton_seconds(task),
        outcome.execution_s,
        outcome.oracle_s,
        outcome.queries,
        outcome.nodes,
        outcome.reused,
        outcome.search_cpu_s,
        ended_by,
    )
    return PlanResult(result, loaded, problem, task.runtime)

"""Skeletons on demand: a source the tree search asks for more, told what the search proved.

The abstract planner of the paper computes k cheapest skeletons once, with a top-k planner that
proves optimality. On long problems that proof is the cost (K* on kitchen-12: 52 s for k = 1 as
for k = 50, where a greedy search finds an equally cheap plan in 0.03 s), and the k plans never
change with what the search learns. A :class:`SkeletonSource` instead hands out skeletons in
batches, as the search asks for them, and each request carries :class:`Feedback`: facts the
search proved false (a test that failed on real inputs, a stream that gave nothing for real
inputs and said so) are left out of the optimistic task, and so are facts it doubts (every query
of their stream failed, many times), unless nothing new reaches the goal without them: a block
standing where another must go gets moved. This is how PDDLStream's algorithms replan on
failures (they disable what failed, and enable it again when planning without it fails).

Sources by name (:data:`SKELETON_SOURCES`):

- ``adaptive`` (the default): Fast Downward's greedy search with the FF heuristic
  (``lazy_greedy([ff()], preferred=[ff()])``), one search per skeleton, the first
  deterministic and the others with randomised successor orders (each seed a different
  ordering of the goals); searches after the first are bounded by the cheapest plan found so
  far, so no skeleton costs more than the first. The task is grounded here when it is STRIPS
  (:mod:`planner.abstract.ground`), else by Fast Downward's translator, once per feedback.
- ``kstar`` and ``symk``: the top-k planners as before (:func:`planner.abstract.plan_abstract`
  semantics): the first request gives the k cheapest unique skeletons; a later one plans
  again on the task the feedback changed, asking for as many more plans as wanted.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

from planner.abstract.compile import (
    FunctionEvaluator,
    PlannerTask,
    compile_planner_task,
    function_values,
    is_strips_task,
)
from planner.abstract.downward import SasTask, improve_plan, search_plan, translate
from planner.abstract.errors import UnreachableGoalError
from planner.abstract.ground import ground_strips
from planner.abstract.instantiate import OptimisticInstantiation, instantiate
from planner.abstract.skeleton import (
    AbstractPlan,
    GroundAction,
    canonical_key,
    recover_stream_plan,
)
from planner.abstract.topk import TOPK_PLANNERS, get_topk_planner
from planner.pddl.structs import Atom, Domain, Problem, StreamSet, problem_predicates

log = logging.getLogger(__name__)

ADAPTIVE = "adaptive"
SKELETON_SOURCES: tuple[str, ...] = (ADAPTIVE, *sorted(TOPK_PLANNERS))
DEFAULT_SOURCE = ADAPTIVE

# phase ("instantiate", "ground", "translate", "search", "recover"), a line, seconds so far
Progress = Callable[[str, str, float], None]


@dataclass(frozen=True)
class Feedback:
    """What the search has proved about the optimistic task, in its own atoms (optimistic
    objects as the instantiation named them)."""

    false: frozenset[Atom] = frozenset()  # proved false: left out of the task
    doubted: frozenset[Atom] = frozenset()  # every query failed, often: left out if possible

    def __post_init__(self) -> None:
        if self.false & self.doubted:
            raise ValueError("a fact is either false or doubted, not both")

    def lines(self) -> list[str]:
        """One line per fact, for events and logs."""
        return [f"{a} false" for a in sorted(self.false, key=str)] + [
            f"{a} doubted" for a in sorted(self.doubted, key=str)
        ]

    def __bool__(self) -> bool:
        return bool(self.false or self.doubted)


@dataclass(frozen=True)
class SkeletonBatch:
    """Skeletons new to the search, and what they took."""

    plans: tuple[AbstractPlan, ...]
    seconds: float  # wall seconds of this request
    exhausted: bool  # the source found nothing new for this feedback (it may for other)
    steps: Mapping[str, float] = field(default_factory=dict)  # seconds per phase
    searches: int = 0  # planner calls made (adaptive: one per search)


class SkeletonSource:
    """Skeletons of one problem, on demand (see the module). Not thread-safe: one search asks."""

    def __init__(
        self,
        domain: Domain,
        streams: StreamSet,
        problem: Problem,
        *,
        backend: str = DEFAULT_SOURCE,
        max_levels: int = 4,
        max_instances: int = 50_000,
        timeout_s: float = 300.0,
        cost_scale: float = 100.0,
        workers: int = 2,
        improve_s: float = 0.5,
        diversity: Callable[[list[AbstractPlan], int], list[AbstractPlan]] | None = None,
        topk_oversample: float = 4.0,
        topk_growth: float = 1.5,
        functions: FunctionEvaluator | None = None,
        progress: Progress | None = None,
    ) -> None:
        if backend not in SKELETON_SOURCES:
            known = ", ".join(SKELETON_SOURCES)
            raise ValueError(f"unknown skeleton source {backend!r} (known: {known})")
        self.domain = domain.declaring(problem_predicates(domain, problem))
        self.streams = streams
        self.problem = problem
        self.backend = backend
        self.max_levels = max_levels
        self.max_instances = max_instances
        self.timeout_s = timeout_s
        self.cost_scale = cost_scale
        self.workers = max(1, workers)
        self.improve_s = improve_s
        self.diversity = diversity
        self.topk_oversample = topk_oversample
        self.topk_growth = topk_growth
        self.functions = functions
        self.progress = progress
        self.inst: OptimisticInstantiation | None = None
        self.served: dict[tuple[str, ...], int] = {}  # skeleton key -> index given
        self.seconds: dict[str, float] = {}  # per phase, over the source's life
        self.requests = 0
        self.best_cost = math.inf  # the cheapest skeleton served so far, in the domain's units
        self._seed = 0  # the next search's random seed (adaptive)
        self._tasks: dict[frozenset[Atom], _Task] = {}  # by the facts left out
        self._topk_asked = 0  # plans asked of the top-k planner in its last call
        self._stale: set[tuple[frozenset[Atom], frozenset[Atom]]] = set()  # nothing new here

    # --- the public steps ----------------------------------------------------------------------

    @property
    def instances(self) -> int:
        return 0 if self.inst is None else len(self.inst.instances)

    def request(self, n: int, feedback: Feedback | None = None) -> SkeletonBatch:
        """Up to ``n`` skeletons the search has not had, planned on the task ``feedback``
        changed. Raises :class:`UnreachableGoalError` when the very first request finds the
        goal unreachable even if every stream succeeds; later, an unreachable goal (the
        feedback ruled out every way) gives an empty, exhausted batch."""
        if n < 1:
            raise ValueError(f"n must be at least 1, got {n}")
        feedback = feedback or Feedback()
        start = time.perf_counter()
        steps: dict[str, float] = {}
        first = self.requests == 0
        self.requests += 1
        if self.inst is None:
            self._say("instantiate", "instantiating streams optimistically", start)
            t0 = time.perf_counter()
            self.inst = instantiate(
                self.streams,
                self.problem,
                max_levels=self.max_levels,
                max_instances=self.max_instances,
            )
            steps["instantiate"] = time.perf_counter() - t0
        key = (feedback.false, feedback.doubted)
        # First without the doubted facts (as PDDLStream disables what failed); if that finds
        # nothing new, with them again.
        tries = [feedback.false | feedback.doubted, feedback.false]
        plans: list[AbstractPlan] = []
        searches, exhausted = 0, True
        for exclude in tries[0 if feedback.doubted else 1 :]:
            try:
                if self.backend == ADAPTIVE:
                    found, calls, exhausted = self._adaptive(n, exclude, steps, start)
                else:
                    found, calls, exhausted = self._topk(n, exclude, steps, start)
            except UnreachableGoalError:
                if first and not feedback:
                    raise
                found, calls, exhausted = [], 0, True
            plans += found
            searches += calls
            if plans:
                break
        if exhausted and not plans:
            self._stale.add(key)
        for name, seconds in steps.items():
            self.seconds[name] = self.seconds.get(name, 0.0) + seconds
        for plan in plans:
            self.served[canonical_key(plan.actions, plan.stream_plan)] = len(self.served)
        total = time.perf_counter() - start
        self.seconds["total"] = self.seconds.get("total", 0.0) + total
        log.info(
            "%s: %d new skeletons in %.2f s (%d searches%s)",
            self.backend,
            len(plans),
            total,
            searches,
            ", nothing more" if exhausted else "",
        )
        return SkeletonBatch(tuple(plans), total, exhausted, steps, searches)

    def exhausted_for(self, feedback: Feedback | None) -> bool:
        """Whether a request with this feedback is known to bring nothing new."""
        feedback = feedback or Feedback()
        return (feedback.false, feedback.doubted) in self._stale

    # --- the task for a feedback -------------------------------------------------------------

    def _say(self, phase: str, message: str, start: float) -> None:
        if self.progress is not None:
            self.progress(phase, message, time.perf_counter() - start)

    def _task(self, exclude: frozenset[Atom], steps: dict[str, float], start: float) -> _Task:
        """The planner's task with every optimistic fact but ``exclude`` (made once)."""
        found = self._tasks.get(exclude)
        if found is not None:
            return found
        assert self.inst is not None
        inst = self.inst
        t0 = time.perf_counter()
        if self.backend == ADAPTIVE and is_strips_task(self.domain, self.problem):
            self._say("ground", f"grounding {len(inst.instances):,} stream instances", start)
            values = function_values(self.domain, self.problem, inst, self.streams, self.functions)
            scale = _scale([*values.values(), *(a.cost or 0 for a in self.domain.actions)])
            scale = self.cost_scale if scale != 1.0 else 1.0
            ground, names = ground_strips(
                self.domain,
                self.problem,
                extra_objects=inst.objects,
                extra_init=inst.facts - exclude,
                function_values={(t.name, t.args): v for t, v in values.items()},
                cost_scale=scale,
            )
            if ground.unreachable_goal:
                missing = ", ".join(str(lit) for lit in ground.unreachable_goal)
                raise UnreachableGoalError(
                    f"the goal is unreachable even if every stream succeeds ({missing} is "
                    "never reached)"
                )
            made = time.perf_counter() - t0
            sas = SasTask(ground.to_sas(), "direct", made, len(ground.operators))
            task = _Task(sas, None, scale, names)
            steps["ground"] = steps.get("ground", 0.0) + time.perf_counter() - t0
        else:
            planner = compile_planner_task(
                self.domain,
                self.problem,
                inst,
                streams=self.streams,
                functions=self.functions,
                cost_scale=self.cost_scale,
                exclude=exclude,
            )
            if self.backend == ADAPTIVE:
                self._say("translate", "Fast Downward's translator grounds the task", start)
                sas = translate(planner.domain_pddl, planner.problem_pddl, timeout_s=self.timeout_s)
                steps["translate"] = steps.get("translate", 0.0) + time.perf_counter() - t0
            else:
                sas = SasTask("", "translator", 0.0, 0)
            task = _Task(sas, planner, planner.cost_scale, {})
        self._tasks[exclude] = task
        return task

    def _plan_from(
        self,
        task: _Task,
        raw: Sequence[str],
        cost: float,
        cache: dict[GroundAction, tuple[Atom, ...]],
    ) -> AbstractPlan | None:
        """The skeleton of one planner plan, or None when it is one already served."""
        assert self.inst is not None
        actions: list[GroundAction] = []
        preconditions = []
        for text in raw:
            parsed = GroundAction.parse(text)
            if task.planner is not None:
                original, pre = task.planner.original(parsed)
                actions.append(original)
                preconditions.append(pre)
            else:
                name, args = task.names.get(text.strip("() "), (None, ()))
                actions.append(parsed if name is None else GroundAction(name, args))
                preconditions.append(None)
        variants = task.planner is not None and bool(task.planner.variants)
        stream_plan, first_use = recover_stream_plan(
            actions,
            self.domain,
            self.problem,
            self.inst,
            cache=cache,
            streams=self.streams,
            preconditions=preconditions if variants else None,
        )
        key = canonical_key(actions, stream_plan)
        if key in self.served:
            return None
        real = cost / task.scale if task.scale != 1.0 else cost
        return AbstractPlan(tuple(actions), stream_plan, real, first_use)

    # --- adaptive: greedy searches -------------------------------------------------------------

    def _adaptive(
        self, n: int, exclude: frozenset[Atom], steps: dict[str, float], start: float
    ) -> tuple[list[AbstractPlan], int, bool]:
        task = self._task(exclude, steps, start)
        found: list[AbstractPlan] = []
        keys: set[tuple[str, ...]] = set()
        cache: dict[GroundAction, tuple[Atom, ...]] = {}
        searches = 0
        # Searches in a row that found nothing new before the bound is relaxed (and, at the
        # last, before the source says it has no more): randomised orders repeat once most
        # have been seen.
        patience = max(4, math.ceil(n / 4))
        misses = 0
        t_search = t_recover = 0.0
        while len(found) < n:
            if misses >= patience:
                if task.level + 1 >= len(BOUND_SLACK):
                    break
                task.level += 1  # costlier plans may now come: detours around what failed
                misses = 0
            want = min(self.workers, n - len(found), patience - misses)
            seeds = list(range(self._seed, self._seed + want))
            self._seed += want
            self._say(
                "search",
                f"greedy search for skeleton {len(self.served) + len(found) + 1}",
                start,
            )
            t0 = time.perf_counter()
            results = self._searches(task, seeds)
            batch_s = time.perf_counter() - t0
            t_search += batch_s
            searches += len(seeds)
            t1 = time.perf_counter()
            for result in results:
                if result is None:
                    misses += 1
                    continue
                actions, cost = result
                task.best = min(task.best, cost)
                plan = self._plan_from(task, actions, cost, cache)
                key = None if plan is None else canonical_key(plan.actions, plan.stream_plan)
                if plan is None or key in keys:
                    misses += 1
                    continue
                keys.add(key)  # type: ignore[arg-type]
                misses = 0
                found.append(plan)
                self.best_cost = min(self.best_cost, plan.cost)
            t_recover += time.perf_counter() - t1
            if found and not task.improved and self.improve_s > 0:
                # The anytime search gets IMPROVE_RATIO times what the greedy searches took,
                # within [IMPROVE_MIN_S, improve_s]: small tasks get an optimal plan, large
                # ones are not held up for long.
                budget = min(self.improve_s, max(IMPROVE_MIN_S, IMPROVE_RATIO * batch_s))
                t0 = time.perf_counter()
                found = self._improve(task, found, cache, start, budget)
                steps["improve"] = steps.get("improve", 0.0) + time.perf_counter() - t0
        steps["search"] = steps.get("search", 0.0) + t_search
        steps["recover"] = steps.get("recover", 0.0) + t_recover
        return found, searches, len(found) < n

    def _improve(
        self,
        task: _Task,
        found: list[AbstractPlan],
        cache: dict[GroundAction, tuple[Atom, ...]],
        start: float,
        seconds: float,
    ) -> list[AbstractPlan]:
        """The task's first plan made cheaper by Fast Downward's anytime search, within
        ``seconds`` (:func:`planner.abstract.downward.improve_plan`); plans of this batch
        costlier than the improved one are left for later (the bound now excludes them)."""
        task.improved = True
        self._say("improve", f"improving the first skeleton's cost ({task.best:g})", start)
        better = improve_plan(task.sas, task.best, seconds=seconds)
        if better is None:
            return found
        plan = self._plan_from(task, better.actions, better.cost, cache)
        task.best = min(task.best, better.cost)
        if plan is None:
            return found
        self.best_cost = min(self.best_cost, plan.cost)
        log.info("anytime search: a skeleton of cost %g (was %g)", plan.cost, found[0].cost)
        return [plan, *(p for p in found if p.cost <= plan.cost)]

    def _searches(
        self, task: _Task, seeds: list[int]
    ) -> list[tuple[tuple[str, ...], float] | None]:
        """One greedy search per seed, up to ``workers`` at a time; results in seed order. No
        plan costlier than the task's bound (:data:`BOUND_SLACK`)."""
        slack = BOUND_SLACK[task.level]
        bound = task.best * slack if math.isfinite(task.best) and slack is not None else None

        def one(seed: int) -> tuple[tuple[str, ...], float] | None:
            found = search_plan(
                task.sas, _greedy(seed, bound), timeout_s=self.timeout_s, bounded=bound is not None
            )
            return None if found is None else (found.actions, found.cost)

        if len(seeds) == 1:
            return [one(seeds[0])]
        with ThreadPoolExecutor(max_workers=len(seeds)) as pool:
            return list(pool.map(one, seeds))

    # --- top-k planners ----------------------------------------------------------------------

    def _topk(
        self, n: int, exclude: frozenset[Atom], steps: dict[str, float], start: float
    ) -> tuple[list[AbstractPlan], int, bool]:
        """The top-k planner on the task ``feedback`` gives: unique skeletons not served yet,
        asking for more plans (x ``topk_growth``) while fewer than ``n`` are new and the planner
        has more."""
        task = self._task(exclude, steps, start)
        assert task.planner is not None
        backend = get_topk_planner(self.backend)
        request = max(math.ceil(n * self.topk_oversample), self._topk_asked + n)
        calls = 0
        unique: dict[tuple[str, ...], AbstractPlan] = {}
        previous = -1
        stale = 0
        t_topk = t_recover = 0.0
        exhausted = False
        while True:
            calls += 1
            self._say("search", f"{self.backend}: asking for {request} plans (call {calls})", start)
            result = backend.plan(
                task.planner.domain_pddl,
                task.planner.problem_pddl,
                request,
                timeout_s=self.timeout_s,
            )
            t_topk += result.seconds
            self._topk_asked = request
            t1 = time.perf_counter()
            cache: dict[GroundAction, tuple[Atom, ...]] = {}
            for planned, cost in zip(result.plans, result.costs, strict=True):
                texts = [" ".join((a.name, *a.args)) for a in planned]
                plan = self._plan_from(task, texts, cost, cache)
                if plan is None:
                    continue
                key = canonical_key(plan.actions, plan.stream_plan)
                if key not in unique:
                    unique[key] = plan
                    self.best_cost = min(self.best_cost, plan.cost)
            t_recover += time.perf_counter() - t1
            message = (
                f"{self.backend}: {len(result.plans)} plans in {result.seconds:.1f} s, "
                f"{len(unique)} new unique skeletons"
            )
            log.info(message)
            self._say("search", message, start)
            if len(unique) >= n:
                break
            if result.exhausted:
                exhausted = True
                break
            stale = stale + 1 if len(unique) <= previous else 0
            if stale >= 2:  # two larger requests in a row found nothing new
                exhausted = True
                break
            previous = len(unique)
            request = math.ceil(request * self.topk_growth)
        steps["topk"] = steps.get("topk", 0.0) + t_topk
        steps["recover"] = steps.get("recover", 0.0) + t_recover
        plans = list(unique.values())
        if self.diversity is not None and len(plans) > n:
            plans = self.diversity(plans, n)
        return plans[:n], calls, exhausted and len(plans) < n


@dataclass
class _Task:
    """The planner's task for one feedback: SAS for the greedy searches, PDDL for the top-k
    planners, the cost scale and (direct grounding) what each operator name grounds."""

    sas: SasTask
    planner: PlannerTask | None
    scale: float
    names: Mapping[str, tuple[str, tuple[str, ...]]]
    best: float = math.inf  # the cheapest plan found on it, in the planner's units
    level: int = 0  # index into BOUND_SLACK: how much costlier than ``best`` a plan may be
    improved: bool = False  # its first plan went through the anytime search


IMPROVE_RATIO = 3.0  # the anytime search's seconds per second of the first greedy searches
IMPROVE_MIN_S = 0.1  # ... but at least this (enough for A* to prove a small task's optimum)

# The adaptive source's searches are bounded by the cheapest plan found on the task times the
# first factor; when that many searches in a row bring nothing new, by the next (None: no bound).
# Cheapest first, as a top-k planner gives them, but without proving optimality.
BOUND_SLACK: tuple[float | None, ...] = (1.0, 1.5, None)


def _greedy(seed: int, bound: float | None) -> str:
    """Fast Downward's greedy search with FF and preferred operators; seed 0 deterministic,
    others with randomised successor orders; ``bound``: no plan costlier than it."""
    options = ["[ff()]", "preferred=[ff()]"]
    if seed > 0:
        options += [
            "randomize_successors=true",
            "preferred_successors_first=false",
            f"random_seed={seed}",
        ]
    if bound is not None:
        options.append(f"bound={int(bound) + 1}")  # exclusive: cost <= bound passes
    return f"lazy_greedy({', '.join(options)})"


def _scale(numbers: Iterable[float]) -> float:
    """1 when every cost is an integer, else anything else (the caller's cost scale)."""
    return 1.0 if all(float(x).is_integer() for x in numbers) else 0.0


__all__ = [
    "ADAPTIVE",
    "DEFAULT_SOURCE",
    "SKELETON_SOURCES",
    "Feedback",
    "SkeletonBatch",
    "SkeletonSource",
]

"""Abstract planning: k unique skeletons (action plan + stream plan) from a skeleton source.

The road eTAMP takes, which scales: plan over the domain's actions only, with every optimistic
stream fact in the initial state, then recover each plan's stream plan. Plans that differ only in
which optimistic object is which are one skeleton. :func:`plan_abstract` asks a
:class:`~planner.abstract.source.SkeletonSource` for k of them at once (``tamp abstract``); a run
keeps its source and asks it for more as the search goes (:mod:`planner.planners`).
"""

from __future__ import annotations

import logging
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field

from planner.abstract.compile import DEFAULT_COST_SCALE, FunctionEvaluator, compile_planner_task
from planner.abstract.instantiate import OptimisticInstantiation
from planner.abstract.skeleton import AbstractPlan, GroundAction, action_multiset
from planner.abstract.source import ADAPTIVE, DEFAULT_SOURCE, SKELETON_SOURCES, SkeletonSource
from planner.pddl.structs import Domain, Problem, StreamSet

log = logging.getLogger(__name__)

MAX_K = 10_000  # more skeletons than any search can use; larger asks are a mistake


@dataclass(frozen=True)
class AbstractConfig:
    """How many skeletons to find and how."""

    k: int = 50  # unique skeletons wanted (the paper uses k = 50 on the kitchen)
    # The skeleton source by name: "adaptive" (greedy searches, on demand, replanning on what
    # the search proved), or a top-k planner: "kstar", "symk" (planner.abstract.source).
    backend: str = DEFAULT_SOURCE
    max_levels: int = 4  # generations of optimistic stream instances
    max_instances: int = 50_000  # bound on optimistic stream instances
    growth: float = 1.5  # request growth per round while duplicates leave < k (eTAMP's 1.5)
    oversample: float = 4.0  # first request = oversample * k plans: duplicates are common, and
    # diversity chooses among more; one large call is cheaper than growing rounds
    diversity_ignore: tuple[str, ...] = ()  # actions left out when comparing plans for diversity
    timeout_s: float = 300.0  # wall-clock limit of one top-k call
    max_requested: int = 4 * MAX_K  # never ask the top-k planner for more plans than this
    # Non-integer costs reach the planners multiplied by this and rounded (they take integers).
    cost_scale: float = DEFAULT_COST_SCALE
    workers: int = 2  # adaptive: greedy searches run side by side (one process each)
    # adaptive, in a run: skeletons in the first batch; each later batch is batch_growth times
    # the last (the search asks for more when the ones it has look worse than a new one).
    first_batch: int = 10
    batch_growth: float = 2.0
    # adaptive: wall seconds Fast Downward's anytime search may spend making a task's first
    # skeleton cheaper (0: the greedy plan as found); the skeletons after it cost no more.
    improve_s: float = 0.5

    def __post_init__(self) -> None:
        if not 1 <= self.k <= MAX_K:
            raise ValueError(f"k must be between 1 and {MAX_K}, got {self.k}")
        if self.backend not in SKELETON_SOURCES:
            known = ", ".join(SKELETON_SOURCES)
            raise ValueError(f"unknown skeleton source {self.backend!r} (known: {known})")
        if self.max_levels < 1 or self.max_instances < 1:
            raise ValueError("max_levels and max_instances must be positive")
        if self.growth <= 1.0:
            raise ValueError(f"growth must exceed 1, got {self.growth}")
        if self.oversample < 1.0:
            raise ValueError(f"oversample must be at least 1, got {self.oversample}")
        if self.timeout_s <= 0:
            raise ValueError(f"timeout_s must be positive, got {self.timeout_s}")
        if self.cost_scale <= 0:
            raise ValueError(f"cost_scale must be positive, got {self.cost_scale}")
        if self.workers < 1 or self.first_batch < 1:
            raise ValueError("workers and first_batch must be positive")
        if self.batch_growth < 1.0:
            raise ValueError(f"batch_growth must be at least 1, got {self.batch_growth}")

    @property
    def adaptive(self) -> bool:
        return self.backend == ADAPTIVE

    def source(
        self,
        domain: Domain,
        streams: StreamSet,
        problem: Problem,
        *,
        functions: FunctionEvaluator | None = None,
        progress: Callable[[str, str, float], None] | None = None,
    ) -> SkeletonSource:
        """The skeleton source this config describes, for one problem."""
        ignore = self.diversity_ignore
        return SkeletonSource(
            domain,
            streams,
            problem,
            backend=self.backend,
            max_levels=self.max_levels,
            max_instances=self.max_instances,
            timeout_s=self.timeout_s,
            cost_scale=self.cost_scale,
            workers=self.workers,
            improve_s=self.improve_s,
            diversity=lambda plans, k: _select_diverse(plans, k, ignore),
            topk_oversample=self.oversample,
            topk_growth=self.growth,
            functions=functions,
            progress=progress,
        )


@dataclass(frozen=True)
class AbstractResult:
    """The chosen skeletons and what it took to find them."""

    plans: tuple[AbstractPlan, ...]
    backend: str
    rounds: int  # planner calls made (top-k calls, or greedy searches)
    requested: int  # skeletons asked for
    returned: int  # skeletons returned
    unique: int  # unique skeletons among them
    exhausted: bool  # the source had no more
    instances: int  # optimistic stream instances
    # instantiate, ground (direct or translator), topk (the planner's searches), recover, total
    seconds: dict[str, float] = field(default_factory=dict)
    diversity_ignore: tuple[str, ...] = ()  # as in the config
    stop_reason: str = "enough"  # enough | exhausted (the source found no more)

    @property
    def distinct_multisets(self) -> int:
        """Distinct multisets of actions among the chosen plans (reorderings count once)."""
        return len({action_multiset(p.actions) for p in self.plans})

    @property
    def distinct_choices(self) -> int:
        """Distinct multisets once ``diversity_ignore`` actions (e.g. moves) are left out."""
        return len({action_multiset(p.actions, self.diversity_ignore) for p in self.plans})


def compile_task(
    domain: Domain,
    problem: Problem,
    inst: OptimisticInstantiation,
    *,
    streams: StreamSet | None = None,
    functions: FunctionEvaluator | None = None,
) -> tuple[str, str]:
    """The classical task: the domain's actions, optimistic facts added to the initial state
    (see :mod:`planner.abstract.compile`)."""
    task = compile_planner_task(domain, problem, inst, streams=streams, functions=functions)
    return task.domain_pddl, task.problem_pddl


def _select_diverse(
    plans: list[AbstractPlan], k: int, ignore: tuple[str, ...]
) -> list[AbstractPlan]:
    """Up to k plans, round-robin over groups with the same action multiset (cheapest first)."""
    if len(plans) <= k:
        return plans
    groups: dict[frozenset[tuple[GroundAction, int]], list[int]] = defaultdict(list)
    for i, plan in enumerate(plans):
        groups[action_multiset(plan.actions, ignore)].append(i)
    chosen: list[int] = []
    depth = 0
    while len(chosen) < k:
        for members in groups.values():
            if depth < len(members) and len(chosen) < k:
                chosen.append(members[depth])
        depth += 1
    return [plans[i] for i in sorted(chosen)]


def plan_abstract(
    domain: Domain,
    streams: StreamSet,
    problem: Problem,
    config: AbstractConfig,
    *,
    progress: Callable[[str], None] | None = None,
    functions: FunctionEvaluator | None = None,
) -> AbstractResult:
    """Find ``config.k`` unique skeletons (fewer if the source runs out).

    ``progress`` receives a line whenever the source starts a phase (for a terminal).
    ``functions`` gives the stream file's numeric functions their values where every input
    is a real object, and their lower bounds elsewhere (without it every stream function is
    worth 0 to the planner: the default lower bound). Plan costs are in the domain's units.
    """
    say = progress or (lambda _msg: None)
    source = config.source(
        domain, streams, problem, functions=functions, progress=lambda _p, m, _s: say(m)
    )
    batch = source.request(config.k)
    steps = dict(batch.steps)
    seconds = {
        "instantiate": steps.pop("instantiate", 0.0),
        "ground": steps.pop("ground", 0.0) + steps.pop("translate", 0.0),
        "topk": steps.pop("topk", 0.0) + steps.pop("search", 0.0),
        "recover": steps.pop("recover", 0.0),
        "total": batch.seconds,
    }
    stop = "enough" if len(batch.plans) >= config.k else "exhausted"
    return AbstractResult(
        plans=batch.plans,
        backend=config.backend,
        rounds=batch.searches,
        requested=config.k,
        returned=len(batch.plans),
        unique=len(batch.plans),
        exhausted=batch.exhausted,
        instances=source.instances,
        seconds=seconds,
        diversity_ignore=config.diversity_ignore,
        stop_reason=stop,
    )

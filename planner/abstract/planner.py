"""Abstract planning: k unique skeletons (action plan + stream plan) from a top-k planner.

The road eTAMP takes, which scales: plan over the domain's actions only, with every optimistic
stream fact in the initial state, then recover each plan's stream plan. Plans that differ only in
which optimistic object is which are one skeleton; while fewer than k skeletons are unique the
request grows by ``growth`` (eTAMP: 1.5x) until the planner has no more.
"""

from __future__ import annotations

import logging
import math
import time
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field

from planner.abstract.compile import DEFAULT_COST_SCALE, FunctionEvaluator, compile_planner_task
from planner.abstract.instantiate import OptimisticInstantiation, instantiate
from planner.abstract.skeleton import (
    AbstractPlan,
    GroundAction,
    action_multiset,
    canonical_key,
    recover_stream_plan,
)
from planner.abstract.topk import DEFAULT_TOPK, TOPK_PLANNERS, get_topk_planner
from planner.pddl.structs import Atom, Domain, Problem, StreamSet, problem_predicates

log = logging.getLogger(__name__)

MAX_K = 10_000  # more skeletons than any search can use; larger asks are a mistake


@dataclass(frozen=True)
class AbstractConfig:
    """How many skeletons to find and how."""

    k: int = 50  # unique skeletons wanted (the paper uses k = 50 on the kitchen)
    backend: str = DEFAULT_TOPK  # top-k planner by name: "kstar" or "symk"
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

    def __post_init__(self) -> None:
        if not 1 <= self.k <= MAX_K:
            raise ValueError(f"k must be between 1 and {MAX_K}, got {self.k}")
        if self.backend not in TOPK_PLANNERS:
            known = ", ".join(sorted(TOPK_PLANNERS))
            raise ValueError(f"unknown top-k planner {self.backend!r} (known: {known})")
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


@dataclass(frozen=True)
class AbstractResult:
    """The chosen skeletons and what it took to find them."""

    plans: tuple[AbstractPlan, ...]
    backend: str
    rounds: int  # top-k calls made
    requested: int  # plans asked for in the last call
    returned: int  # plans the last call returned
    unique: int  # unique skeletons among them
    exhausted: bool  # the planner had no more plans
    instances: int  # optimistic stream instances
    seconds: dict[str, float] = field(default_factory=dict)  # instantiate, topk, recover, total
    diversity_ignore: tuple[str, ...] = ()  # as in the config
    stop_reason: str = "enough"  # enough | exhausted | limit | no-new-skeletons

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
    """Find ``config.k`` unique skeletons (fewer if the planner runs out).

    ``progress`` receives one line before each top-k call and after it (for a terminal).
    ``functions`` gives the stream file's numeric functions their values where every input
    is a real object, and their lower bounds elsewhere (without it every stream function is
    worth 0 to the planner: the default lower bound). Plan costs are in the domain's units.
    """
    say = progress or (lambda _msg: None)
    t0 = time.perf_counter()
    domain = domain.declaring(problem_predicates(domain, problem))  # the problem's own facts
    inst = instantiate(
        streams, problem, max_levels=config.max_levels, max_instances=config.max_instances
    )
    t_inst = time.perf_counter() - t0
    task = compile_planner_task(
        domain,
        problem,
        inst,
        streams=streams,
        functions=functions,
        cost_scale=config.cost_scale,
    )
    domain_pddl, problem_pddl = task.domain_pddl, task.problem_pddl
    backend = get_topk_planner(config.backend)
    request = min(math.ceil(config.k * config.oversample), config.max_requested)
    rounds, t_topk, t_recover = 0, 0.0, 0.0
    previous_unique = 0
    stale = 0
    stop_reason = "enough"
    while True:
        rounds += 1
        say(f"{config.backend}: asking for {request} plans (call {rounds})")
        result = backend.plan(domain_pddl, problem_pddl, request, timeout_s=config.timeout_s)
        t_topk += result.seconds
        t1 = time.perf_counter()
        unique: dict[object, AbstractPlan] = {}
        cache: dict[GroundAction, tuple[Atom, ...]] = {}
        for planned, cost in zip(result.plans, result.costs, strict=True):
            originals = [task.original(a) for a in planned]
            actions = tuple(a for a, _ in originals)
            stream_plan, first_use = recover_stream_plan(
                actions,
                domain,
                problem,
                inst,
                cache=cache,
                streams=streams,
                preconditions=[f for _, f in originals] if task.variants else None,
            )
            key = canonical_key(actions, stream_plan)
            if key not in unique:
                real = cost / task.cost_scale if task.cost_scale != 1.0 else cost
                unique[key] = AbstractPlan(actions, stream_plan, real, first_use)
        t_recover += time.perf_counter() - t1
        message = (
            f"{config.backend}: {len(result.plans)} plans in {result.seconds:.1f} s, "
            f"{len(unique)} unique skeletons"
        )
        log.info(message)
        say(message)
        if len(unique) >= config.k:
            stop_reason = "enough"
            break
        if result.exhausted or request >= config.max_requested:
            stop_reason = "exhausted" if result.exhausted else "limit"
            break
        stale = stale + 1 if rounds > 1 and len(unique) <= previous_unique else 0
        if stale >= 2:  # two larger requests in a row found nothing new
            stop_reason = "no-new-skeletons"
            log.info("no new skeletons in %d more plans; stopping at %d", request, len(unique))
            break  # a domain with cycles has endless plans but no new stream plans
        previous_unique = len(unique)
        request = min(math.ceil(request * config.growth), config.max_requested)
    chosen = _select_diverse(list(unique.values()), config.k, config.diversity_ignore)
    total = time.perf_counter() - t0
    return AbstractResult(
        plans=tuple(chosen),
        backend=config.backend,
        rounds=rounds,
        requested=request,
        returned=len(result.plans),
        unique=len(unique),
        exhausted=result.exhausted,
        instances=len(inst.instances),
        seconds={
            "instantiate": t_inst,
            "topk": t_topk,
            "recover": t_recover,
            "total": total,
        },
        diversity_ignore=config.diversity_ignore,
        stop_reason=stop_reason,
    )

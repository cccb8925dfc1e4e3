"""A planning run from a scene: abstract plans, then binding, then the result and its figures.

The only planner here is ``sequential`` (bind each skeleton's streams in order, skeletons in
cost order); the tree searches of issues 4 and 5 join the :data:`PLANNERS` registry.
"""

from __future__ import annotations

import logging
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

from planner.abstract import AbstractConfig, plan_abstract
from planner.domains import LoadedDomain, problem_for_scene
from planner.pddl.structs import Problem
from planner.search.binding import BoundPlan, bind_sequentially
from planner.streams.runtime import QueryResult

log = logging.getLogger(__name__)

PLANNERS = ("sequential",)  # known planner names


@dataclass(frozen=True)
class RunConfig:
    scene: str
    seed: int = 0  # draws the scene's random parts and seeds the samplers
    planner: str = "sequential"  # one of PLANNERS
    k: int = 10  # skeletons asked of the top-k planner
    attempts: int = 10  # queries of one stream before the binder restarts
    restarts: int = 3  # restarts of one skeleton before the next is tried
    budget_s: float = 300.0  # wall-clock budget of the run, top-k included

    def __post_init__(self) -> None:
        if self.planner not in PLANNERS:
            raise ValueError(f"unknown planner {self.planner!r} (known: {', '.join(PLANNERS)})")
        if self.budget_s <= 0 or self.k < 1 or self.attempts < 1 or self.restarts < 1:
            raise ValueError("budget, k, attempts and restarts must be positive")


@dataclass(frozen=True)
class RunResult:
    config: RunConfig
    bound: BoundPlan | None
    planning_s: float  # wall seconds from start (top-k included) to the bound plan or the end
    topk_s: float
    queries: list[QueryResult] = field(repr=False)
    skeletons_tried: int = 0

    @property
    def solved(self) -> bool:
        return self.bound is not None

    def query_counts(self) -> Counter[tuple[str, bool]]:
        return Counter((q.stream, q.success) for q in self.queries)


def run(
    config: RunConfig, *, progress: Callable[[str], None] | None = None
) -> tuple[RunResult, LoadedDomain, Problem]:
    say = progress or (lambda _m: None)
    start = time.perf_counter()
    loaded, problem = problem_for_scene(config.scene, seed=config.seed)
    abstract = plan_abstract(
        loaded.domain,
        loaded.streams,
        problem,
        AbstractConfig(k=config.k, diversity_ignore=loaded.spec.diversity_ignore),
    )
    runtime = loaded.runtime(problem, seed=config.seed)
    queries: list[QueryResult] = []
    bound: BoundPlan | None = None
    tried = 0
    for plan in abstract.plans:
        if time.perf_counter() - start > config.budget_s:
            break
        tried += 1
        say(f"skeleton {tried}/{len(abstract.plans)}: {len(queries)} queries so far")
        bound, made = bind_sequentially(
            plan,
            loaded.domain,
            problem,
            runtime,
            attempts=config.attempts,
            restarts=config.restarts,
        )
        queries += made
        if bound is not None:
            break
    result = RunResult(
        config,
        bound,
        time.perf_counter() - start,
        abstract.seconds["topk"],
        queries,
        tried,
    )
    return result, loaded, problem

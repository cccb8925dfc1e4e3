"""The horizon curves of the store's benchmarks (``GET /api/benchmarks/horizon``): what
``tamp horizon`` draws, for every series the store holds.

A series is the benchmarks that share a domain, the planners (in order: the first is the
reference), the number of seeds, the first seed, the budget, the model file and the stream order,
and whose scenes differ: one benchmark per scene, as ``tamp horizon`` runs them (or as benchmarks
launched one by one with the same settings). A group of one scene is a benchmark, not a curve,
and is not a series. Benchmarks that are done count, and running ones with the seeds every
planner has finished; cancelled and interrupted ones do not. When a scene has several
benchmarks of the same settings the newest done one is taken (a running one only while no done
one exists).

Each benchmark's points (:func:`planner.horizon.summary_points`: per planner, the mean
planning and total seconds over the seeds, unsolved at the budget, with 95% bootstrap
intervals) are kept while its trials and status are unchanged, as the benchmark page keeps its
summary: a request costs two queries of the store while nothing changed.
"""

from __future__ import annotations

import hashlib
import logging
import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, Field

from app.errors import RequestError
from planner.bench import BenchConfig
from planner.horizon import Point, scene_goal, summary_points
from planner.planners import get_planner
from planner.status import BenchStatus

if TYPE_CHECKING:
    from app.benchmarks import BenchInfo, BenchService
    from planner.store import BenchRecord

log = logging.getLogger(__name__)

KEPT_POINTS = 512  # benchmarks whose points are kept while their trials and status are unchanged
SHOWN: tuple[BenchStatus, ...] = ("done", "running")  # benchmarks a series is drawn from


# --- the answer ---------------------------------------------------------------------------------


class HorizonPoint(BaseModel):
    """One planner on one scene: ``tamp horizon``'s point (its JSON file's fields)."""

    scene: str
    objects: int = Field(description="facts the scene's goal names")
    planner: str
    seeds: int = Field(description="seeds every planner of the benchmark finished")
    solved: int
    bench_id: str
    code: str | None = Field(description="the code revision the benchmark ran")
    planning: tuple[float, float, float] = Field(
        description="mean, low, high (95% bootstrap) planning seconds; unsolved at the budget"
    )
    total: tuple[float, float, float] = Field(
        description="mean, low, high total (planning + execution) seconds; unsolved at the budget"
    )
    improvement: tuple[float, float, float] | None = Field(
        description="1 - mean total / the first planner's over the same seeds (None for it)"
    )
    zero_planning_bound: tuple[float, float, float] | None = Field(
        description="1 - mean execution / the first planner's mean total over the seeds both "
        "solved: what this planner would save planning in no time (None for the first)"
    )
    skeleton: tuple[float, float, float] | None = Field(
        default=None,
        description="mean, low, high seconds of planning spent by the skeleton source (every "
        "batch); None where no run recorded them",
    )


class HorizonBench(BaseModel):
    """A benchmark of a series: the one taken for its scene."""

    id: str
    scene: str
    objects: int
    status: str
    done: int  # trials finished
    total: int  # trials in all


class HorizonSeries(BaseModel):
    """Benchmarks of one domain with the same settings over different scenes, and their points."""

    key: str = Field(description="stable while the settings are: pick a series by it")
    label: str = Field(description='"kitchen: baseline, paper, learned — 20 seeds, 300 s"')
    domain: str
    planners: list[str]
    trials: int
    seed_start: int
    budget_s: float
    model: str | None = Field(description="the model file's name")
    order: str
    benchmarks: list[HorizonBench] = Field(description="one per scene, by objects")
    points: list[HorizonPoint] = Field(description="by objects, then planner")


# --- grouping -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Settings:
    """What the benchmarks of one series share."""

    domain: str  # the domain's name
    planners: tuple[str, ...]
    trials: int
    seed_start: int
    budget_s: float
    model: str | None  # the model file as the benchmark recorded it
    order: str
    # each trial's bounds besides its seconds (BenchConfig.max_queries, max_iterations)
    max_queries: int | None = None
    max_iterations: int | None = None

    @property
    def model_name(self) -> str | None:
        return None if self.model is None else Path(self.model).stem

    def key(self) -> str:
        fields: tuple[Any, ...] = (
            self.domain,
            self.planners,
            self.trials,
            self.seed_start,
            self.budget_s,
            self.model,
            self.order,
        )
        if self.max_queries is not None or self.max_iterations is not None:
            fields += (self.max_queries, self.max_iterations)  # a series without keeps its key
        return hashlib.sha1(repr(fields).encode()).hexdigest()[:12]

    def label(self) -> str:
        text = (
            f"{self.domain}: {', '.join(self.planners)} — {self.trials} seeds, {self.budget_s:g} s"
        )
        if self.model is not None:
            text += f", model {self.model_name}"
        if self.order != "auto":
            text += f", order {self.order}"
        if self.max_queries is not None:
            text += f", {self.max_queries} queries"
        if self.max_iterations is not None:
            text += f", {self.max_iterations} iterations"
        return text


@dataclass(frozen=True)
class _Member:
    record: BenchRecord
    info: BenchInfo
    objects: int


@dataclass(frozen=True)
class _Filter:
    domain: str | None
    planners: tuple[str, ...] | None
    trials: int | None
    seed_start: int | None
    budget_s: float | None
    model: str | None

    def admits(self, s: _Settings) -> bool:
        return (
            (self.domain is None or s.domain == self.domain)
            and (self.planners is None or s.planners == self.planners)
            and (self.trials is None or s.trials == self.trials)
            and (self.seed_start is None or s.seed_start == self.seed_start)
            and (self.budget_s is None or s.budget_s == self.budget_s)
            and (self.model is None or s.model_name == self.model)
        )


def parse_planners(text: str) -> tuple[str, ...]:
    """``"baseline,paper,learned"`` as ``tamp horizon --planners`` takes it; a
    :class:`RequestError` on ``planners`` names an unknown one."""
    names = tuple(p.strip() for p in text.split(","))
    if not any(names):
        raise RequestError("planners", "name at least one planner: baseline,paper,learned")
    for name in names:
        try:
            get_planner(name)
        except ValueError as exc:
            raise RequestError("planners", str(exc)) from exc
    return names


class Horizon:
    """The series of the store's benchmarks, their points kept while unchanged."""

    def __init__(self, benches: BenchService) -> None:
        self.benches = benches
        self._lock = threading.Lock()
        self._points: OrderedDict[tuple[Any, ...], list[Point]] = OrderedDict()
        # (scene, domain as recorded) -> (the domain's name, objects in the goal); None: the
        # scene no longer loads, and its benchmarks are left out.
        self._scenes: dict[tuple[str, str | None], tuple[str, int] | None] = {}

    def series(
        self,
        *,
        domain: str | None = None,
        planners: str | None = None,
        trials: int | None = None,
        seed_start: int | None = None,
        budget_s: float | None = None,
        model: str | None = None,
    ) -> list[HorizonSeries]:
        """Every series (newest first), or those with the settings given; a
        :class:`RequestError` names a parameter that names nothing known."""
        wanted = _Filter(
            domain,
            None if planners is None else parse_planners(planners),
            trials,
            seed_start,
            budget_s,
            model,
        )
        groups = self._groups()
        self._check(wanted, groups)
        out = []
        for settings, members in groups.items():
            if len(members) < 2 or not wanted.admits(settings):
                continue
            out.append(self._series(settings, members))
        return out

    def _groups(self) -> dict[_Settings, list[_Member]]:
        """Every group of settings (newest benchmark first) with one benchmark per scene."""
        groups: dict[_Settings, dict[str, _Member]] = {}
        for record, info in self.benches.listed():  # newest first
            if info.status not in SHOWN:
                continue
            try:
                config = BenchConfig.from_dict(record.config)
            except (KeyError, TypeError, ValueError):
                continue
            facts = self._scene(config.scene, config.domain) if config.seeds else None
            if facts is None:
                continue
            settings = _Settings(
                domain=facts[0],
                planners=config.planners,
                trials=len(config.seeds),
                seed_start=min(config.seeds),
                budget_s=config.budget_s,
                model=config.model,
                order=config.order,
                max_queries=config.max_queries,
                max_iterations=config.max_iterations,
            )
            scenes = groups.setdefault(settings, {})
            kept = scenes.get(config.scene)
            if kept is None or (kept.info.status != "done" and info.status == "done"):
                scenes[config.scene] = _Member(record, info, facts[1])
        return {s: list(members.values()) for s, members in groups.items()}

    def _check(self, wanted: _Filter, groups: dict[_Settings, list[_Member]]) -> None:
        if wanted.domain is not None:
            known = {s.domain for s in self.benches.domains.scenes()} | {g.domain for g in groups}
            if wanted.domain not in known:
                raise RequestError(
                    "domain",
                    f"unknown domain {wanted.domain!r} (known: {', '.join(sorted(known))})",
                )
        if wanted.model is not None:
            names = set(self.benches.models.files())
            known = names | {g.model_name for g in groups if g.model_name is not None}
            if wanted.model not in known:
                raise RequestError(
                    "model",
                    f"unknown model {wanted.model!r} (known: {', '.join(sorted(known)) or 'none'})",
                )

    def _series(self, settings: _Settings, members: list[_Member]) -> HorizonSeries:
        members = sorted(members, key=lambda m: (m.objects, m.info.scene))
        points: list[Point] = []
        for m in members:
            points += self._points_of(m)
        order = {p: i for i, p in enumerate(settings.planners)}
        points.sort(key=lambda p: (p.objects, p.scene, order.get(p.planner, len(order))))
        return HorizonSeries(
            key=settings.key(),
            label=settings.label(),
            domain=settings.domain,
            planners=list(settings.planners),
            trials=settings.trials,
            seed_start=settings.seed_start,
            budget_s=settings.budget_s,
            model=settings.model_name,
            order=settings.order,
            benchmarks=[
                HorizonBench(
                    id=m.info.id,
                    scene=m.info.scene,
                    objects=m.objects,
                    status=m.info.status,
                    done=m.info.done,
                    total=m.info.total,
                )
                for m in members
            ],
            points=[HorizonPoint.model_validate(p.to_dict()) for p in points],
        )

    def _points_of(self, member: _Member) -> list[Point]:
        key = self.benches.summary_key(member.info)
        with self._lock:
            kept = self._points.get(key)
            if kept is not None:
                self._points.move_to_end(key)
                return kept
        if member.info.done == 0:
            return []  # nothing finished yet: no summary to read
        info, summary = self.benches.summary(member.info.id)  # kept by the benchmark page too
        found = summary_points(summary, member.objects)
        with self._lock:
            self._points[self.benches.summary_key(info)] = found
            while len(self._points) > KEPT_POINTS:
                self._points.popitem(last=False)
        return found

    def _scene(self, scene: str, domain: str | None) -> tuple[str, int] | None:
        key = (scene, domain)
        with self._lock:
            if key in self._scenes:
                return self._scenes[key]
        try:
            facts: tuple[str, int] | None = scene_goal(scene, domain)
        except Exception as exc:  # a scene or domain that no longer loads
            log.warning("benchmarks of scene %s left out of the horizon: %s", scene, exc)
            facts = None
        with self._lock:
            self._scenes[key] = facts
        return facts

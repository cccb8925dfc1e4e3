"""Domains: one folder each with ``domain.pddl``, ``stream.pddl`` and Python bindings.

A domain is registered by name in :data:`DOMAINS`; asking for an unknown name lists the known.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from planner.pddl.parser import load_domain, load_problem, load_streams
from planner.pddl.structs import Domain, Problem, StreamSet
from planner.scene import Scene, SceneError, load_scene
from planner.streams.adapters import StreamAdapter
from planner.streams.runtime import StreamRuntime, bind_streams

DOMAINS_DIR = Path(__file__).resolve().parent

ProblemBuilder = Callable[[Scene, Domain, int], Problem]  # scene, domain, seed
BindingFactory = Callable[[Problem, random.Random], Mapping[str, StreamAdapter]]
StaticContext = Callable[[Problem], Mapping[str, Any]]  # JSON facts of the scene, per problem


@dataclass(frozen=True)
class DomainSpec:
    """How to load a domain and build its problems and samplers."""

    name: str
    problem_from_scene: ProblemBuilder
    bindings: BindingFactory | None  # None: samplers not written yet
    diversity_ignore: tuple[str, ...] = ()  # actions that only reorder (see AbstractConfig)
    # Fluents that do not change a stream's outcome: left out when the learned search pools the
    # outcomes of the same query made from different nodes (see LearnedPolicy).
    evidence_ignore: tuple[str, ...] = ()
    # Per stream, fluents of its context its sampler never reads: the model's stream order
    # (planner/search/order.py) need not bind the objects they name first.
    unread: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    # What every query's context carries besides its state (JSON; the kitchen: the footprints of
    # its platforms and the sizes of its blocks, which a learned model needs to tell how much
    # room a platform has left). Recorded with each query and given to the learned models.
    static_context: StaticContext | None = None

    @property
    def directory(self) -> Path:
        return DOMAINS_DIR / self.name


@dataclass(frozen=True)
class LoadedDomain:
    spec: DomainSpec
    domain: Domain
    streams: StreamSet

    def problem_from_scene(self, scene: Scene, *, seed: int = 0) -> Problem:
        """The scene's problem; ``seed`` draws its randomised parts (initial block poses)."""
        if scene.domain != self.spec.name:
            raise SceneError(
                f"{scene.source}: domain: scene is for {scene.domain!r}, not {self.spec.name!r}"
            )
        return self.spec.problem_from_scene(scene, self.domain, seed)

    def problem_from_file(self, path: str | Path) -> Problem:
        return load_problem(path, self.domain)

    def static_context(self, problem: Problem) -> dict[str, Any]:
        """The scene facts every query's context carries (empty for most domains)."""
        if self.spec.static_context is None:
            return {}
        return dict(self.spec.static_context(problem))

    def runtime(self, problem: Problem, *, seed: int) -> StreamRuntime:
        """Samplers bound to the declared streams, seeded."""
        if self.spec.bindings is None:
            raise NotImplementedError(
                f"domain {self.spec.name!r} has no stream samplers yet"
            )  # TODO(#3): the kitchen's pybullet samplers
        return bind_streams(self.streams, self.spec.bindings(problem, random.Random(seed)))


def _registry() -> dict[str, DomainSpec]:
    from planner.domains import kitchen, line

    return {spec.name: spec for spec in (kitchen.SPEC, line.SPEC)}


def known_domains() -> tuple[str, ...]:
    return tuple(sorted(_registry()))


def get_domain(name: str) -> LoadedDomain:
    """Parse the domain called ``name`` and its streams."""
    specs = _registry()
    if name not in specs:
        raise ValueError(f"unknown domain {name!r} (known: {', '.join(sorted(specs))})")
    spec = specs[name]
    domain = load_domain(spec.directory / "domain.pddl")
    streams = load_streams(spec.directory / "stream.pddl", domain)
    known = {s.name for s in streams.streams}
    unknown = sorted(set(spec.unread) - known)
    if unknown:
        raise ValueError(
            f"domain {name!r}: unread names streams not in {streams.source}: {', '.join(unknown)}"
        )
    return LoadedDomain(spec, domain, streams)


def problem_for_scene(scene_name: str, *, seed: int = 0) -> tuple[LoadedDomain, Problem]:
    """Load a scene by name or path, its domain, and the problem it describes."""
    scene = load_scene(scene_name)
    if scene.domain not in known_domains():
        raise scene.field_error(
            "domain", f"unknown domain {scene.domain!r} (known: {', '.join(known_domains())})"
        )
    loaded = get_domain(scene.domain)
    return loaded, loaded.problem_from_scene(scene, seed=seed)

"""What a manipulation domain's :class:`~planner.domains.spec.DomainSpec` shares: the inputs of
its four streams, its samplers and its validator imported when first used, the search hints
every pick-and-place domain gives (:func:`manipulation_spec`), and the domain loaded with other
samplers. No pybullet here: a domain's module imports this when it loads."""

from __future__ import annotations

import importlib
import random
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from planner.abstract.skeleton import GroundAction
from planner.domains.spec import (
    BindingFactory,
    DomainSpec,
    LoadedDomain,
    PlanCheck,
    ProblemBuilder,
    StateFeatures,
    StaticContext,
)
from planner.values import ValueType

if TYPE_CHECKING:
    from planner.view import DomainView
from planner.pddl.structs import Problem
from planner.streams.adapters import StreamAdapter


def stream_inputs(pose: str, grasp: str, conf: str) -> dict[str, tuple[str, ...]]:
    """What each of the four streams' inputs are (``DomainSpec.input_kinds``), given the names of
    the domain's pose, grasp and configuration value types: a stream may go unrecorded in a
    model's training data."""
    return {
        "sample-grasp": ("name",),
        "sample-placement": ("name", "name"),
        "inverse-kinematics": ("name", pose, grasp),
        "plan-motion": (conf, conf),
    }


@dataclass(frozen=True)
class LazySamplers:
    """A domain's samplers as its ``DomainSpec.bindings``: ``bindings(problem, rng, config)`` of
    the module ``module``, imported when first asked for (pybullet only when sampling), set by
    ``config`` (None: the module's ``SamplerConfig()``)."""

    module: str
    config: object | None = None

    def __call__(self, problem: Problem, rng: random.Random) -> Mapping[str, StreamAdapter]:
        samplers = importlib.import_module(self.module)
        config = samplers.SamplerConfig() if self.config is None else self.config
        made: Mapping[str, StreamAdapter] = samplers.bindings(problem, rng, config)
        return made


@dataclass(frozen=True)
class LazyValidator:
    """A domain's plan validator as its ``DomainSpec.validate``: ``validate_plan(actions,
    values, problem)`` of the module ``module`` (which replays the plan in pybullet), imported
    when first asked for; what it reports (``ok``, ``message``, ``execution_s``) as a
    :class:`~planner.domains.spec.PlanCheck`."""

    module: str

    def __call__(
        self, actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
    ) -> PlanCheck:
        report = importlib.import_module(self.module).validate_plan(actions, values, problem)
        return PlanCheck(bool(report.ok), str(report.message), report.execution_s)


def with_bindings(loaded: LoadedDomain, domain: str, bindings: BindingFactory) -> LoadedDomain:
    """``loaded`` (which must be the domain called ``domain``) with its samplers made by
    ``bindings`` instead of its own: for probes that compare sampler settings (pass it to
    :func:`planner.api.solve` as ``loaded``)."""
    if loaded.spec.name != domain:
        raise ValueError(f"with_samplers takes the {domain} domain, got {loaded.spec.name!r}")
    return replace(loaded, spec=replace(loaded.spec, bindings=bindings))


ROBOT_FLUENTS = ("at-conf", "can-move", "holding")  # where the robot is, what its hand holds


def manipulation_spec(
    *,
    name: str,
    description: str,
    package: str,
    problem_from_scene: ProblemBuilder,
    static_context: StaticContext,
    value_types: tuple[ValueType, ...],
    view: DomainView,
    features: StateFeatures,
    kinds: tuple[str, str, str],
    model: Path | None,
    blocking: tuple[str, ...] = (),
    placement_unread: tuple[str, ...] = (),
) -> DomainSpec:
    """The :class:`DomainSpec` of a pick-and-place domain whose package ``package`` holds the
    modules ``samplers`` (``bindings`` and ``SamplerConfig``) and ``validate`` (``validate_plan``),
    imported when first used; ``kinds`` names its pose, grasp and configuration value types.

    The search hints are the same rule for every such domain: moves only connect configurations
    (plans that differ in them are alike); where the robot stands and how it holds the block do
    not change where a block fits, so a dead end is not blamed on them, nor on the fluents of
    ``blocking`` (what stands in the way of a grasp); a placement reads only the blocks already
    where it goes, so it may be sampled before that block's grasp and IK (the placements come
    together and a full region is blamed on them alone), never the robot nor the fluents of
    ``placement_unread``.
    """
    return DomainSpec(
        name=name,
        description=description,
        problem_from_scene=problem_from_scene,
        bindings=LazySamplers(f"{package}.samplers"),
        value_types=value_types,
        validate=LazyValidator(f"{package}.validate"),
        static_context=static_context,
        view=view,
        features=features,
        input_kinds=stream_inputs(*kinds),
        model=model,
        diversity_ignore=("move",),
        evidence_ignore=(*ROBOT_FLUENTS, *blocking),
        unread={"sample-placement": (*ROBOT_FLUENTS, *placement_unread)},
    )

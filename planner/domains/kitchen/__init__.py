"""The PR2 kitchen: blocks are cleaned at the sink and cooked on the stove.

The domain object :data:`DOMAIN` is registered through the ``guided_tamp.domains`` entry point
like any other domain; pybullet is imported only when samplers or the validator are used.
"""

from __future__ import annotations

import random
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from planner.abstract.skeleton import GroundAction
from planner.domains.kitchen.codec import VALUE_TYPES
from planner.domains.kitchen.features import KitchenFeatures
from planner.domains.kitchen.problem import (
    ARM,
    GEOMETRY_KEY,
    START_CONF,
    initial_pose_name,
    problem_from_scene,
    static_context,
)
from planner.domains.kitchen.view import KitchenView
from planner.domains.spec import DomainSpec, LoadedDomain, PlanCheck
from planner.pddl.structs import Problem
from planner.streams.adapters import StreamAdapter

if TYPE_CHECKING:
    from planner.domains.kitchen.samplers import SamplerConfig

MODEL = Path(__file__).resolve().parent / "model.pt"  # the shipped model (docs/learning.md)


def _bindings(problem: Problem, rng: random.Random) -> Mapping[str, StreamAdapter]:
    from planner.domains.kitchen.samplers import bindings  # pybullet only when sampling

    return bindings(problem, rng)


def with_samplers(loaded: LoadedDomain, config: SamplerConfig) -> LoadedDomain:
    """The loaded kitchen with its samplers set by ``config`` instead of the defaults: for
    probes that compare sampler settings (pass it to :func:`planner.api.solve` as ``loaded``)."""

    def bindings(problem: Problem, rng: random.Random) -> Mapping[str, StreamAdapter]:
        from planner.domains.kitchen.samplers import bindings as kitchen_bindings

        return kitchen_bindings(problem, rng, config)

    if loaded.spec.name != DOMAIN.name:
        raise ValueError(f"with_samplers takes the kitchen, got domain {loaded.spec.name!r}")
    return replace(loaded, spec=replace(loaded.spec, bindings=bindings))


def validate(
    actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
) -> PlanCheck:
    """Replay the plan in simulation (planner/domains/kitchen/validate.py)."""
    from planner.domains.kitchen.validate import validate_plan

    report = validate_plan(actions, values, problem)
    return PlanCheck(report.ok, report.message, report.execution_s)


DOMAIN = DomainSpec(
    name="kitchen",
    description="the PR2 kitchen: clean blocks at the sink, cook them on the stove",
    problem_from_scene=problem_from_scene,
    bindings=_bindings,
    value_types=VALUE_TYPES,
    validate=validate,
    static_context=static_context,
    view=KitchenView(),
    features=KitchenFeatures(),
    # What each stream's inputs are (a stream may go unrecorded in a model's training data).
    input_kinds={
        "sample-grasp": ("name",),
        "sample-placement": ("name", "name"),
        "inverse-kinematics": ("name", "pose", "grasp"),
        "plan-motion": ("conf", "conf"),
    },
    model=MODEL,
    diversity_ignore=("move",),  # moves only connect configurations; compare what is done
    # Where the robot stands and how it holds the block do not change where a block fits.
    evidence_ignore=("at-conf", "can-move", "holding"),
    # A placement looks only at the blocks already on the platform, not at where the robot
    # stands or how it holds the block: it can be sampled before that block's grasp and IK, so
    # the blocks' placements come together and a full stove is blamed on the placements alone.
    unread={"sample-placement": ("at-conf", "can-move", "holding")},
)

__all__ = [
    "ARM",
    "DOMAIN",
    "GEOMETRY_KEY",
    "MODEL",
    "START_CONF",
    "initial_pose_name",
    "with_samplers",
]

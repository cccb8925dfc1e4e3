"""A Franka Panda at a table: blocks go from a cluttered table into a tray (or onto a shelf) with
little room; tall obstacles stand in the way of some blocks' grasps until they are moved.

A fixed-base arm executes in seconds, so planning is most of a run's time (the paper's regime).
The domain object :data:`DOMAIN` is registered through the ``guided_tamp.domains`` entry point
like any other; pybullet is imported only when samplers, the validator or the world are used.
See docs/panda.md.
"""

from __future__ import annotations

import random
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from planner.abstract.skeleton import GroundAction
from planner.domains.panda.features import PandaFeatures
from planner.domains.panda.problem import (
    GEOMETRY_KEY,
    START_CONF,
    initial_pose_name,
    problem_from_scene,
    static_context,
)
from planner.domains.panda.values import VALUE_TYPES
from planner.domains.panda.view import PandaView
from planner.domains.spec import DomainSpec, LoadedDomain, PlanCheck
from planner.pddl.structs import Problem
from planner.streams.adapters import StreamAdapter

if TYPE_CHECKING:
    from planner.domains.panda.samplers import SamplerConfig

MODEL = Path(__file__).resolve().parent / "model.pt"  # the shipped model (docs/panda.md)


def _bindings(problem: Problem, rng: random.Random) -> Mapping[str, StreamAdapter]:
    from planner.domains.panda.samplers import bindings  # pybullet only when sampling

    return bindings(problem, rng)


def with_samplers(loaded: LoadedDomain, config: SamplerConfig) -> LoadedDomain:
    """The loaded Panda domain with its samplers set by ``config`` instead of the defaults."""

    def bindings(problem: Problem, rng: random.Random) -> Mapping[str, StreamAdapter]:
        from planner.domains.panda.samplers import bindings as panda_bindings

        return panda_bindings(problem, rng, config)

    if loaded.spec.name != DOMAIN.name:
        raise ValueError(f"with_samplers takes the panda domain, got {loaded.spec.name!r}")
    return replace(loaded, spec=replace(loaded.spec, bindings=bindings))


def validate(
    actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
) -> PlanCheck:
    """Replay the plan in simulation (planner/domains/panda/validate.py)."""
    from planner.domains.panda.validate import validate_plan

    return validate_plan(actions, values, problem)


DOMAIN = DomainSpec(
    name="panda",
    description="a Franka Panda clears a cluttered table into a tray with little room",
    problem_from_scene=problem_from_scene,
    bindings=_bindings,
    value_types=VALUE_TYPES,
    validate=validate,
    static_context=static_context,
    view=PandaView(),
    features=PandaFeatures(),
    input_kinds={
        "sample-grasp": ("name",),
        "sample-placement": ("name", "name"),
        "inverse-kinematics": ("name", "panda_pose", "panda_grasp"),
        "plan-motion": ("panda_conf", "panda_conf"),
    },
    model=MODEL if MODEL.is_file() else None,
    diversity_ignore=("move",),  # moves only connect configurations; compare what is done
    # Where the arm is and how it holds the block do not change where a block fits.
    evidence_ignore=("at-conf", "can-move", "holding", "obstructed"),
    # A placement reads only the blocks already in the region, not the arm or the hand.
    unread={"sample-placement": ("at-conf", "can-move", "holding", "hand-empty", "obstructed")},
)

__all__ = ["DOMAIN", "GEOMETRY_KEY", "MODEL", "START_CONF", "initial_pose_name", "with_samplers"]

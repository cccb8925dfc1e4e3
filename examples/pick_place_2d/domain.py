"""The 2-D pick-and-place, brought over as a PDDLStream user would: its PDDL files in
PDDLStream's style, its primitives unchanged, and its stream map written with PDDLStream's
adapters (``planner.streams.pddlstream``). Only the scene reader, the value type of a
trajectory and the validator are this project's."""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from planner.domains import DomainSpec
from planner.pddl import Problem
from planner.streams import StreamAdapter
from planner.streams.pddlstream import from_fn, from_gen_fn, from_list_fn, from_test

from .primitives import (
    distance_fn,
    get_cfree_test,
    get_grasps,
    get_ik_fn,
    get_motion_fn,
    get_pose_gen,
)
from .scene import problem_from_scene, world_of
from .validate import validate
from .values import VALUE_TYPES

MODEL = Path(__file__).with_name("model.pt")  # trained by `tamp train` (docs/BENCHMARKS.md)


def stream_map(
    problem: Problem, rng: random.Random
) -> Mapping[str, StreamAdapter | Callable[..., Any]]:
    """The stream map, as PDDLStream's run scripts write it."""
    world = world_of(problem)
    return {
        "sample-pose": from_gen_fn(get_pose_gen(world, rng)),
        "sample-grasp": from_list_fn(get_grasps(world)),
        "inverse-kinematics": from_fn(get_ik_fn(world)),
        "plan-motion": from_fn(get_motion_fn(world)),
        "test-cfree": from_test(get_cfree_test(world)),
        "Dist": distance_fn,
    }


DOMAIN = DomainSpec(
    name="pick-place-2d",
    description=(
        "PDDLStream's 2-D continuous pick-and-place: blocks into regions, clear of each other"
    ),
    problem_from_scene=problem_from_scene,
    bindings=stream_map,
    value_types=VALUE_TYPES,
    validate=validate,
    diversity_ignore=("move",),
    model=MODEL if MODEL.exists() else None,
)

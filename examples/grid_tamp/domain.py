"""The grid TAMP, brought over as a PDDLStream user would: its PDDL files in PDDLStream's
style (a rule, a stream with no inputs, a constant), its primitives unchanged, its stream map
written with PDDLStream's adapters (``planner.streams.pddlstream``), an ``or`` goal built in
Python. No validator of its own (a plan is replayed fact by fact and its tests asked again) and
no value types (cells are numpy arrays, paths plain lists); only the paths' seconds are said
here, for the execution time."""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping
from typing import Any

from planner.domains import DomainSpec
from planner.pddl import Problem
from planner.streams import StreamAdapter
from planner.streams.pddlstream import from_fn, from_gen_fn, from_test

from .primitives import (
    collision_test,
    get_ik_fn,
    get_motion_fn,
    get_pose_gen,
    path_seconds,
)
from .scene import problem_from_scene, world_of


def stream_map(
    problem: Problem, rng: random.Random
) -> Mapping[str, StreamAdapter | Callable[..., Any]]:
    """The stream map, as PDDLStream's run scripts write it (``collision`` is a helper the
    stream file never declares: PDDLStream ignores it, and so does this project)."""
    world = world_of(problem)
    return {
        "sample-pose": from_gen_fn(get_pose_gen(world, rng)),
        "inverse-kinematics": from_fn(get_ik_fn(world)),
        "plan-motion": from_fn(get_motion_fn(world)),
        "test-cfree": from_test(lambda *args: not collision_test(*args)),
        "collision": collision_test,
    }


def execution_s(stream: str, outputs: tuple[Any, ...], problem: Problem) -> float:
    """A path takes its cells' seconds; nothing else moves."""
    if stream != "plan-motion":
        return 0.0
    return path_seconds(world_of(problem), outputs[0])


DOMAIN = DomainSpec(
    name="grid-tamp",
    description="PDDLStream's discrete TAMP: an arm over a grid moves blocks to target cells",
    problem_from_scene=problem_from_scene,
    bindings=stream_map,
    execution_s=execution_s,
    diversity_ignore=("move",),
)

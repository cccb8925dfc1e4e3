"""The blocksworld with streams, brought over as a PDDLStream user would: its PDDL files in
PDDLStream's style, its primitives unchanged, and its stream map written with PDDLStream's
adapters (``planner.streams.pddlstream``), the carry a fluent stream."""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from planner.domains import DomainSpec
from planner.pddl import Problem
from planner.streams import StreamAdapter
from planner.streams.pddlstream import from_fn, from_test

from .primitives import get_carry_fn, get_fits_test, get_stackable_test
from .scene import problem_from_scene, world_of
from .validate import validate
from .values import VALUE_TYPES

MODEL = Path(__file__).with_name("model.pt")


def stream_map(
    problem: Problem, rng: random.Random
) -> Mapping[str, StreamAdapter | Callable[..., Any]]:
    """The stream map, as PDDLStream's run scripts write it."""
    world = world_of(problem)
    return {
        "test-stackable": from_test(get_stackable_test(world)),
        "test-fits": from_test(get_fits_test(world)),
        "plan-carry": from_fn(get_carry_fn(world)),
    }


DOMAIN = DomainSpec(
    name="blocks-streams",
    description=(
        "PDDLStream's blocksworld with streams: towers of blocks that may not stand on every block"
    ),
    problem_from_scene=problem_from_scene,
    bindings=stream_map,
    value_types=VALUE_TYPES,
    validate=validate,
    model=MODEL if MODEL.exists() else None,
)

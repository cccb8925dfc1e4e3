"""A test domain for the learned planner's ``model_order``: the plan needs a dear, sure value
before a cheap, doubtful one that does not read it (tests/search/test_order.py)."""

from __future__ import annotations

import random
import time
from collections.abc import Mapping

from planner.domains import DomainSpec
from planner.pddl.structs import Atom, Domain, Literal, Problem, TypedName
from planner.scene import Scene, check_name
from planner.streams.adapters import Failure, StreamAdapter, from_fn

DEAR_S = 0.005  # what a dear query costs (its sampler waits)
CHEAP_P = 0.25  # how often a cheap query finds a value


def problem_from_scene(scene: Scene, domain: Domain, seed: int = 0) -> Problem:
    del seed
    items = [check_name(scene, f"items[{i}]", x) for i, x in enumerate(scene.get("items", list))]
    return Problem(
        scene.name,
        domain.name,
        tuple(TypedName(i, "object") for i in items),
        frozenset(Atom("item", (i,)) for i in items),
        tuple(Literal(Atom("finished", (i,))) for i in items),
        scene.source,
    )


def bindings(problem: Problem, rng: random.Random) -> Mapping[str, StreamAdapter]:
    del problem

    def dear(item: str) -> tuple[float]:
        time.sleep(DEAR_S)
        return (1.0,)

    def cheap(item: str) -> tuple[float] | Failure:
        return (2.0,) if rng.random() < CHEAP_P else Failure("nothing found")

    return {"sample-dear": from_fn(dear), "sample-cheap": from_fn(cheap)}


DOMAIN = DomainSpec(
    name="order", problem_from_scene=problem_from_scene, bindings=bindings, description="test"
)

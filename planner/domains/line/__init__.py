"""A tiny pure-Python domain: blocks on a 1-D line, picked and placed into regions.

Scene fields: ``regions`` (name, lo, hi), ``blocks`` (name, width, x, region), ``reach`` (how far
from 0 the gripper reaches) and ``goal``. Values handed to samplers: a block's width, a region's
``(lo, hi)``, a pose's centre ``x``.
"""

from __future__ import annotations

import random
from collections.abc import Mapping
from typing import Any

from planner.domains import DomainSpec
from planner.pddl.structs import Atom, Domain, Literal, Problem, TypedName
from planner.scene import Scene, check_name, goal_atoms
from planner.streams.adapters import Failure, StreamAdapter, from_fn, from_test

REACH_KEY = "__reach__"  # where a problem keeps the gripper's reach among its values


def _number(scene: Scene, path: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise scene.field_error(path, f"expected a number, got {value!r}")
    return float(value)


def problem_from_scene(scene: Scene, domain: Domain, seed: int = 0) -> Problem:
    """The line's problem; nothing in it is random, so ``seed`` is unused."""
    del seed
    values: dict[str, object] = {REACH_KEY: _number(scene, "reach", scene.data.get("reach"))}
    objects: list[TypedName] = []
    init: set[Atom] = {Atom("hand-empty")}
    regions: dict[str, tuple[float, float]] = {}
    for i, reg in enumerate(scene.get("regions", list)):
        if not isinstance(reg, dict):
            raise scene.field_error(f"regions[{i}]", "expected an object with name, lo, hi")
        name = check_name(scene, f"regions[{i}].name", reg.get("name"))
        lo = _number(scene, f"regions[{i}].lo", reg.get("lo"))
        hi = _number(scene, f"regions[{i}].hi", reg.get("hi"))
        if hi <= lo:
            raise scene.field_error(f"regions[{i}].hi", f"must exceed lo ({lo}), got {hi}")
        regions[name] = (lo, hi)
        values[name] = (lo, hi)
        objects.append(TypedName(name, "region"))
        init.add(Atom("region", (name,)))
    names = set(regions)
    for i, blk in enumerate(scene.get("blocks", list)):
        if not isinstance(blk, dict):
            raise scene.field_error(
                f"blocks[{i}]", "expected an object with name, width, x, region"
            )
        name = check_name(scene, f"blocks[{i}].name", blk.get("name"))
        width = _number(scene, f"blocks[{i}].width", blk.get("width"))
        x = _number(scene, f"blocks[{i}].x", blk.get("x"))
        region = blk.get("region")
        if region not in regions:
            raise scene.field_error(f"blocks[{i}].region", f"unknown region {region!r}")
        lo, hi = regions[region]
        if not lo + width / 2 <= x <= hi - width / 2:
            raise scene.field_error(f"blocks[{i}].x", f"block does not lie inside {region}")
        pose = f"x0-{name}"
        if name in names:
            raise scene.field_error(f"blocks[{i}].name", f"name {name!r} is already used")
        names |= {name, pose}
        values[name], values[pose] = width, x
        objects += [TypedName(name, "block"), TypedName(pose, "pose")]
        init |= {
            Atom("movable", (name,)),
            Atom("valid", (name, pose)),
            Atom("contained", (name, pose, region)),
            Atom("at", (name, pose)),
            Atom("in", (name, region)),
        }
    arity = {p.name: p.arity for p in domain.predicates}
    goal = tuple(Literal(Atom(p, a)) for p, a in goal_atoms(scene, arity, names))
    return Problem(
        scene.name, domain.name, tuple(objects), frozenset(init), goal, scene.source, values=values
    )


def bindings(problem: Problem, rng: random.Random) -> Mapping[str, StreamAdapter]:
    """Samplers on plain floats: a uniform position in a region, and a reach test."""
    reach = float(problem.values.get(REACH_KEY, float("inf")))  # type: ignore[arg-type]

    def sample_pose(width: float, region: tuple[float, float]) -> tuple[float] | Failure:
        lo, hi = region
        if hi - lo < width:
            return Failure(f"the region is {hi - lo:g} wide, the block {width:g}")
        return (rng.uniform(lo + width / 2, hi - width / 2),)

    def reachable(width: float, x: float) -> bool:
        return abs(x) + width / 2 <= reach

    return {"sample-pose": from_fn(sample_pose), "test-reachable": from_test(reachable)}


DOMAIN = DomainSpec(
    name="line",
    description="blocks on a 1-D line, picked and placed into regions (a test domain)",
    problem_from_scene=problem_from_scene,
    bindings=bindings,
)

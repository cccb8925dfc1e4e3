"""A tiny domain brought over from PDDLStream unchanged: its files, its primitives and its stream
map, bound with planner.streams.pddlstream's adapters; its problem from PDDLStream's init."""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping
from typing import Any

from planner.domains import DomainSpec
from planner.pddl import Domain, Problem
from planner.scene import Scene
from planner.streams import StreamAdapter
from planner.streams.pddlstream import (
    from_fn,
    from_gen_fn,
    from_list_fn,
    from_test,
    problem_from_init,
)

from .primitives import blocked, distance, get_grasps, get_pose_gen, inverse_kinematics, reachable

CALLS: list[tuple[str, list[tuple[Any, ...]]]] = []  # what the fluent stream was given


def problem_from_scene(scene: Scene, domain: Domain, seed: int) -> Problem:
    regions = scene.get("regions", dict)
    blocks = scene.get("blocks", dict)
    init: list[tuple[Any, ...]] = [("HandEmpty",), ("CanMove",), ("Conf", 0.0), ("AtConf", 0.0)]
    for r in regions:
        init.append(("Region", r))
    for b, spec in blocks.items():
        pose = float(spec["pose"])
        init += [("Block", b), ("Pose", b, pose), ("AtPose", b, pose)]
        init += [("Grasp", b, g) for (g,) in get_grasps(b)]
    goal = ("and", *[("InRegion", b, "goal") for b in blocks])
    values = {
        "__scene__": {"regions": regions, "widths": {b: s["width"] for b, s in blocks.items()}}
    }
    return problem_from_init(domain, init, goal, name=scene.name, values=values)


def bindings(
    problem: Problem, rng: random.Random
) -> Mapping[str, StreamAdapter | Callable[..., Any]]:
    scene = problem.values["__scene__"]
    regions = {r: tuple(box) for r, box in scene["regions"].items()}  # type: ignore[index]
    return {
        "sample-pose": from_gen_fn(get_pose_gen(regions, scene["widths"], rng, CALLS)),  # type: ignore[index]
        "sample-grasp": from_list_fn(get_grasps),
        "inverse-kinematics": from_fn(inverse_kinematics),
        "test-reachable": from_test(reachable),
        "Blocked": blocked,  # PDDLStream binds a (:predicate ...) to a plain function
        "Distance": distance,  # ... and a (:function ...)
    }


DOMAIN = DomainSpec(
    name="tiny-pddlstream",
    problem_from_scene=problem_from_scene,
    bindings=bindings,
    description="a PDDLStream-style 1-D pick-and-place (tests)",
)

"""The Panda tabletop's problems: objects, initial facts, goal and values from a scene file."""

from __future__ import annotations

from typing import Any

from planner.domains.panda.geometry import PandaGeometry, geometry_from_scene
from planner.domains.panda.values import Conf
from planner.pddl.structs import Atom, Domain, Literal, Problem, TypedName
from planner.robots.panda.model import READY
from planner.scene import Scene, SceneError, goal_atoms

GEOMETRY_KEY = "__panda_geometry__"  # where a Panda problem keeps its geometry in values
START_CONF = "q0"  # the arm's start configuration


def initial_pose_name(block: str) -> str:
    """The object naming a block's start pose (its value depends on the seed)."""
    return f"p0-{block}"


def problem_from_scene(scene: Scene, domain: Domain, seed: int = 0) -> Problem:
    """Objects, initial facts and goal of a Panda scene; ``seed`` draws the start poses."""
    geometry = geometry_from_scene(scene)
    try:
        poses = geometry.initial_poses(seed)
    except ValueError as err:
        raise SceneError(f"{scene.source}: spawn: {err}") from None
    values: dict[str, object] = {START_CONF: Conf(READY, READY), GEOMETRY_KEY: geometry}
    init: set[Atom] = {
        Atom("conf", (START_CONF,)),
        Atom("at-conf", (START_CONF,)),
        Atom("hand-empty"),
        Atom("can-move"),
    }
    objects = [TypedName(START_CONF)]
    names = {START_CONF}
    for region in geometry.regions:
        objects.append(TypedName(region.name))
        names.add(region.name)
        init.add(Atom("region", (region.name,)))
    for block in geometry.blocks:
        pose = initial_pose_name(block.name)
        names |= {block.name, pose}
        values[pose] = poses[block.name]
        objects += [TypedName(block.name), TypedName(pose)]
        init |= {
            Atom("block", (block.name,)),
            Atom("pose", (block.name, pose)),
            Atom("at-pose", (block.name, pose)),
            Atom("on", (block.name, block.start)),
        }
        init |= {Atom("placeable", (block.name, r)) for r in geometry.placeable(block)}
        if block.blocks is not None:
            init |= {
                Atom("obstructs", (block.name, block.blocks)),
                Atom("obstructed", (block.blocks,)),
            }
    arity = {p.name: p.arity for p in domain.predicates}
    goal = tuple(Literal(Atom(p, a)) for p, a in goal_atoms(scene, arity, names))
    return Problem(
        scene.name, domain.name, tuple(objects), frozenset(init), goal, scene.source, values
    )


def geometry_of(problem: Problem) -> PandaGeometry:
    geometry = problem.values.get(GEOMETRY_KEY)
    if not isinstance(geometry, PandaGeometry):
        raise ValueError(
            f"problem {problem.name}: no Panda geometry in its values (build it from a scene)"
        )
    return geometry


def static_context(problem: Problem) -> dict[str, Any]:
    """``{"geometry": {"regions": {name: {"box": [xmin, xmax, ymin, ymax], "kind", "rim"}},
    "blocks": {name: [sx, sy, sz]}}}``: what a learned model reads to tell how much room a
    region has left and what stands around a grasp (planner/domains/panda/features.py)."""
    geometry = geometry_of(problem)
    return {
        "geometry": {
            "regions": {
                r.name: {"box": [round(v, 6) for v in r.footprint()], "kind": r.kind, "rim": r.rim}
                for r in geometry.regions
            },
            "blocks": {b.name: list(b.size) for b in geometry.blocks},
        }
    }

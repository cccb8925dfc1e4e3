"""The kitchen's problems: objects, initial facts, goal and values from a scene file."""

from __future__ import annotations

from typing import Any

from planner.domains.kitchen.geometry import KitchenGeometry, geometry_from_scene
from planner.domains.kitchen.values import Conf
from planner.pddl.structs import Atom, Domain, Literal, Problem, TypedName
from planner.robots.pr2.model import REST_ARM_CONF
from planner.scene import Scene, goal_atoms

GEOMETRY_KEY = "__kitchen_geometry__"  # where a kitchen problem keeps its geometry in values

START_CONF = "q0"  # the robot's initial base and arm configuration
ARM = "right"  # the arm that works; the other stays tucked


def problem_from_scene(scene: Scene, domain: Domain, seed: int = 0) -> Problem:
    """Objects, initial facts and goal of a kitchen scene (its geometry is checked too).

    ``seed`` draws the initial block poses; they are the values of the ``p0-*`` objects.
    """
    geometry = geometry_from_scene(scene)
    poses = geometry.initial_poses(seed)
    values: dict[str, object] = {
        START_CONF: Conf(geometry.robot.base, geometry.robot.torso, REST_ARM_CONF[ARM]),
        GEOMETRY_KEY: geometry,
    }
    init: set[Atom] = {
        Atom("conf", (START_CONF,)),
        Atom("at-conf", (START_CONF,)),
        Atom("hand-empty"),
        Atom("can-move"),
    }
    objects = [TypedName(START_CONF)]
    for plat in geometry.platforms:
        objects.append(TypedName(plat.name))
        init.add(Atom("platform", (plat.name,)))
        if plat.kind in ("sink", "stove"):
            init.add(Atom(plat.kind, (plat.name,)))
    names = {p.name for p in geometry.platforms} | {START_CONF}
    for block in geometry.blocks:
        pose = initial_pose_name(block.name)
        names |= {block.name, pose}
        values[pose] = poses[block.name]
        objects += [TypedName(block.name), TypedName(pose)]
        init |= {
            Atom("block", (block.name,)),
            Atom("pose", (block.name, pose)),
            Atom("supported", (block.name, pose, block.start)),
            Atom("at-pose", (block.name, pose)),
            Atom("on", (block.name, block.start)),
        }
    arity = {p.name: p.arity for p in domain.predicates}
    goal = tuple(Literal(Atom(p, a)) for p, a in goal_atoms(scene, arity, names))
    return Problem(
        scene.name, domain.name, tuple(objects), frozenset(init), goal, scene.source, values
    )


def initial_pose_name(block: str) -> str:
    """The object naming a block's initial pose (its value depends on the seed)."""
    return f"p0-{block}"


def static_context(problem: Problem) -> dict[str, Any]:
    """``{"geometry": {"platforms": {name: [xmin, xmax, ymin, ymax]}, "blocks": {name: edge}}}``:
    the parts of the scene a learned model reads to tell how much room a platform has left."""
    geometry = problem.values.get(GEOMETRY_KEY)
    if not isinstance(geometry, KitchenGeometry):
        raise ValueError(f"problem {problem.name}: no kitchen geometry in its values")
    return {
        "geometry": {
            "platforms": {p.name: [round(v, 6) for v in p.footprint()] for p in geometry.platforms},
            "blocks": {b.name: b.size for b in geometry.blocks},
        }
    }

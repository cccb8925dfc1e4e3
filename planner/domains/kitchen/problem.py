"""The kitchen's problems: objects, initial facts, goal and values from a scene file."""

from __future__ import annotations

from typing import Any

from planner.domains.kitchen.geometry import KitchenGeometry, geometry_from_scene
from planner.domains.kitchen.values import Conf
from planner.domains.manipulation.problem import ProblemParts, stored
from planner.pddl.structs import Atom, Domain, Problem
from planner.robots.pr2.model import REST_ARM_CONF
from planner.scene import Scene

GEOMETRY_KEY = "__kitchen_geometry__"  # where a kitchen problem keeps its geometry in values

ROBOT = "pr2"  # the kitchen's robot: its name in planner.robots, and its body's in the 3D view
START_CONF = "q0"  # the robot's initial base and arm configuration
ARM = "right"  # the arm that works; the other stays tucked


def problem_from_scene(scene: Scene, domain: Domain, seed: int = 0) -> Problem:
    """Objects, initial facts and goal of a kitchen scene (its geometry is checked too).

    ``seed`` draws the initial block poses; they are the values of the ``p0-*`` objects.
    """
    geometry = geometry_from_scene(scene)
    poses = geometry.initial_poses(seed)
    start = Conf(geometry.robot.base, geometry.robot.torso, REST_ARM_CONF[ARM])
    parts = ProblemParts(START_CONF, {START_CONF: start, GEOMETRY_KEY: geometry})
    for plat in geometry.platforms:
        kind = (Atom(plat.kind, (plat.name,)),) if plat.kind in ("sink", "stove") else ()
        parts.fixture(plat.name, Atom("platform", (plat.name,)), *kind)
    for block in geometry.blocks:
        pose = parts.block(block.name, poses[block.name], block.start)
        parts.init.add(Atom("supported", (block.name, pose, block.start)))
    return parts.problem(scene, domain)


def geometry_of(problem: Problem) -> KitchenGeometry:
    """The kitchen geometry a problem keeps (a ValueError if it was not built from a scene)."""
    return stored(problem, GEOMETRY_KEY, KitchenGeometry, "kitchen geometry")


def static_context(problem: Problem) -> dict[str, Any]:
    """``{"geometry": {"platforms": {name: [xmin, xmax, ymin, ymax]}, "blocks": {name: edge}}}``:
    the parts of the scene a learned model reads to tell how much room a platform has left."""
    geometry = geometry_of(problem)
    return {
        "geometry": {
            "platforms": {p.name: [round(v, 6) for v in p.footprint()] for p in geometry.platforms},
            "blocks": {b.name: b.size for b in geometry.blocks},
        }
    }

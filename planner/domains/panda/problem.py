"""The Panda tabletop's problems: objects, initial facts, goal and values from a scene file."""

from __future__ import annotations

from typing import Any

from planner.domains.manipulation.problem import ProblemParts, stored
from planner.domains.panda.geometry import PandaGeometry, geometry_from_scene
from planner.domains.panda.values import Conf
from planner.pddl.structs import Atom, Domain, Problem
from planner.robots.panda.model import READY
from planner.scene import Scene, SceneError

GEOMETRY_KEY = "__panda_geometry__"  # where a Panda problem keeps its geometry in values
ROBOT = "panda"  # the domain's robot: its name in planner.robots, and its body's in the 3D view
START_CONF = "q0"  # the arm's start configuration


def problem_from_scene(scene: Scene, domain: Domain, seed: int = 0) -> Problem:
    """Objects, initial facts and goal of a Panda scene; ``seed`` draws the start poses."""
    geometry = geometry_from_scene(scene)
    try:
        poses = geometry.initial_poses(seed)
    except ValueError as err:
        raise SceneError(f"{scene.source}: spawn: {err}") from None
    parts = ProblemParts(START_CONF, {START_CONF: Conf(READY, READY), GEOMETRY_KEY: geometry})
    for region in geometry.regions:
        parts.fixture(region.name, Atom("region", (region.name,)))
    for block in geometry.blocks:
        parts.block(block.name, poses[block.name], block.start)
        parts.init |= {Atom("placeable", (block.name, r)) for r in geometry.placeable(block)}
        if block.blocks is not None:
            parts.init |= {
                Atom("obstructs", (block.name, block.blocks)),
                Atom("obstructed", (block.blocks,)),
            }
    return parts.problem(scene, domain)


def geometry_of(problem: Problem) -> PandaGeometry:
    """The Panda geometry a problem keeps (a ValueError if it was not built from a scene)."""
    return stored(problem, GEOMETRY_KEY, PandaGeometry, "Panda geometry")


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

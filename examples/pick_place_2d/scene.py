"""A pick-and-place scene file as PDDLStream's ``init`` and ``goal``, then a planning problem.

Scene fields::

    "regions": {"grey": [xmin, xmax], "red": [xmin, xmax], ...}
    "arm":     {"base_x": 0.0, "reach": 8.5, "speed": 4.0}
    "blocks":  [{"name": "A", "width": 1.0, "height": 1.0, "region": "grey"}, ...]
    "goal":    [["In", "A", "red"], ...]

Each block starts at a position drawn with the seed: inside its region, where the arm reaches it,
clear of the others; or, with ``"x": 4.5``, exactly there (PDDLStream's problem generators place
blocks so: packed side by side, or one standing in the goal region). Every error names the scene
file and the field.
"""

from __future__ import annotations

import random
from typing import Any

import numpy as np

from planner.pddl import Domain, Problem
from planner.scene import Scene, check_name
from planner.streams.pddlstream import problem_from_init

from .primitives import GRASP_FRACTIONS, GRIP, TRAVEL_Y, Block, World

WORLD_KEY = "__world__"  # where a problem keeps its World among its values
PLACE_TRIES = 2000


def _number(scene: Scene, path: str, value: Any, *, positive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise scene.field_error(path, f"expected a number, got {value!r}")
    if positive and value <= 0:
        raise scene.field_error(path, f"expected a positive number, got {value!r}")
    return float(value)


def world_from_scene(scene: Scene) -> tuple[World, dict[str, str], dict[str, float]]:
    """The scene's geometry, each block's start region, and the fixed starts."""
    regions: dict[str, tuple[float, float]] = {}
    for name, box in scene.get("regions", dict).items():
        check_name(scene, f"regions.{name}", name)
        if not isinstance(box, list) or len(box) != 2:
            raise scene.field_error(f"regions.{name}", "expected [xmin, xmax]")
        lo = _number(scene, f"regions.{name}[0]", box[0], positive=False)
        hi = _number(scene, f"regions.{name}[1]", box[1], positive=False)
        if hi <= lo:
            raise scene.field_error(f"regions.{name}", "expected xmin < xmax")
        regions[name] = (lo, hi)
    arm = scene.get("arm", dict)
    blocks: dict[str, Block] = {}
    starts: dict[str, str] = {}
    fixed: dict[str, float] = {}
    for i, raw in enumerate(scene.get("blocks", list)):
        where = f"blocks[{i}]"
        if not isinstance(raw, dict):
            raise scene.field_error(where, "expected an object with name, width and region")
        check_name(scene, f"{where}.name", raw.get("name"))
        name = str(raw["name"])  # as written: the samplers see it so
        if name.lower() in {b.lower() for b in blocks} | set(regions):
            raise scene.field_error(f"{where}.name", f"name {name!r} is already used")
        width = _number(scene, f"{where}.width", raw.get("width", 1.0))
        height = _number(scene, f"{where}.height", raw.get("height", 1.0))
        if raw.get("region") not in regions:
            raise scene.field_error(f"{where}.region", f"unknown region {raw.get('region')!r}")
        blocks[name] = Block(name, width, height)
        starts[name] = str(raw["region"])
        if "x" in raw:
            fixed[name] = _number(scene, f"{where}.x", raw["x"], positive=False)
    if not blocks:
        raise scene.field_error("blocks", "expected at least one block")
    world = World(
        regions,
        blocks,
        _number(scene, "arm.base_x", arm.get("base_x", 0.0), positive=False),
        _number(scene, "arm.reach", arm.get("reach")),
        _number(scene, "arm.speed", arm.get("speed")),
    )
    return world, starts, fixed


def reachable(world: World, block: Block, x: float) -> bool:
    """Whether some grasp of ``block`` at ``x`` is within the arm's reach."""
    return any(abs(x + f * block.width - world.base_x) <= world.reach for f in GRASP_FRACTIONS)


def initial_poses(
    scene: Scene, world: World, starts: dict[str, str], fixed: dict[str, float], seed: int
) -> dict[str, Any]:
    rng = random.Random(seed)
    placed: dict[str, float] = {}
    for i, (name, block) in enumerate(world.blocks.items()):
        if name not in fixed:
            continue
        lo, hi = world.regions[starts[name]]
        x = fixed[name]
        if not lo + block.width / 2 <= x <= hi - block.width / 2:
            raise scene.field_error(
                f"blocks[{i}].x", f"{x:g} does not hold the block inside region {starts[name]!r}"
            )
        if not reachable(world, block, x):
            raise scene.field_error(f"blocks[{i}].x", f"{x:g} is out of the arm's reach")
        for other, x2 in placed.items():
            if abs(x - x2) < (block.width + world.blocks[other].width) / 2:
                raise scene.field_error(f"blocks[{i}].x", f"{x:g} overlaps block {other!r}")
        placed[name] = x
    for i, (name, block) in enumerate(world.blocks.items()):
        if name in fixed:
            continue
        lo, hi = world.regions[starts[name]]
        for _ in range(PLACE_TRIES):
            x = rng.uniform(lo + block.width / 2, hi - block.width / 2)
            clear = all(
                abs(x - x2) >= (block.width + world.blocks[o].width) / 2 for o, x2 in placed.items()
            )
            if clear and reachable(world, block, x):
                placed[name] = x
                break
        else:
            raise scene.field_error(
                f"blocks[{i}]",
                f"no reachable start clear of the others in region {starts[name]!r} after "
                f"{PLACE_TRIES} draws (seed {seed}): make the region larger",
            )
    return {name: np.array([placed[name], 0.0]) for name in world.blocks}


def pddlstream_problem(scene: Scene, seed: int) -> tuple[list[tuple[Any, ...]], Any, World]:
    """PDDLStream's ``init`` and ``goal`` for the scene, as its examples build them."""
    world, starts, fixed = world_from_scene(scene)
    poses = initial_poses(scene, world, starts, fixed, seed)
    q0 = np.array([world.base_x, TRAVEL_Y])
    init: list[tuple[Any, ...]] = [("CanMove",), ("HandEmpty",), ("Conf", q0), ("AtConf", q0)]
    init += [("Region", r) for r in world.regions]
    for name in world.blocks:
        p = poses[name]
        init += [("Block", name), ("Pose", name, p), ("AtPose", name, p)]
        init += [("Contained", name, p, starts[name])]
        init += [("Placeable", name, r) for r in world.regions]
    goal_facts = []
    for i, fact in enumerate(scene.get("goal", list)):
        if not isinstance(fact, list) or not fact or not all(isinstance(a, str) for a in fact):
            raise scene.field_error(f"goal[{i}]", "expected a fact such as ['In', 'A', 'red']")
        goal_facts.append(tuple(fact))
    if not goal_facts:
        raise scene.field_error("goal", "expected at least one goal fact")
    return init, ("and", *goal_facts), world


def problem_from_scene(scene: Scene, domain: Domain, seed: int = 0) -> Problem:
    init, goal, world = pddlstream_problem(scene, seed)
    try:
        return problem_from_init(
            domain, init, goal, name=scene.name, values={WORLD_KEY: world}, source=scene.source
        )
    except ValueError as exc:
        raise scene.field_error("goal", str(exc)) from exc


def world_of(problem: Problem) -> World:
    world = problem.values.get(WORLD_KEY)
    if not isinstance(world, World):
        raise ValueError(f"problem {problem.name}: not a pick-place-2d problem")
    return world


__all__ = ["GRIP", "WORLD_KEY", "pddlstream_problem", "problem_from_scene", "world_of"]

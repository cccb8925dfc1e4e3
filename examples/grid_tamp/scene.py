"""A grid scene file as PDDLStream's ``init`` and ``goal``, then a planning problem.

Scene fields::

    "grid":    [width, height]                      cells along x and y
    "arm":     {"base": [x, y], "reach": 6, "seconds_per_cell": 0.5}
    "targets": {"t1": [x, y], ...}                  cells the goal may name
    "blocks":  [{"name": "A", "at": [x, y]}, {"name": "B", "at": "t1"}, {"name": "C"}]
    "goal":    ["and", ["or", ["AtPose", "A", "t1"], ["AtPose", "A", "t2"]], ["AtConf", "home"]]

A block without ``"at"`` starts on a cell drawn with the seed: on the grid, in the arm's reach,
clear of the other blocks and of the targets. The goal is PDDLStream's tuple goal written as
lists: ``and``, ``or``, ``not`` and facts whose arguments are block names, target names and
``home`` (the arm's resting configuration, a constant of the domain). Every error names the
scene file and the field.
"""

from __future__ import annotations

import random
from typing import Any

import numpy as np

from planner.pddl import Domain, Problem
from planner.scene import Scene, check_name
from planner.streams.pddlstream import problem_from_init

from .primitives import UP, World

WORLD_KEY = "__world__"  # where a problem keeps its World among its values
DRAWS = 1000  # tries to draw a block's start cell


def _cell(scene: Scene, path: str, value: Any, world: World | None = None) -> np.ndarray:
    ok = isinstance(value, list) and len(value) == 2
    if not ok or not all(isinstance(v, int) and not isinstance(v, bool) for v in value):
        raise scene.field_error(path, f"expected a cell [x, y] of integers, got {value!r}")
    if world is not None and not (0 <= value[0] < world.width and 0 <= value[1] < world.height):
        raise scene.field_error(path, f"cell {value} is off the {world.width}x{world.height} grid")
    return np.array(value)


def _count(scene: Scene, path: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise scene.field_error(path, f"expected a positive integer, got {value!r}")
    return value


def world_from_scene(scene: Scene) -> World:
    grid = scene.get("grid", list)
    if len(grid) != 2:
        raise scene.field_error("grid", "expected [width, height]")
    arm = scene.get("arm", dict)
    seconds = arm.get("seconds_per_cell", 0.5)
    if isinstance(seconds, bool) or not isinstance(seconds, int | float) or seconds <= 0:
        raise scene.field_error("arm.seconds_per_cell", f"expected seconds > 0, got {seconds!r}")
    world = World(
        _count(scene, "grid[0]", grid[0]),
        _count(scene, "grid[1]", grid[1]),
        (0, 0),
        _count(scene, "arm.reach", arm.get("reach")),
        float(seconds),
    )
    base = _cell(scene, "arm.base", arm.get("base"), world)
    return World(world.width, world.height, (int(base[0]), int(base[1])), world.reach, seconds)


def _goal(scene: Scene, data: Any, path: str, names: dict[str, Any]) -> tuple[Any, ...]:
    """The scene's goal as PDDLStream's tuples, target names replaced by their cells."""
    if not isinstance(data, list) or not data or not isinstance(data[0], str):
        raise scene.field_error(path, "expected a fact or ['and' | 'or' | 'not', ...]")
    head = data[0]
    if head.lower() in ("and", "or", "not"):
        return (head, *(_goal(scene, d, f"{path}[{i + 1}]", names) for i, d in enumerate(data[1:])))
    args = []
    for i, arg in enumerate(data[1:]):
        if not isinstance(arg, str) or arg not in names:
            known = ", ".join(names)
            raise scene.field_error(f"{path}[{i + 1}]", f"unknown name {arg!r} (known: {known})")
        args.append(names[arg])
    return (head, *args)


def pddlstream_problem(
    scene: Scene, seed: int
) -> tuple[list[tuple[Any, ...]], tuple[Any, ...], dict[str, Any], World]:
    """PDDLStream's ``init``, ``goal`` and ``constant_map`` for the scene."""
    world = world_from_scene(scene)
    targets: dict[str, np.ndarray] = {}
    for name, cell in scene.get("targets", dict).items():
        check_name(scene, f"targets.{name}", name)
        targets[name] = _cell(scene, f"targets.{name}", cell, world)
    home = np.array([*world.base, 0]) + UP
    rng = random.Random(seed)
    poses: dict[str, np.ndarray] = {}
    drawn = []
    for i, raw in enumerate(scene.get("blocks", list)):
        where = f"blocks[{i}]"
        if not isinstance(raw, dict):
            raise scene.field_error(where, "expected an object with a name")
        check_name(scene, f"{where}.name", raw.get("name"))
        name = str(raw["name"])
        if name in poses or name in targets or name == "home":
            raise scene.field_error(f"{where}.name", f"name {name!r} is already used")
        at = raw.get("at")
        if at is None:
            drawn.append((i, name))
            poses[name] = np.array([-1, -1])  # drawn below, once every fixed cell is known
        elif isinstance(at, str):
            if at not in targets:
                raise scene.field_error(f"{where}.at", f"unknown target {at!r}")
            poses[name] = targets[at]
        else:
            poses[name] = _cell(scene, f"{where}.at", at, world)
    taken = {tuple(p) for p in (*poses.values(), *targets.values())}
    for i, name in drawn:
        for _ in range(DRAWS):
            cell = (rng.randrange(world.width), rng.randrange(world.height))
            if (
                cell not in taken
                and abs(cell[0] - world.base[0]) + abs(cell[1] - world.base[1]) <= world.reach
            ):
                break
        else:
            raise scene.field_error(f"blocks[{i}]", "no free cell in reach: make the grid larger")
        taken.add(cell)
        poses[name] = np.array(cell)
    if not poses:
        raise scene.field_error("blocks", "expected at least one block")
    init: list[tuple[Any, ...]] = [("HandEmpty",), ("CanMove",), ("Conf", "home")]
    init.append(("AtConf", "home"))
    for name, p in poses.items():
        init += [("Block", name), ("Pose", p), ("AtPose", name, p)]
    init += [("Target", t) for t in targets.values()]
    names: dict[str, Any] = {**{b: b for b in poses}, **targets, "home": "home"}
    goal = _goal(scene, scene.get("goal", list), "goal", names)
    return init, goal, {"home": home}, world


def problem_from_scene(scene: Scene, domain: Domain, seed: int = 0) -> Problem:
    init, goal, constant_map, world = pddlstream_problem(scene, seed)
    try:
        return problem_from_init(
            domain,
            init,
            goal,
            name=scene.name,
            constant_map=constant_map,
            values={WORLD_KEY: world},
            source=scene.source,
        )
    except ValueError as exc:
        raise scene.field_error("goal", str(exc)) from exc


def world_of(problem: Problem) -> World:
    world = problem.values.get(WORLD_KEY)
    if not isinstance(world, World):
        raise ValueError(f"problem {problem.name}: not a grid-tamp problem")
    return world

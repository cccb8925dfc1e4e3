"""A blocksworld scene file as PDDLStream's ``init`` and ``goal``, then a planning problem.

Scene fields::

    "slots":  {"s1": {"x": -4.0, "width": 1.5}, ...}
    "arm":    {"base_x": 0.0, "moment": 9.0, "speed": 2.0, "travel_y": 6.0}
    "blocks": [{"name": "A", "width": 1.2, "height": 1.0, "weight": 1.0, "fragile": false}, ...]
    "goal":   [["On", "A", "s2"], ["On", "B", "A"], ...]
    "min_moves": 3, "max_moves": 5   (optional; default: the number of goal facts, twice it)

The seed draws where the blocks start: in a random order, each goes into a free slot it fits or
onto a clear block it may stand on; a start from which the goal cannot be reached in
``min_moves`` to ``max_moves`` carries (a breadth-first search over the same rules as the
streams) is drawn again.
Every error names the scene file and the field.
"""

from __future__ import annotations

import random
from typing import Any

from planner.pddl import Domain, Problem
from planner.scene import Scene, check_name
from planner.streams.pddlstream import problem_from_init

from .primitives import (
    Block,
    World,
    column_and_top,
    fewest_moves,
    get_fits_test,
    get_stackable_test,
)

WORLD_KEY = "__world__"
START_TRIES = 2000


def _number(scene: Scene, path: str, value: Any, *, positive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise scene.field_error(path, f"expected a number, got {value!r}")
    if positive and value <= 0:
        raise scene.field_error(path, f"expected a positive number, got {value!r}")
    return float(value)


def world_from_scene(scene: Scene) -> World:
    slots: dict[str, tuple[float, float]] = {}
    for name, raw in scene.get("slots", dict).items():
        check_name(scene, f"slots.{name}", name)
        if not isinstance(raw, dict):
            raise scene.field_error(f"slots.{name}", "expected an object with x and width")
        slots[name] = (
            _number(scene, f"slots.{name}.x", raw.get("x"), positive=False),
            _number(scene, f"slots.{name}.width", raw.get("width")),
        )
    if not slots:
        raise scene.field_error("slots", "expected at least one slot")
    blocks: dict[str, Block] = {}
    for i, raw in enumerate(scene.get("blocks", list)):
        where = f"blocks[{i}]"
        if not isinstance(raw, dict):
            raise scene.field_error(where, "expected an object with name, width, weight")
        check_name(scene, f"{where}.name", raw.get("name"))
        name = str(raw["name"])
        if name.lower() in {b.lower() for b in blocks} | {s.lower() for s in slots}:
            raise scene.field_error(f"{where}.name", f"name {name!r} is already used")
        fragile = raw.get("fragile", False)
        if not isinstance(fragile, bool):
            raise scene.field_error(f"{where}.fragile", f"expected true or false, got {fragile!r}")
        blocks[name] = Block(
            name,
            _number(scene, f"{where}.width", raw.get("width", 1.0)),
            _number(scene, f"{where}.height", raw.get("height", 1.0)),
            _number(scene, f"{where}.weight", raw.get("weight", 1.0)),
            fragile,
        )
    if not blocks:
        raise scene.field_error("blocks", "expected at least one block")
    arm = scene.get("arm", dict)
    return World(
        slots,
        blocks,
        _number(scene, "arm.base_x", arm.get("base_x", 0.0), positive=False),
        _number(scene, "arm.moment", arm.get("moment")),
        _number(scene, "arm.speed", arm.get("speed")),
        _number(scene, "arm.travel_y", arm.get("travel_y")),
    )


def _goal(scene: Scene, world: World) -> list[tuple[str, str, str]]:
    goal: list[tuple[str, str, str]] = []
    for i, fact in enumerate(scene.get("goal", list)):
        ok = isinstance(fact, list) and len(fact) == 3 and all(isinstance(a, str) for a in fact)
        if not ok or str(fact[0]).lower() != "on":
            raise scene.field_error(f"goal[{i}]", "expected a fact such as ['On', 'B', 'A']")
        if fact[1] not in world.blocks or (
            fact[2] not in world.blocks and fact[2] not in world.slots
        ):
            raise scene.field_error(f"goal[{i}]", f"unknown block or slot in {fact}")
        goal.append((fact[0], fact[1], fact[2]))
    if not goal:
        raise scene.field_error("goal", "expected at least one goal fact")
    return goal


def holdable(world: World, on: dict[str, str], b: str, support: str) -> bool:
    """Whether the arm can hold ``b`` over ``support``'s stack (so that it can lift it again)."""
    x, _ = column_and_top(world, on, support)
    return world.blocks[b].weight * abs(x - world.base_x) <= world.moment


def initial_stacks(
    scene: Scene,
    world: World,
    goal: list[tuple[str, str, str]],
    seed: int,
    min_moves: int,
    max_moves: int,
) -> dict[str, str]:
    """Where each block starts (the support under it), drawn with the seed: a start from which
    the goal is reachable in ``min_moves`` to ``max_moves`` carries."""
    rng = random.Random(seed)
    fits, stackable = get_fits_test(world), get_stackable_test(world)
    for _ in range(START_TRIES):
        on: dict[str, str] = {}
        order = list(world.blocks)
        rng.shuffle(order)
        for b in order:
            used = set(on.values())
            choices = [s for s in world.slots if s not in used and fits(b, s)]
            choices += [y for y in on if y not in used and stackable(b, y)]
            choices = [c for c in choices if holdable(world, on, b, c)]
            if not choices:
                break
            on[b] = rng.choice(choices)
        if len(on) < len(world.blocks):
            continue
        needed = fewest_moves(world, on, [(b, y) for _, b, y in goal], most=max_moves)
        if needed is not None and min_moves <= needed <= max_moves:
            return on
    raise scene.field_error(
        "blocks",
        f"no start that reaches the goal in {min_moves} to {max_moves} carries after "
        f"{START_TRIES} draws (seed {seed}): widen min_moves..max_moves or give the blocks room",
    )


def problem_from_scene(scene: Scene, domain: Domain, seed: int = 0) -> Problem:
    world = world_from_scene(scene)
    goal = _goal(scene, world)
    min_moves = scene.get("min_moves", int) if "min_moves" in scene.data else len(goal)
    max_moves = scene.get("max_moves", int) if "max_moves" in scene.data else 2 * len(goal)
    if not 0 <= min_moves <= max_moves:
        raise scene.field_error(
            "max_moves", f"expected min_moves <= max_moves, got {min_moves} and {max_moves}"
        )
    on = initial_stacks(scene, world, goal, seed, min_moves, max_moves)
    init: list[tuple[Any, ...]] = []
    for s in world.slots:
        init += [("Slot", s), ("Support", s)]
    for b in world.blocks:
        init += [("Block", b), ("Support", b), ("On", b, on[b])]
    covered = set(on.values())
    init += [("Clear", x) for x in [*world.slots, *world.blocks] if x not in covered]
    try:
        return problem_from_init(
            domain,
            init,
            ("and", *goal),
            name=scene.name,
            values={WORLD_KEY: world},
            source=scene.source,
        )
    except ValueError as exc:
        raise scene.field_error("goal", str(exc)) from exc


def world_of(problem: Problem) -> World:
    world = problem.values.get(WORLD_KEY)
    if not isinstance(world, World):
        raise ValueError(f"problem {problem.name}: not a blocks-streams problem")
    return world

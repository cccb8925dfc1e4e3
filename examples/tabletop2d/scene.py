"""A tabletop scene file as a planning problem: objects, initial facts, goal and values.

Scene fields (every length in metres)::

    "table":   [xmin, xmax, ymin, ymax]
    "arm":     {"base": [x, y], "reach": r, "speed": m/s, "start": [x, y]}
    "regions": [{"name": "left", "box": [xmin, xmax, ymin, ymax], "color": [r, g, b]}, ...]
    "blocks":  [{"name": "b1", "size": [w, d], "region": "left"}, ...]
    "goal":    [["in", "b1", "goal"], ...]

The blocks start at positions drawn with the seed: inside their region, within reach, clear of
each other. Every error names the scene file and the field.
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from planner.pddl import Atom, Domain, Literal, Problem, TypedName
from planner.scene import Scene, check_name, goal_atoms

from .values import Conf2D, Pose2D

TABLETOP_KEY = "__tabletop__"  # where a problem keeps its Tabletop among its values
START_CONF = "q0"  # the gripper's start
PLACE_TRIES = 1000  # draws of a block's start position before the scene is refused


@dataclass(frozen=True)
class Region:
    name: str
    box: tuple[float, float, float, float]  # xmin, xmax, ymin, ymax
    color: tuple[int, int, int]

    def holds(self, x: float, y: float, half_w: float, half_d: float) -> bool:
        xmin, xmax, ymin, ymax = self.box
        return xmin + half_w <= x <= xmax - half_w and ymin + half_d <= y <= ymax - half_d


@dataclass(frozen=True)
class Block:
    name: str
    size: tuple[float, float]  # width (x), depth (y)
    start: str  # its region at the start
    color: tuple[int, int, int]


@dataclass(frozen=True)
class Tabletop:
    """The geometry the samplers, the validator and the 3D view read."""

    table: tuple[float, float, float, float]
    base: tuple[float, float]  # where the arm is mounted
    reach: float  # how far from its base the gripper reaches
    speed: float  # how fast the gripper moves
    start: tuple[float, float]  # the gripper's start
    regions: tuple[Region, ...]
    blocks: tuple[Block, ...]

    def region(self, name: str) -> Region:
        return next(r for r in self.regions if r.name == name)

    def block(self, name: str) -> Block:
        return next(b for b in self.blocks if b.name == name)

    def reaches(self, x: float, y: float) -> bool:
        return math.dist(self.base, (x, y)) <= self.reach


def overlap(a: Pose2D, a_size: Sequence[float], b: Pose2D, b_size: Sequence[float]) -> bool:
    """Whether two axis-aligned blocks overlap."""
    return (
        abs(a.x - b.x) < (a_size[0] + b_size[0]) / 2
        and abs(a.y - b.y) < (a_size[1] + b_size[1]) / 2
    )


PALETTE = [(214, 69, 65), (66, 133, 244), (244, 180, 0), (15, 157, 88), (171, 71, 188)]


def _numbers(scene: Scene, path: str, value: Any, n: int) -> tuple[float, ...]:
    if (
        not isinstance(value, list)
        or len(value) != n
        or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    ):
        raise scene.field_error(path, f"expected a list of {n} numbers, got {value!r}")
    return tuple(float(v) for v in value)


def _box(scene: Scene, path: str, value: Any) -> tuple[float, float, float, float]:
    xmin, xmax, ymin, ymax = _numbers(scene, path, value, 4)
    if xmax <= xmin or ymax <= ymin:
        raise scene.field_error(path, "expected [xmin, xmax, ymin, ymax] with min < max")
    return xmin, xmax, ymin, ymax


def _number(scene: Scene, path: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or value <= 0:
        raise scene.field_error(path, f"expected a positive number, got {value!r}")
    return float(value)


def tabletop_from_scene(scene: Scene) -> Tabletop:
    """The scene's geometry, every field checked."""
    table = _box(scene, "table", scene.get("table", list))
    arm = scene.get("arm", dict)
    base = _numbers(scene, "arm.base", arm.get("base"), 2)
    start = _numbers(scene, "arm.start", arm.get("start", list(base)), 2)
    reach = _number(scene, "arm.reach", arm.get("reach"))
    speed = _number(scene, "arm.speed", arm.get("speed"))
    regions = []
    for i, raw in enumerate(scene.get("regions", list)):
        if not isinstance(raw, dict):
            raise scene.field_error(f"regions[{i}]", "expected an object with name and box")
        name = check_name(scene, f"regions[{i}].name", raw.get("name"))
        color = raw.get("color", [200, 200, 200])
        r, g, b = (int(c) for c in _numbers(scene, f"regions[{i}].color", color, 3))
        regions.append(Region(name, _box(scene, f"regions[{i}].box", raw.get("box")), (r, g, b)))
    names = {r.name for r in regions}
    if len(names) != len(regions):
        raise scene.field_error("regions", "two regions share a name")
    blocks = []
    for i, raw in enumerate(scene.get("blocks", list)):
        if not isinstance(raw, dict):
            raise scene.field_error(f"blocks[{i}]", "expected an object with name, size, region")
        name = check_name(scene, f"blocks[{i}].name", raw.get("name"))
        if name in names:
            raise scene.field_error(f"blocks[{i}].name", f"name {name!r} is already used")
        names.add(name)
        w, d = _numbers(scene, f"blocks[{i}].size", raw.get("size"), 2)
        if w <= 0 or d <= 0:
            raise scene.field_error(f"blocks[{i}].size", "sizes must be positive")
        region = raw.get("region")
        if region not in {r.name for r in regions}:
            raise scene.field_error(f"blocks[{i}].region", f"unknown region {region!r}")
        blocks.append(Block(name, (w, d), str(region), PALETTE[i % len(PALETTE)]))
    if not blocks:
        raise scene.field_error("blocks", "expected at least one block")
    return Tabletop(
        table, (base[0], base[1]), reach, speed, (start[0], start[1]), tuple(regions), tuple(blocks)
    )


def initial_poses(scene: Scene, top: Tabletop, seed: int) -> dict[str, Pose2D]:
    """Start positions drawn with ``seed``: in the block's region, reachable, clear."""
    rng = random.Random(seed)
    placed: dict[str, Pose2D] = {}
    for i, block in enumerate(top.blocks):
        region = top.region(block.start)
        xmin, xmax, ymin, ymax = region.box
        hw, hd = block.size[0] / 2, block.size[1] / 2
        for _ in range(PLACE_TRIES):
            pose = Pose2D(rng.uniform(xmin + hw, xmax - hw), rng.uniform(ymin + hd, ymax - hd))
            clear = not any(
                overlap(pose, block.size, other, top.block(name).size)
                for name, other in placed.items()
            )
            if clear and top.reaches(pose.x, pose.y):
                placed[block.name] = pose
                break
        else:
            raise scene.field_error(
                f"blocks[{i}]",
                f"no reachable place clear of the others in region {region.name!r} "
                f"after {PLACE_TRIES} draws (seed {seed}): make the region larger",
            )
    return placed


def start_pose_name(block: str) -> str:
    return f"p0-{block}"


def problem_from_scene(scene: Scene, domain: Domain, seed: int = 0) -> Problem:
    """Objects, initial facts, goal and values of a tabletop scene."""
    top = tabletop_from_scene(scene)
    poses = initial_poses(scene, top, seed)
    values: dict[str, object] = {TABLETOP_KEY: top, START_CONF: Conf2D(*top.start)}
    objects = [TypedName(START_CONF)]
    init = {
        Atom("conf", (START_CONF,)),
        Atom("at-conf", (START_CONF,)),
        Atom("hand-empty"),
        Atom("can-move"),
    }
    names = {START_CONF}
    for region in top.regions:
        objects.append(TypedName(region.name))
        init.add(Atom("region", (region.name,)))
        names.add(region.name)
    for block in top.blocks:
        pose = start_pose_name(block.name)
        values[pose] = poses[block.name]
        objects += [TypedName(block.name), TypedName(pose)]
        names |= {block.name, pose}
        init |= {
            Atom("block", (block.name,)),
            Atom("pose", (block.name, pose)),
            Atom("contained", (block.name, pose, block.start)),
            Atom("at", (block.name, pose)),
            Atom("in", (block.name, block.start)),
        }
    arity = {p.name: p.arity for p in domain.predicates}
    goal = tuple(Literal(Atom(p, a)) for p, a in goal_atoms(scene, arity, names))
    return Problem(
        scene.name, domain.name, tuple(objects), frozenset(init), goal, scene.source, values
    )


def tabletop(problem: Problem) -> Tabletop:
    """The geometry of a tabletop problem (ValueError for another problem)."""
    top = problem.values.get(TABLETOP_KEY)
    if not isinstance(top, Tabletop):
        raise ValueError(f"problem {problem.name}: not a tabletop problem")
    return top

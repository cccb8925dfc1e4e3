"""Kitchen geometry from a scene file: fixtures, blocks, the robot's start, and seeded block poses.

Pure Python (no pybullet): it validates the scene and samples initial block poses; the pybullet
world is built from it in :mod:`planner.domains.kitchen.world`. Units: metres and radians.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass
from typing import Any

from planner.domains.manipulation.problem import UprightPose, by_name
from planner.scene import Scene, check_name

PLATFORM_KINDS = ("table", "sink", "stove")  # every kitchen has at least one of each
Color = tuple[float, float, float, float]


@dataclass(frozen=True)
class Platform:
    """A box-shaped fixture whose top face holds blocks."""

    name: str
    kind: str
    center: tuple[float, float]  # x, y of the box centre
    size: tuple[float, float, float]  # x, y extent and height of the top face above the floor
    color: Color

    def __post_init__(self) -> None:
        if self.kind not in PLATFORM_KINDS:
            raise ValueError(f"platform {self.name}: unknown kind {self.kind!r}")
        if min(self.size) <= 0:
            raise ValueError(f"platform {self.name}: sizes must be positive")

    @property
    def top(self) -> float:
        return self.size[2]

    def footprint(self) -> tuple[float, float, float, float]:
        """xmin, xmax, ymin, ymax."""
        (x, y), (sx, sy, _) = self.center, self.size
        return (x - sx / 2, x + sx / 2, y - sy / 2, y + sy / 2)


@dataclass(frozen=True)
class Block:
    name: str
    size: float  # edge of the cube
    color: Color
    start: str  # platform it starts on


@dataclass(frozen=True)
class BlockPose(UprightPose):
    """An upright block on a platform: centre x, y, z and yaw."""


@dataclass(frozen=True)
class RobotStart:
    base: tuple[float, float, float]  # x, y, yaw of base_footprint
    torso: float  # torso lift, metres


@dataclass(frozen=True)
class SpawnRegion:
    """Where initial block poses are drawn on their start platform (margins from its edges)."""

    margin: float  # keep blocks this far from the platform's edges
    min_gap: float  # and this far from each other


@dataclass(frozen=True)
class KitchenGeometry:
    platforms: tuple[Platform, ...]
    blocks: tuple[Block, ...]
    robot: RobotStart
    spawn: SpawnRegion

    def platform(self, name: str) -> Platform:
        return by_name(self.platforms, name, "platform")

    def block(self, name: str) -> Block:
        return by_name(self.blocks, name, "block")

    def initial_poses(self, seed: int) -> dict[str, BlockPose]:
        """Seeded, collision-free initial poses of every block on its start platform."""
        rng = random.Random(seed)
        placed: list[tuple[float, float, float]] = []  # x, y, radius
        poses: dict[str, BlockPose] = {}
        for block in self.blocks:
            plat = self.platform(block.start)
            xmin, xmax, ymin, ymax = plat.footprint()
            radius = block.size * math.sqrt(2) / 2
            lo_x, hi_x = xmin + self.spawn.margin + radius, xmax - self.spawn.margin - radius
            lo_y, hi_y = ymin + self.spawn.margin + radius, ymax - self.spawn.margin - radius
            for _ in range(1000):
                x, y = rng.uniform(lo_x, hi_x), rng.uniform(lo_y, hi_y)
                if all(
                    math.hypot(x - px, y - py) >= radius + pr + self.spawn.min_gap
                    for px, py, pr in placed
                ):
                    break
            else:
                raise ValueError(
                    f"no room for block {block.name} on {plat.name} after 1000 tries (seed {seed})"
                )
            placed.append((x, y, radius))
            yaw = rng.uniform(-math.pi / 4, math.pi / 4)
            poses[block.name] = BlockPose(x, y, plat.top + block.size / 2, yaw)
        return poses


def _numbers(scene: Scene, path: str, value: Any, n: int) -> tuple[float, ...]:
    if (
        not isinstance(value, list)
        or len(value) != n
        or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    ):
        raise scene.field_error(path, f"expected a list of {n} numbers, got {value!r}")
    return tuple(float(v) for v in value)


def _number(scene: Scene, path: str, value: Any, *, minimum: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise scene.field_error(path, f"expected a number, got {value!r}")
    if minimum is not None and value <= minimum:
        raise scene.field_error(path, f"must be greater than {minimum}, got {value}")
    return float(value)


def _color(scene: Scene, path: str, value: Any) -> Color:
    rgba = _numbers(scene, path, value, 4)
    if not all(0.0 <= c <= 1.0 for c in rgba):
        raise scene.field_error(path, f"colour components must lie in [0, 1], got {value!r}")
    return (rgba[0], rgba[1], rgba[2], rgba[3])


def _overlap(a: Platform, b: Platform) -> bool:
    ax0, ax1, ay0, ay1 = a.footprint()
    bx0, bx1, by0, by1 = b.footprint()
    return ax0 < bx1 and bx0 < ax1 and ay0 < by1 and by0 < ay1


def geometry_from_scene(scene: Scene) -> KitchenGeometry:
    """Parse and check the geometric part of a kitchen scene; errors name the field."""
    platforms: list[Platform] = []
    for i, plat in enumerate(scene.get("platforms", list)):
        path = f"platforms[{i}]"
        if not isinstance(plat, dict):
            raise scene.field_error(path, "expected an object with name, kind, center, size")
        name = check_name(scene, f"{path}.name", plat.get("name"))
        kind = plat.get("kind")
        if kind not in PLATFORM_KINDS:
            raise scene.field_error(
                f"{path}.kind", f"expected one of {', '.join(PLATFORM_KINDS)}, got {kind!r}"
            )
        if any(p.name == name for p in platforms):
            raise scene.field_error(f"{path}.name", f"platform {name!r} is repeated")
        cx, cy = _numbers(scene, f"{path}.center", plat.get("center"), 2)
        sx, sy, sz = _numbers(scene, f"{path}.size", plat.get("size"), 3)
        if min(sx, sy, sz) <= 0:
            raise scene.field_error(f"{path}.size", f"sizes must be positive, got {[sx, sy, sz]}")
        color = _color(scene, f"{path}.color", plat.get("color", [0.6, 0.6, 0.6, 1.0]))
        platform = Platform(name, kind, (cx, cy), (sx, sy, sz), color)
        for j, other in enumerate(platforms):
            if _overlap(platform, other):
                raise scene.field_error(
                    f"{path}.center", f"{name} overlaps {other.name} (platforms[{j}])"
                )
        platforms.append(platform)
    for kind in PLATFORM_KINDS:
        if not any(p.kind == kind for p in platforms):
            raise scene.field_error("platforms", f"the kitchen needs a platform of kind {kind!r}")
    default_start = next(p.name for p in platforms if p.kind == "table")
    blocks: list[Block] = []
    raw_blocks = scene.get("blocks", list)
    if not raw_blocks:
        raise scene.field_error("blocks", "expected at least one block")
    for i, blk in enumerate(raw_blocks):
        path = f"blocks[{i}]"
        if not isinstance(blk, dict):
            raise scene.field_error(path, "expected an object with a name")
        name = check_name(scene, f"{path}.name", blk.get("name"))
        if any(b.name == name for b in blocks) or any(p.name == name for p in platforms):
            raise scene.field_error(f"{path}.name", f"name {name!r} is already used")
        size = _number(scene, f"{path}.size", blk.get("size", 0.07), minimum=0.0)
        if all(size > min(p.size[0], p.size[1]) for p in platforms):
            raise scene.field_error(f"{path}.size", f"a {size} m block fits on no platform")
        start = blk.get("on", default_start)
        if not any(p.name == start for p in platforms):
            raise scene.field_error(f"{path}.on", f"unknown platform {start!r}")
        color = _color(scene, f"{path}.color", blk.get("color", [0.8, 0.2, 0.2, 1.0]))
        blocks.append(Block(name, size, color, start))
    robot = scene.data.get("robot", {})
    if not isinstance(robot, dict):
        raise scene.field_error("robot", f"expected an object, got {robot!r}")
    base = _numbers(scene, "robot.base", robot.get("base", [0.0, 0.0, 0.0]), 3)
    torso = _number(scene, "robot.torso", robot.get("torso", 0.2))
    if not 0.0 <= torso <= 0.33:
        raise scene.field_error("robot.torso", f"torso lift must lie in [0, 0.33] m, got {torso}")
    spawn = scene.data.get("spawn", {})
    if not isinstance(spawn, dict):
        raise scene.field_error("spawn", f"expected an object, got {spawn!r}")
    margin = _number(scene, "spawn.margin", spawn.get("margin", 0.05))
    gap = _number(scene, "spawn.min_gap", spawn.get("min_gap", 0.03))
    geometry = KitchenGeometry(
        tuple(platforms),
        tuple(blocks),
        RobotStart((base[0], base[1], base[2]), torso),
        SpawnRegion(margin, gap),
    )
    for plat in platforms:
        if _robot_overlaps(geometry.robot, plat):
            raise scene.field_error("robot.base", f"the robot starts inside {plat.name}")
    try:
        geometry.initial_poses(seed=0)
    except ValueError as exc:
        raise scene.field_error("blocks", str(exc)) from exc
    return geometry


ROBOT_HALF_WIDTH = 0.34  # half the PR2 base's side, metres


def _robot_overlaps(robot: RobotStart, plat: Platform) -> bool:
    x, y, _ = robot.base
    xmin, xmax, ymin, ymax = plat.footprint()
    r = ROBOT_HALF_WIDTH * math.sqrt(2)
    return xmin - r < x < xmax + r and ymin - r < y < ymax + r

"""The Panda tabletop's geometry from a scene file: the table, its regions (the cluttered start
area, a tray with rims, a raised shelf), the blocks and the obstacles, and seeded start poses.

Pure Python (no pybullet): it validates the scene and draws the start poses; the pybullet world
is built from it in :mod:`planner.domains.panda.world`. Units: metres and radians. The robot's
base stands at the origin on the table top (z = 0), facing +x.
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from planner.domains.manipulation.problem import by_name
from planner.domains.panda.values import BlockPose
from planner.scene import Scene, SceneError, check_name

REGION_KINDS = ("table", "tray", "shelf")  # where blocks start (table), where they go (the rest)
Color = tuple[float, float, float, float]
# Metres from the base's axis where the hand comes straight down onto a block on the table (IK
# with the 0.6 rad of straight move down: at 0.28 m none, at 0.29 m every grasp, out to 0.75 m).
REACH = (0.30, 0.75)
PLACEMENT_GAP = 0.01  # metres a placed block keeps from the others and from a tray's rims
GRID_GAP = 0.035  # metres between the packing grid's blocks and from the rims: a finger's room
SPAWN_RESTARTS = 100  # whole draws of the start poses before a scene is called too crowded
MAX_WIDTH = 0.045  # metres across: the widest block the open hand comes down around


@dataclass(frozen=True)
class Region:
    """A rectangle blocks stand in: part of the table top, a tray's floor inside its rims, or a
    shelf's top face."""

    name: str
    kind: str
    center: tuple[float, float]
    size: tuple[float, float]  # inner x, y extent
    top: float  # height of the surface blocks stand on
    rim: float = 0.0  # a tray's walls rise this far above its floor
    wall: float = 0.0  # and are this thick
    color: Color = (0.6, 0.6, 0.6, 1.0)

    def __post_init__(self) -> None:
        if self.kind not in REGION_KINDS:
            raise ValueError(f"region {self.name}: unknown kind {self.kind!r}")
        if min(self.size) <= 0:
            raise ValueError(f"region {self.name}: sizes must be positive")

    def footprint(self) -> tuple[float, float, float, float]:
        """xmin, xmax, ymin, ymax of the surface blocks may stand on."""
        (x, y), (sx, sy) = self.center, self.size
        return (x - sx / 2, x + sx / 2, y - sy / 2, y + sy / 2)

    def contains(self, pose: BlockPose, size: tuple[float, float, float]) -> bool:
        """The block's footprint lies inside the region (1 mm of slack) at its height."""
        xmin, xmax, ymin, ymax = self.footprint()
        hx, hy = footprint_half(size, pose.yaw)
        return (
            xmin - 1e-3 <= pose.x - hx
            and pose.x + hx <= xmax + 1e-3
            and ymin - 1e-3 <= pose.y - hy
            and pose.y + hy <= ymax + 1e-3
            and abs(pose.z - (self.top + size[2] / 2)) < 2e-3
        )


@dataclass(frozen=True)
class Block:
    """A box on the table: a target (goes to a goal region) or an obstacle (tall; stands next
    to the target named by ``blocks``, in the way of every grasp of it)."""

    name: str
    size: tuple[float, float, float]  # x, y, z extent
    color: Color
    start: str  # the region it starts in
    obstacle: bool = False
    blocks: str | None = None  # the target it stands next to


@dataclass(frozen=True)
class Spawn:
    """How start poses are drawn: ``margin`` from the start region's edges, ``min_gap`` between
    blocks (room for the fingers), an obstacle ``blocker_gap`` from its target and
    ``obstacle_clearance`` from every other block, turned up to ``max_yaw`` from square."""

    margin: float = 0.01
    min_gap: float = 0.05
    blocker_gap: float = 0.005
    max_yaw: float = math.pi / 4
    # Centre to centre, metres, between an obstacle and the blocks it does not stand against:
    # the open hand is 21 cm long and 7 cm wide, and a tall block within its reach stops it
    # coming down. Without it 2 of panda-10's 300 blocks on seeds 1000-1029 could not be
    # picked by any plan (their obstacles named other blocks); at 10 cm 1, at 12 cm none (and
    # none of panda-12's 360).
    obstacle_clearance: float = 0.12


@dataclass(frozen=True)
class Table:
    center: tuple[float, float]
    size: tuple[float, float]
    height: float  # of its legs below the top (drawn; the top is at z = 0)
    color: Color


@dataclass(frozen=True)
class PandaGeometry:
    table: Table
    regions: tuple[Region, ...]
    blocks: tuple[Block, ...]
    spawn: Spawn

    def region(self, name: str) -> Region:
        return by_name(self.regions, name, "region")

    def block(self, name: str) -> Block:
        return by_name(self.blocks, name, "block")

    def placeable(self, block: Block) -> tuple[str, ...]:
        """The regions a block may be put in: an obstacle back on the table, a target into a
        tray or onto a shelf."""
        kinds = ("table",) if block.obstacle else ("tray", "shelf")
        return tuple(r.name for r in self.regions if r.kind in kinds)

    def initial_poses(self, seed: int) -> dict[str, BlockPose]:
        """Seeded start poses: targets apart by ``min_gap``, each obstacle ``blocker_gap`` from
        one side of its target, turned as it is. Raises ValueError when they do not fit."""
        rng = random.Random(seed)
        for _ in range(SPAWN_RESTARTS):
            poses = self._draw_all(rng)
            if poses is not None:
                return poses
        raise ValueError(
            f"seed {seed}: the blocks do not fit apart in their start regions "
            f"({SPAWN_RESTARTS} tries)"
        )

    def _draw_all(self, rng: random.Random) -> dict[str, BlockPose] | None:
        blockers: dict[str, Block] = {b.blocks: b for b in self.blocks if b.blocks is not None}
        poses: dict[str, BlockPose] = {}
        for block in self.blocks:
            if block.obstacle and block.blocks is not None:
                continue  # drawn with its target
            blocker = blockers.get(block.name)
            for _ in range(200):
                pose = self._draw(block, rng)
                if pose is None or not self._apart(block, pose, poses):
                    continue
                if blocker is None:
                    poses[block.name] = pose
                    break
                beside = self._beside(block, pose, blocker, poses, rng)
                if beside is not None:
                    poses[block.name] = pose
                    poses[blocker.name] = beside
                    break
            else:
                return None
        return poses

    def _draw(self, block: Block, rng: random.Random) -> BlockPose | None:
        region = self.region(block.start)
        yaw = rng.uniform(-self.spawn.max_yaw, self.spawn.max_yaw)
        hx, hy = footprint_half(block.size, yaw)
        xmin, xmax, ymin, ymax = region.footprint()
        m = self.spawn.margin
        if xmax - xmin < 2 * (hx + m) or ymax - ymin < 2 * (hy + m):
            return None
        x = rng.uniform(xmin + m + hx, xmax - m - hx)
        y = rng.uniform(ymin + m + hy, ymax - m - hy)
        if not REACH[0] <= math.hypot(x, y) <= REACH[1]:
            return None  # blocks start where the hand reaches
        return BlockPose(x, y, region.top + block.size[2] / 2, yaw)

    def _apart(
        self, block: Block, pose: BlockPose, poses: Mapping[str, BlockPose], gap: float = -1.0
    ) -> bool:
        gap = self.spawn.min_gap if gap < 0 else gap
        r = radius(block.size)
        for n, o in poses.items():
            other = self.block(n)
            d = math.hypot(pose.x - o.x, pose.y - o.y)
            if d < r + radius(other.size) + gap:
                return False
            # A tall obstacle stands in the way of its own block only: the others keep the
            # hand's room from it (the palm reaches over the short blocks, not over it).
            pair = {block.name, other.name}
            if (
                (block.obstacle or other.obstacle)
                and not (block.blocks in pair or other.blocks in pair)
                and d < self.spawn.obstacle_clearance
            ):
                return False
        return True

    def _beside(
        self,
        target: Block,
        pose: BlockPose,
        blocker: Block,
        poses: Mapping[str, BlockPose],
        rng: random.Random,
    ) -> BlockPose | None:
        """The obstacle against one side of the target (in the target's frame), inside the
        region and apart from the other blocks; None when no side has room."""
        region = self.region(blocker.start)
        sides = [0, 1, 2, 3]
        rng.shuffle(sides)
        for side in sides:
            angle = pose.yaw + side * math.pi / 2
            along = (target.size[0] if side % 2 == 0 else target.size[1]) / 2
            depth = (blocker.size[0] if side % 2 == 0 else blocker.size[1]) / 2
            d = along + self.spawn.blocker_gap + depth
            beside = BlockPose(
                pose.x + d * math.cos(angle),
                pose.y + d * math.sin(angle),
                region.top + blocker.size[2] / 2,
                pose.yaw,
            )
            reach = REACH[0] <= math.hypot(beside.x, beside.y) <= REACH[1]
            if (
                reach
                and region.contains(beside, blocker.size)
                and self._apart(blocker, beside, poses)
            ):
                return beside
        return None


def slots(lo: float, hi: float, pitch: float) -> list[float]:
    """Centres from ``lo`` to ``hi`` (both ends) at least ``pitch`` apart: as many as fit."""
    n = int((hi - lo) / pitch + 1e-6) + 1 if hi > lo else 1
    if n == 1:
        return [(lo + hi) / 2]
    return [lo + i * (hi - lo) / (n - 1) for i in range(n)]


def grid_slots(
    box: tuple[float, float, float, float],
    half: tuple[float, float],
    *,
    gap: float = GRID_GAP,
) -> tuple[list[float], list[float]]:
    """The packing grid of a region (``box``: xmin, xmax, ymin, ymax) for a block of footprint
    ``half`` extents: x and y centres ``gap`` from the rims and ``gap`` apart, as many as fit."""
    xmin, xmax, ymin, ymax = box
    hx, hy = half
    return (
        slots(xmin + gap + hx, xmax - gap - hx, 2 * hx + gap),
        slots(ymin + gap + hy, ymax - gap - hy, 2 * hy + gap),
    )


def radius(size: tuple[float, float, float]) -> float:
    """Half the diagonal of a block's footprint: it fits in this circle however it turns."""
    return math.hypot(size[0], size[1]) / 2


def footprint_half(size: tuple[float, float, float], yaw: float) -> tuple[float, float]:
    """Half the x and y extent of a block's footprint turned by ``yaw``."""
    c, s = abs(math.cos(yaw)), abs(math.sin(yaw))
    return (size[0] / 2 * c + size[1] / 2 * s, size[0] / 2 * s + size[1] / 2 * c)


# --- reading a scene file ---------------------------------------------------------------------


def _numbers(scene: Scene, path: str, value: Any, n: int, *, positive: bool = False) -> list[float]:
    if (
        not isinstance(value, list)
        or len(value) != n
        or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    ):
        raise scene.field_error(path, f"expected {n} numbers, got {value!r}")
    if positive and min(value) <= 0:
        raise scene.field_error(path, f"expected positive numbers, got {value!r}")
    return [float(v) for v in value]


def _number(scene: Scene, path: str, value: Any, *, low: float = 0.0) -> float:
    if not isinstance(value, int | float) or isinstance(value, bool) or value < low:
        raise scene.field_error(path, f"expected a number >= {low:g}, got {value!r}")
    return float(value)


def _color(scene: Scene, path: str, value: Any, default: Color) -> Color:
    if value is None:
        return default
    c = _numbers(scene, path, value, 4)
    if not all(0 <= v <= 1 for v in c):
        raise scene.field_error(path, f"expected 4 numbers in [0, 1], got {value!r}")
    return (c[0], c[1], c[2], c[3])


def _object(scene: Scene, path: str, value: Any) -> Mapping[str, Any]:
    if not isinstance(value, dict):
        raise scene.field_error(path, f"expected an object, got {value!r}")
    return value


def geometry_from_scene(scene: Scene) -> PandaGeometry:
    """The scene's geometry, every field checked (a :class:`SceneError` names the field)."""
    t = _object(scene, "table", scene.get("table", dict))
    (tcx, tcy), (tsx, tsy) = (
        _numbers(scene, "table.center", t.get("center"), 2),
        _numbers(scene, "table.size", t.get("size"), 2, positive=True),
    )
    table = Table(
        (tcx, tcy),
        (tsx, tsy),
        _number(scene, "table.height", t.get("height", 0.75), low=0.0),
        _color(scene, "table.color", t.get("color"), (0.62, 0.47, 0.32, 1.0)),
    )
    regions: list[Region] = []
    for i, raw in enumerate(scene.get("regions", list)):
        path = f"regions[{i}]"
        r = _object(scene, path, raw)
        kind = r.get("kind")
        if kind not in REGION_KINDS:
            raise scene.field_error(
                f"{path}.kind", f"expected one of {', '.join(REGION_KINDS)}, got {kind!r}"
            )
        cx, cy = _numbers(scene, f"{path}.center", r.get("center"), 2)
        sx, sy = _numbers(scene, f"{path}.size", r.get("size"), 2, positive=True)
        default_top = {"table": 0.0, "tray": 0.01, "shelf": 0.2}[kind]
        region = Region(
            check_name(scene, f"{path}.name", r.get("name")),
            kind,
            (cx, cy),
            (sx, sy),
            _number(scene, f"{path}.top", r.get("top", default_top)),
            _number(scene, f"{path}.rim", r.get("rim", 0.03 if kind == "tray" else 0.0)),
            _number(scene, f"{path}.wall", r.get("wall", 0.01 if kind == "tray" else 0.0)),
            _color(scene, f"{path}.color", r.get("color"), (0.55, 0.6, 0.68, 1.0)),
        )
        if region.name in {x.name for x in regions}:
            raise scene.field_error(f"{path}.name", f"region {region.name!r} appears twice")
        _check_region(scene, path, region, table)
        for j, other in enumerate(regions):
            if kind != "table" and other.kind != "table" and _overlap(region, other):
                raise scene.field_error(path, f"{region.name} overlaps regions[{j}] {other.name}")
        regions.append(region)
    kinds = {r.kind for r in regions}
    if "table" not in kinds or not kinds & {"tray", "shelf"}:
        raise scene.field_error("regions", "expected a table region and a tray or a shelf")
    names = {r.name: r for r in regions}
    blocks: list[Block] = []
    for key, obstacle in (("blocks", False), ("obstacles", True)):
        if key == "obstacles" and key not in scene.data:
            continue
        for i, raw in enumerate(scene.get(key, list)):
            path = f"{key}[{i}]"
            b = _object(scene, path, raw)
            default = [0.04, 0.04, 0.12] if obstacle else [0.04, 0.04, 0.04]
            sx, sy, sz = _numbers(scene, f"{path}.size", b.get("size", default), 3, positive=True)
            start = b.get("on", "table")
            if start not in names or names[start].kind != "table":
                raise scene.field_error(f"{path}.on", f"expected a table region, got {start!r}")
            blocks_ = b.get("blocks")
            block = Block(
                check_name(scene, f"{path}.name", b.get("name")),
                (sx, sy, sz),
                _color(scene, f"{path}.color", b.get("color"), (0.8, 0.3, 0.2, 1.0)),
                start,
                obstacle,
                None if blocks_ is None else check_name(scene, f"{path}.blocks", blocks_),
            )
            if block.name in {x.name for x in blocks} | set(names):
                raise scene.field_error(f"{path}.name", f"name {block.name!r} is used twice")
            if max(sx, sy) > MAX_WIDTH:
                raise scene.field_error(
                    f"{path}.size",
                    f"the open hand's pads are 5 cm apart: blocks up to {MAX_WIDTH * 100:.1f} cm "
                    "across fit between them",
                )
            blocks.append(block)
    targets = {b.name for b in blocks if not b.obstacle}
    if not targets:
        raise scene.field_error("blocks", "expected at least one block")
    blocked: set[str] = set()
    for i, ob in enumerate(x for x in blocks if x.obstacle):
        if ob.blocks is not None:
            if ob.blocks not in targets:
                raise scene.field_error(f"obstacles[{i}].blocks", f"no block {ob.blocks!r}")
            if ob.blocks in blocked:
                raise scene.field_error(f"obstacles[{i}].blocks", f"{ob.blocks} is blocked twice")
            blocked.add(ob.blocks)
    s = scene.data.get("spawn", {})
    spawn_raw = _object(scene, "spawn", s)
    spawn = Spawn(
        _number(scene, "spawn.margin", spawn_raw.get("margin", 0.01)),
        _number(scene, "spawn.min_gap", spawn_raw.get("min_gap", 0.05)),
        _number(scene, "spawn.blocker_gap", spawn_raw.get("blocker_gap", 0.005)),
        _number(scene, "spawn.max_yaw", spawn_raw.get("max_yaw", math.pi / 4)),
        _number(scene, "spawn.obstacle_clearance", spawn_raw.get("obstacle_clearance", 0.12)),
    )
    geometry = PandaGeometry(table, tuple(regions), tuple(blocks), spawn)
    try:
        geometry.initial_poses(0)
    except ValueError as err:
        raise SceneError(f"{scene.source}: spawn: {err}") from None
    return geometry


def _check_region(scene: Scene, path: str, region: Region, table: Table) -> None:
    xmin, xmax, ymin, ymax = region.footprint()
    w = region.wall
    txmin, tymin = table.center[0] - table.size[0] / 2, table.center[1] - table.size[1] / 2
    txmax, tymax = txmin + table.size[0], tymin + table.size[1]
    if xmin - w < txmin or xmax + w > txmax or ymin - w < tymin or ymax + w > tymax:
        raise scene.field_error(path, f"{region.name} is not on the table")
    near = min(math.hypot(x, y) for x in (xmin, xmax) for y in (ymin, ymax))
    far = max(math.hypot(x, y) for x in (xmin, xmax) for y in (ymin, ymax))
    if xmin < 0.2 and xmax > -0.2 and ymin < 0.2 and ymax > -0.2:
        raise scene.field_error(path, f"{region.name} is under the robot's base")
    if far > REACH[1] + 0.1 or near < REACH[0] - 0.15:
        raise scene.field_error(
            path,
            f"{region.name} spans {near:.2f} to {far:.2f} m from the robot; the hand reaches "
            f"{REACH[0]:.2f} to {REACH[1]:.2f} m",
        )


def _overlap(a: Region, b: Region) -> bool:
    ax0, ax1, ay0, ay1 = a.footprint()
    bx0, bx1, by0, by1 = b.footprint()
    m = a.wall + b.wall
    return ax0 - m < bx1 and bx0 - m < ax1 and ay0 - m < by1 and by0 - m < ay1

"""The samplers of the 2-D pick-and-place, written as a PDDLStream user writes primitives:
functions of a problem that return generators, functions and tests over numpy values. Nothing
here imports the planner; ``domain.py`` turns them into a stream map with PDDLStream's adapters.

Coordinates: x along the table, y up. A block of width ``w`` and height ``h`` at pose
``p = [x, 0]`` stands on the table centred at x. The gripper holds it from above: at
``q = p + [g, h + GRIP]`` for a grasp offset ``g``. The arm's base is at ``BASE_X``; it reaches
configurations within ``reach`` of it along the table.
"""

from __future__ import annotations

import itertools
import math
import random
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

GRIP = 0.5  # the gripper's height above the block it holds
TRAVEL_Y = 4.0  # the height the gripper travels at between configurations
GRASP_FRACTIONS = (0.0, -0.25, 0.25)  # grasp offsets, in block widths


@dataclass(frozen=True)
class Block:
    name: str
    width: float
    height: float


@dataclass(frozen=True)
class World:
    """What the samplers need to know of a scene."""

    regions: Mapping[str, tuple[float, float]]  # name -> (x min, x max)
    blocks: Mapping[str, Block]
    base_x: float
    reach: float
    speed: float  # of the gripper, units per second


@dataclass(frozen=True)
class Trajectory:
    """Up from ``start`` to the travel height, across, and down to ``end``; ``seconds`` is the
    time the gripper takes (what the planner counts as execution time)."""

    start: tuple[float, float]
    end: tuple[float, float]
    speed: float

    @property
    def waypoints(self) -> list[tuple[float, float]]:
        (x1, _), (x2, _) = self.start, self.end
        return [self.start, (x1, TRAVEL_Y), (x2, TRAVEL_Y), self.end]

    @property
    def length(self) -> float:
        pts = self.waypoints
        return sum(math.dist(a, b) for a, b in itertools.pairwise(pts))

    @property
    def seconds(self) -> float:
        return self.length / self.speed


def get_pose_gen(world: World, rng: random.Random) -> Callable[..., Iterator[tuple[Any, ...]]]:
    """Uniform placements of a block inside a region."""

    def gen(b: str, r: str) -> Iterator[tuple[Any, ...]]:
        lo, hi = world.regions[r]
        w = world.blocks[b].width
        if hi - lo < w:
            return
        while True:
            yield (np.array([rng.uniform(lo + w / 2, hi - w / 2), 0.0]),)

    return gen


def get_grasps(world: World) -> Callable[[str], list[tuple[float]]]:
    def grasps(b: str) -> list[tuple[float]]:
        return [(f * world.blocks[b].width,) for f in GRASP_FRACTIONS]

    return grasps


def get_ik_fn(world: World) -> Callable[..., tuple[Any, ...] | None]:
    def ik(b: str, p: Any, g: float) -> tuple[Any, ...] | None:
        q = np.array([p[0] + g, p[1] + world.blocks[b].height + GRIP])
        if abs(q[0] - world.base_x) > world.reach:
            return None  # out of reach
        return (q,)

    return ik


def get_motion_fn(world: World) -> Callable[..., tuple[Trajectory]]:
    def motion(q1: Any, q2: Any) -> tuple[Trajectory]:
        start = (float(q1[0]), float(q1[1]))
        end = (float(q2[0]), float(q2[1]))
        return (Trajectory(start, end, world.speed),)

    return motion


def get_cfree_test(world: World) -> Callable[..., bool]:
    def cfree(b1: str, p1: Any, b2: str, p2: Any) -> bool:
        if b1 == b2:
            return True
        gap = abs(float(p1[0]) - float(p2[0]))
        return gap >= (world.blocks[b1].width + world.blocks[b2].width) / 2

    return cfree


def distance_fn(q1: Sequence[float], q2: Sequence[float]) -> float:
    return float(np.linalg.norm(np.asarray(q2) - np.asarray(q1)))

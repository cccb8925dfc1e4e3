"""The samplers of the grid TAMP, written as a PDDLStream user writes primitives: functions of a
world that return generators, functions and tests over numpy values, and trajectories that are
plain Python lists of cells. Nothing here imports the planner; ``domain.py`` turns them into a
stream map with PDDLStream's adapters.

Cells are integer numpy arrays ``[x, y]``. The gripper's configuration over a cell is
``[x, y, 1]`` (one level up); the arm stands at ``base`` and reaches configurations within
``reach`` cells of it (Manhattan distance). A path visits the cells between two configurations,
first along x, then along y.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

UP = np.array([0, 0, 1])  # a configuration is its cell, one level up


@dataclass(frozen=True)
class World:
    """What the samplers need to know of a scene."""

    width: int  # cells along x
    height: int  # cells along y
    base: tuple[int, int]  # the cell the arm stands on
    reach: int  # cells (Manhattan) the arm reaches from its base
    seconds_per_cell: float  # how long the gripper takes from one cell to the next


def get_pose_gen(world: World, rng: random.Random) -> Callable[[], Iterator[tuple[Any, ...]]]:
    """Cells of the grid, drawn uniformly (they may be taken or out of reach: the tests say)."""

    def gen() -> Iterator[tuple[Any, ...]]:
        while True:
            yield (np.array([rng.randrange(world.width), rng.randrange(world.height)]),)

    return gen


def get_ik_fn(world: World) -> Callable[[Any], tuple[Any, ...] | None]:
    def ik(p: Any) -> tuple[Any, ...] | None:
        if np.abs(p - np.array(world.base)).sum() > world.reach:
            return None  # out of reach
        return (np.append(p, 0) + UP,)

    return ik


def get_motion_fn(world: World) -> Callable[[Any, Any], tuple[list[Any]]]:
    def plan_motion(q1: Any, q2: Any) -> tuple[list[Any]]:
        path = [q1]
        step = np.array([np.sign(q2[0] - q1[0]), 0, 0])
        while path[-1][0] != q2[0]:
            path.append(path[-1] + step)
        step = np.array([0, np.sign(q2[1] - q1[1]), 0])
        while path[-1][1] != q2[1]:
            path.append(path[-1] + step)
        return (path,)

    return plan_motion


def collision_test(p1: Any, p2: Any) -> bool:
    return bool(np.array_equal(p1, p2))


def path_seconds(world: World, path: list[Any]) -> float:
    """How long the gripper takes along a path."""
    return (len(path) - 1) * world.seconds_per_cell


def distance_fn(q1: Any, q2: Any) -> float:
    return float(np.abs(q2 - q1).sum())

"""The samplers of the tiny PDDLStream-style domain, written as a PDDLStream user writes them:
generator functions, plain functions and tests over Python values, with no import of this
project; ``domain.py`` maps them to streams with PDDLStream's adapters."""

from __future__ import annotations

import random
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

REACH = 9.0  # the arm reaches positions up to here
OBSTACLE = (3.0, 3.6)  # gripper positions inside are blocked


def get_pose_gen(
    regions: Mapping[str, tuple[float, float]],
    widths: Mapping[str, float],
    rng: random.Random,
    calls: list[tuple[str, list[tuple[Any, ...]]]],
) -> Any:
    def gen(
        b: str, r: str, fluents: Sequence[tuple[Any, ...]] = ()
    ) -> Iterator[tuple[float] | None]:
        calls.append((b, list(fluents)))
        lo, hi = regions[r]
        w = widths[b]
        placed = [(o, p) for name, o, p in fluents if name == "atpose" and o != b]
        while True:
            p = rng.uniform(lo + w / 2, hi - w / 2)
            if all(abs(p - p2) >= (w + widths[o]) / 2 for o, p2 in placed):
                yield (p,)
            else:
                yield None  # nothing this time; ask again

    return gen


def get_grasps(b: str) -> list[tuple[float]]:
    return [(0.0,), (0.25,)]


def inverse_kinematics(b: str, p: float, g: float) -> tuple[float]:
    return (p + g,)


def reachable(q: float) -> bool:
    return abs(q) <= REACH


def blocked(q: float) -> bool:
    return OBSTACLE[0] <= q <= OBSTACLE[1]


def distance(q1: float, q2: float) -> float:
    return abs(q1 - q2)

"""The samplers of the blocksworld, written as a PDDLStream user writes primitives: plain
functions over the scene's blocks and slots. Nothing here imports the planner; ``domain.py``
turns them into a stream map with PDDLStream's adapters.

Geometry: slots are places on the table at ``x``; a block stands in a slot or on another block.
A support's column is the slot at the bottom of its stack, its top the height of the stack. The
arm lifts a block from its support to the travel height, carries it across and sets it down; it
cannot carry a block whose weight times its distance from the base exceeds ``moment``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

PICK_S = 1.0  # seconds to grasp and to let go, per carry


@dataclass(frozen=True)
class Block:
    name: str
    width: float
    height: float
    weight: float
    fragile: bool


@dataclass(frozen=True)
class World:
    slots: Mapping[str, tuple[float, float]]  # name -> (x, width)
    blocks: Mapping[str, Block]
    base_x: float
    moment: float  # the heaviest weight times distance the arm holds
    speed: float  # units per second
    travel_y: float


@dataclass(frozen=True)
class Carry:
    """A block lifted from ``start`` (its base there) to the travel height, across, and down to
    ``end``; ``seconds`` is what the arm takes."""

    block: str
    start: tuple[float, float]
    end: tuple[float, float]
    travel_y: float
    speed: float

    @property
    def waypoints(self) -> list[tuple[float, float]]:
        (x1, _), (x2, _) = self.start, self.end
        return [self.start, (x1, self.travel_y), (x2, self.travel_y), self.end]

    @property
    def seconds(self) -> float:
        pts = self.waypoints
        length = sum(math.dist(a, b) for a, b in itertools.pairwise(pts))
        return PICK_S + length / self.speed


def get_stackable_test(world: World) -> Callable[[str, str], bool]:
    def stackable(b: str, y: str) -> bool:
        top, bottom = world.blocks[b], world.blocks[y]
        return b != y and top.width <= bottom.width and not bottom.fragile

    return stackable


def get_fits_test(world: World) -> Callable[[str, str], bool]:
    def fits(b: str, s: str) -> bool:
        return world.blocks[b].width <= world.slots[s][1]

    return fits


def column_and_top(world: World, on: Mapping[str, str], support: str) -> tuple[float, float]:
    """The x of ``support``'s stack and the height of its top."""
    top = 0.0
    seen: set[str] = set()
    while support in world.blocks:
        if support in seen or support not in on:
            raise ValueError(f"block {support} stands on nothing")
        seen.add(support)
        top += world.blocks[support].height
        support = on[support]
    return world.slots[support][0], top


def get_carry_fn(world: World) -> Callable[..., tuple[Carry] | None]:
    def carry(
        b: str, x: str, y: str, fluents: Sequence[tuple[Any, ...]] = ()
    ) -> tuple[Carry] | None:
        on = {str(f[1]): str(f[2]) for f in fluents if f[0] == "on"}
        if on.get(b) != x:
            return None  # the block is not on ?x in this state
        x1, y1 = column_and_top(world, on, x)
        x2, y2 = column_and_top(world, on, y)
        reach = max(abs(x1 - world.base_x), abs(x2 - world.base_x))
        if world.blocks[b].weight * reach > world.moment:
            return None  # too heavy to hold that far out
        return (Carry(b, (x1, y1), (x2, y2), world.travel_y, world.speed),)

    return carry


def moves(world: World, on: Mapping[str, str]) -> list[tuple[str, str]]:
    """Every (block, destination) the arm can carry from the stacks ``on``: the rules of the
    streams above, for the scene reader's check that a start can reach the goal."""
    covered = set(on.values())
    stackable, fits, carry = get_stackable_test(world), get_fits_test(world), get_carry_fn(world)
    fluents = [("on", b, x) for b, x in on.items()]
    found = []
    for b in world.blocks:
        if b in covered:
            continue
        for y in [*world.slots, *world.blocks]:
            if y in covered or y in (b, on[b]):
                continue
            ok = stackable(b, y) if y in world.blocks else fits(b, y)
            if ok and carry(b, on[b], y, fluents) is not None:
                found.append((b, y))
    return found


def fewest_moves(
    world: World,
    on: Mapping[str, str],
    goal: Sequence[tuple[str, str]],
    most: int = 20,
    limit: int = 100_000,
) -> int | None:
    """The fewest carries from ``on`` to a state with every goal ``(block, support)``; ``None``
    when no plan of at most ``most`` carries reaches it (or more than ``limit`` states would
    have to be searched)."""
    start = tuple(sorted(on.items()))
    frontier, seen, depth = [start], {start}, 0
    while frontier and depth <= most:
        following = []
        for state in frontier:
            here = dict(state)
            if all(here.get(b) == y for b, y in goal):
                return depth
            for b, y in moves(world, here):
                nxt = tuple(sorted({**here, b: y}.items()))
                if nxt not in seen:
                    seen.add(nxt)
                    following.append(nxt)
            if len(seen) > limit:
                return None
        frontier, depth = following, depth + 1
    return None

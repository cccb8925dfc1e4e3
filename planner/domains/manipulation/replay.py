"""What a manipulation domain's validator shares: the replay's state (where the plan has put the
blocks, the block in the hand, the seconds its moves take), the world set to it, the values a
plan's actions name, and the points checked along a path."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any, Generic, TypeVar

from planner.abstract.skeleton import GroundAction
from planner.domains.manipulation.problem import UprightPose
from planner.domains.manipulation.samplers import stage
from planner.domains.manipulation.world import BlocksWorld
from planner.pddl.structs import Problem
from planner.sim.transforms import wrap_angle

W = TypeVar("W", bound=BlocksWorld[Any])  # a domain's world
P = TypeVar("P", bound=UprightPose)  # its block pose
G = TypeVar("G")  # its grasp
T = TypeVar("T")


def plan_values(problem: Problem, values: Mapping[str, Any]) -> dict[str, Any]:
    """What each name a plan's actions use stands for: the problem's objects themselves, then
    the problem's values, then the plan's."""
    named: dict[str, Any] = {o.name: o.name for o in problem.objects}
    named.update(problem.values)
    named.update(values)
    return named


def start_value(problem: Problem, name: str, kind: type[T]) -> T:
    """The problem's start configuration ``name``, which must be a ``kind``."""
    value = problem.values.get(name)
    if not isinstance(value, kind):
        raise ValueError(f"the problem has no start configuration {name}")
    return value


def path_points(
    path: Sequence[Sequence[float]], step: float, *, yaw_last: bool = False
) -> list[tuple[float, ...]]:
    """Points along a piecewise-linear path, at most ``step`` apart in every coordinate.

    Arm paths are straight in joint space (OMPL plans in R^7); a base path's last coordinate is
    the yaw, which turns the short way round (``yaw_last``).
    """
    out: list[tuple[float, ...]] = []
    for a, b in itertools.pairwise(path):
        d = [y - x for x, y in zip(a, b, strict=True)]
        if yaw_last:
            d[-1] = wrap_angle(d[-1])
        n = max(1, math.ceil(max(abs(x) for x in d) / step))
        out += [tuple(x + i / n * dx for x, dx in zip(a, d, strict=True)) for i in range(n)]
    out.append(tuple(path[-1]))
    return out


class Replay(Generic[W, P, G]):
    """A plan being replayed in ``world``: the blocks stand where the problem's ``at-pose``
    facts put them (poses of ``pose_type``) until an action moves them, the hand holds nothing
    yet, and no move has taken a second."""

    def __init__(self, world: W, problem: Problem, pose_type: type[P]) -> None:
        self.world = world
        self.problem = problem
        self.poses: dict[str, P] = {}
        for atom in problem.init:
            if atom.predicate == "at-pose":
                value = problem.values.get(atom.args[1])
                if isinstance(value, pose_type):
                    self.poses[atom.args[0]] = value
        self.held: tuple[str, G] | None = None  # the block in the hand and its grasp
        self.seconds = 0.0

    def step(self, i: int, actions: Sequence[GroundAction], args: list[Any]) -> str | None:
        """Replay action ``i`` of ``actions`` with its arguments' values: why it fails, or None
        (the domain's actions)."""
        raise NotImplementedError

    def play(
        self, actions: Sequence[GroundAction], values: Mapping[str, Any]
    ) -> tuple[int, str] | None:
        """Replay the actions in order, with the plan's ``values``, until one fails: its index
        and a message that names it and says why (None: none fails)."""
        named = plan_values(self.problem, values)
        for i, act in enumerate(actions):
            try:
                args = [named[a] for a in act.args]
            except KeyError as exc:
                return i, f"step {i} {act}: no value for {exc.args[0]}"
            err = self.step(i, actions, args)
            if err is not None:
                return i, f"step {i} {act}: {err}"
        return None

    def cannot_pick(self, block: str, pose: P) -> str | None:
        """Why ``block`` cannot be picked from ``pose`` as things stand (the hand is full, or the
        block stands elsewhere); None if it can."""
        if self.held is not None:
            return f"the hand already holds {self.held[0]}"
        if self.poses.get(block) != pose:
            return f"{block} is not at the pose to pick it from"
        return None

    def not_holding(self, block: str) -> str | None:
        """Why ``block`` cannot be put down: the hand does not hold it (None: it does)."""
        if self.held is None or self.held[0] != block:
            return f"the hand does not hold {block}"
        return None

    def picked(self, block: str, grasp: G) -> None:
        """``block`` is in the hand, held by ``grasp``."""
        del self.poses[block]
        self.held = (block, grasp)

    def placed(self, block: str, pose: P) -> None:
        """``block`` stands at ``pose``, the hand empty."""
        self.held = None
        self.poses[block] = pose

    def stage(self) -> None:
        """The world's blocks where they stand now, the held one in the hand."""
        stage(self.world, self.poses, self.held)

    def put_down(self, block: str, pose: P) -> None:
        """The world with the held ``block`` let go of at ``pose`` (the replay's state is the
        caller's to change once the placement is checked)."""
        self.world.hold(None)
        self.world.set_blocks({**self.poses, block: pose})

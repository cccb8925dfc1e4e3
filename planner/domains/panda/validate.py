"""Replay a bound Panda plan in pybullet and report the first violated condition.

The replay starts from the scene's start (the seeded block poses, the arm at its start
configuration) and checks each action against the geometry, not against what the samplers
promised: a ``move`` must start where the arm is and end at its target, and every 0.02 rad of its
joint path (the straight moves down and up included) must be free of collisions with what the
hand holds; a ``pick`` needs the hand empty, the block at the pose and the tool on it by the
grasp; a ``place`` needs the block in the hand, its pose inside the region and clear of the
other blocks. At the end every ``on`` fact of the goal must hold where the blocks stand.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any

from planner.abstract.skeleton import GroundAction
from planner.domains.panda.geometry import PandaGeometry
from planner.domains.panda.problem import START_CONF, geometry_of
from planner.domains.panda.samplers import tool_target
from planner.domains.panda.values import BlockPose, Conf, Grasp, Trajectory
from planner.domains.panda.world import PENETRATION, PandaWorld
from planner.domains.spec import PlanCheck
from planner.pddl.structs import Problem
from planner.robots.panda.model import duration, within_limits
from planner.sim.transforms import angle_between

POSITION_TOLERANCE = 0.005  # metres between where the tool is and where the grasp puts it
ANGLE_TOLERANCE = 0.03  # radians, likewise (the hand is symmetric: either way round counts)
ARM_STEP = 0.02  # radians between collision checks along joint paths
SAME = 1e-6  # radians: two configurations this close are the same


def _same(a: Sequence[float], b: Sequence[float]) -> bool:
    return max(abs(x - y) for x, y in zip(a, b, strict=True)) < SAME


def _points(path: Sequence[Sequence[float]], step: float) -> list[tuple[float, ...]]:
    """Points along a joint path, at most ``step`` apart in every joint."""
    out: list[tuple[float, ...]] = []
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(max(abs(y - x) for x, y in zip(a, b, strict=True)) / step))
        out += [tuple(x + i / n * (y - x) for x, y in zip(a, b, strict=True)) for i in range(n)]
    out.append(tuple(path[-1]))
    return out


class _Replay:
    def __init__(self, world: PandaWorld, geometry: PandaGeometry, problem: Problem) -> None:
        self.world = world
        self.geometry = geometry
        self.poses: dict[str, BlockPose] = {}
        for atom in problem.init:
            if atom.predicate == "at-pose":
                value = problem.values.get(atom.args[1])
                if isinstance(value, BlockPose):
                    self.poses[atom.args[0]] = value
        start = problem.values.get(START_CONF)
        if not isinstance(start, Conf):
            raise ValueError(f"the problem has no start configuration {START_CONF}")
        self.arm: tuple[float, ...] = start.arm
        self.held: tuple[str, Grasp] | None = None
        self.seconds = 0.0

    def _sync(self, arm: Sequence[float]) -> None:
        self.world.hold(None)
        self.world.set_blocks(self.poses)
        if self.held is not None:
            self.world.hold(*self.held)
        self.world.set_arm(arm)

    def move(self, q1: Conf, q2: Conf, traj: Trajectory) -> str | None:
        if not _same(self.arm, q1.arm) or not _same(traj.path[0], q1.arm):
            return "the trajectory does not start where the arm is"
        if not _same(traj.path[-1], q2.arm):
            return "the trajectory does not end at the target configuration"
        held = self.held[0] if self.held else None
        if traj.holding != held:
            return f"the trajectory carries {traj.holding}, the hand holds {held}"
        points = _points(traj.path, ARM_STEP)
        for i, arm in enumerate(points):
            if not within_limits(arm):
                return f"point {i} of {len(points)} is outside the joint limits"
            self._sync(arm)
            if self.world.robot_collides():
                return f"collision at point {i} of {len(points)} of the trajectory"
        self.seconds += duration(traj.path)
        self.arm = q2.arm
        return None

    def reaches(self, block: str, pose: BlockPose, grasp: Grasp, conf: Conf) -> str | None:
        if not _same(self.arm, conf.arm):
            return "the arm is not at the grasp configuration"
        self._sync(conf.arm)
        have = self.world.tool_pose()
        misses = []
        for flip in (False, True):
            want = tool_target(pose, grasp, flip=flip)
            miss = math.dist(want[0], have[0])
            if miss <= POSITION_TOLERANCE and angle_between(want[1], have[1]) <= ANGLE_TOLERANCE:
                return None
            misses.append(miss)
        return f"the hand misses {block} by {min(misses) * 100:.1f} cm"

    def inside(self, block: str, pose: BlockPose, region: str) -> str | None:
        size = self.geometry.block(block).size
        if not self.geometry.region(region).contains(pose, size):
            return f"{block} at ({pose.x:.3f}, {pose.y:.3f}, {pose.z:.3f}) is not in {region}"
        return None


def validate_plan(
    actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
) -> PlanCheck:
    """Replay ``actions`` with the bound ``values`` from the problem's start."""
    geometry = geometry_of(problem)
    allv: dict[str, Any] = {o.name: o.name for o in problem.objects}
    allv.update(problem.values)
    allv.update(values)
    with PandaWorld(geometry) as world:
        r = _Replay(world, geometry, problem)
        for step, act in enumerate(actions):
            try:
                args = [allv[a] for a in act.args]
            except KeyError as exc:
                return PlanCheck(False, f"step {step} {act}: no value for {exc.args[0]}", r.seconds)
            err = _step(r, act.name, args)
            if err is not None:
                return PlanCheck(False, f"step {step} {act}: {err}", r.seconds)
        for lit in problem.goal:
            atom = lit.atom
            if atom.predicate != "on":
                continue
            block, region = atom.args
            pose = r.poses.get(block)
            err = f"{block} is in the hand" if pose is None else r.inside(block, pose, region)
            if lit.positive != (err is None):
                return PlanCheck(False, f"goal {atom}: {err or 'holds'}", r.seconds)
        return PlanCheck(True, "valid (replayed in pybullet)", r.seconds)


def _step(r: _Replay, name: str, args: list[Any]) -> str | None:
    if name == "move":
        q1, q2, traj = args
        if not (isinstance(q1, Conf) and isinstance(q2, Conf) and isinstance(traj, Trajectory)):
            return "expected two configurations and a trajectory"
        return r.move(q1, q2, traj)
    if name in ("pick", "pick-obstacle"):
        block, pose, _region, grasp, conf = args[1:] if name == "pick-obstacle" else args
        if name == "pick-obstacle":
            block = args[0]
        if not (
            isinstance(pose, BlockPose) and isinstance(grasp, Grasp) and isinstance(conf, Conf)
        ):
            return "expected a pose, a grasp and a configuration"
        if r.held is not None:
            return f"the hand already holds {r.held[0]}"
        if r.poses.get(block) != pose:
            return f"{block} is not at the pose to pick it from"
        err = r.reaches(block, pose, grasp, conf)
        if err is None:
            del r.poses[block]
            r.held = (block, grasp)
        return err
    if name == "place":
        block, pose, region, grasp, conf = args
        if not (
            isinstance(pose, BlockPose) and isinstance(grasp, Grasp) and isinstance(conf, Conf)
        ):
            return "expected a pose, a grasp and a configuration"
        if r.held is None or r.held[0] != block:
            return f"the hand does not hold {block}"
        err = r.inside(block, pose, region) or r.reaches(block, pose, grasp, conf)
        if err is None:
            r.world.hold(None)
            r.world.set_blocks({**r.poses, block: pose})
            if r.world.block_collides(block, margin=PENETRATION):
                return f"{block} overlaps another block or a rim in {region}"
            r.held = None
            r.poses[block] = pose
        return err
    return f"unknown action {name!r}"

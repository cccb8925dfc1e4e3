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

import math
from collections.abc import Mapping, Sequence
from typing import Any

from planner.abstract.skeleton import GroundAction
from planner.domains.manipulation.replay import Replay, path_points, start_value
from planner.domains.manipulation.world import PENETRATION
from planner.domains.panda.geometry import PandaGeometry
from planner.domains.panda.problem import START_CONF, geometry_of
from planner.domains.panda.samplers import tool_target
from planner.domains.panda.values import BlockPose, Conf, Grasp, Trajectory
from planner.domains.panda.world import PandaWorld
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


class _Replay(Replay[PandaWorld, BlockPose, Grasp]):
    def __init__(self, world: PandaWorld, geometry: PandaGeometry, problem: Problem) -> None:
        super().__init__(world, problem, BlockPose)
        self.geometry = geometry
        self.arm: tuple[float, ...] = start_value(problem, START_CONF, Conf).arm

    def step(self, i: int, actions: Sequence[GroundAction], args: list[Any]) -> str | None:
        name = actions[i].name
        if name == "move":
            q1, q2, traj = args
            if not (isinstance(q1, Conf) and isinstance(q2, Conf) and isinstance(traj, Trajectory)):
                return "expected two configurations and a trajectory"
            return self.move(q1, q2, traj)
        if name not in ("pick", "pick-obstacle", "place"):
            return f"unknown action {name!r}"
        # pick-obstacle names the target it frees before the obstacle's pose.
        block, pose, region, grasp, conf = args[1:] if name == "pick-obstacle" else args
        block = args[0]
        if not (
            isinstance(pose, BlockPose) and isinstance(grasp, Grasp) and isinstance(conf, Conf)
        ):
            return "expected a pose, a grasp and a configuration"
        if name == "place":
            return self.not_holding(block) or self._place(block, pose, region, grasp, conf)
        err = self.cannot_pick(block, pose) or self.reaches(block, pose, grasp, conf)
        if err is None:
            self.picked(block, grasp)
        return err

    def _place(
        self, block: str, pose: BlockPose, region: str, grasp: Grasp, conf: Conf
    ) -> str | None:
        """The block inside the region, the hand on it, and clear of the other blocks and the
        rims once let go of."""
        err = self.inside(block, pose, region) or self.reaches(block, pose, grasp, conf)
        if err is None:
            self.put_down(block, pose)
            if self.world.block_collides(block, margin=PENETRATION):
                return f"{block} overlaps another block or a rim in {region}"
            self.placed(block, pose)
        return err

    def _sync(self, arm: Sequence[float]) -> None:
        self.stage()
        self.world.set_arm(arm)

    def move(self, q1: Conf, q2: Conf, traj: Trajectory) -> str | None:
        if not _same(self.arm, q1.arm) or not _same(traj.path[0], q1.arm):
            return "the trajectory does not start where the arm is"
        if not _same(traj.path[-1], q2.arm):
            return "the trajectory does not end at the target configuration"
        held = self.held[0] if self.held else None
        if traj.holding != held:
            return f"the trajectory carries {traj.holding}, the hand holds {held}"
        points = path_points(traj.path, ARM_STEP)
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
    with PandaWorld(geometry_of(problem)) as world:
        r = _Replay(world, world.geometry, problem)
        failed = r.play(actions, values)
        if failed is not None:
            return PlanCheck(False, failed[1], r.seconds)
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

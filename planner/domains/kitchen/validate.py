"""Replay a bound kitchen plan in pybullet and report the first violated condition."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from planner.abstract.skeleton import GroundAction
from planner.domains.kitchen.geometry import BlockPose, KitchenGeometry
from planner.domains.kitchen.problem import ARM, START_CONF, geometry_of
from planner.domains.kitchen.values import Conf, Grasp, Trajectory
from planner.domains.kitchen.world import KitchenWorld
from planner.domains.manipulation.problem import block_pose_to_pose
from planner.domains.manipulation.replay import Replay, path_points, start_value
from planner.pddl.structs import Problem
from planner.sim.transforms import angle_between, multiply, wrap_angle

POSITION_TOLERANCE = 0.01  # metres between where the tool is and where the grasp puts it
ANGLE_TOLERANCE = 0.05  # radians, likewise
ARM_STEP = 0.05  # radians between collision checks along arm paths
BASE_STEP = 0.02  # metres (and radians / 2) between collision checks along base paths


@dataclass(frozen=True)
class ValidationReport:
    ok: bool
    step: int | None  # index of the failing action (len(actions) for the goal)
    message: str
    execution_s: float  # duration of the plan's trajectories (up to the failure)


def _same_conf(a: Conf, b: Conf) -> bool:
    return (
        math.dist(a.base[:2], b.base[:2]) < 1e-6
        and abs(wrap_angle(a.base[2] - b.base[2])) < 1e-6
        and max(abs(x - y) for x, y in zip(a.arm, b.arm, strict=True)) < 1e-6
    )


class _Replay(Replay[KitchenWorld, BlockPose, Grasp]):
    def __init__(self, world: KitchenWorld, geometry: KitchenGeometry, problem: Problem) -> None:
        super().__init__(world, problem, BlockPose)
        self.geometry = geometry
        self.conf = start_value(problem, START_CONF, Conf)
        self.cleaned: set[str] = set()
        self.cooked: set[str] = set()
        self.last_block: str | None = None  # of the last pick, place or cook

    def step(self, i: int, actions: Sequence[GroundAction], args: list[Any]) -> str | None:
        if i and actions[i - 1].name in ("pick", "place", "cook"):
            self.last_block = actions[i - 1].args[0]
        name = actions[i].name
        if name == "move":
            q1, q2, traj = args
            nxt = actions[i + 1] if i + 1 < len(actions) else None
            next_block = nxt.args[0] if nxt is not None and nxt.name != "move" else None
            if not (isinstance(q1, Conf) and isinstance(q2, Conf) and isinstance(traj, Trajectory)):
                return "expected two configurations and a trajectory"
            return self.move(q1, q2, traj, self.last_block, next_block)
        if name == "pick":
            block, pose, _plat, grasp, conf = args
            err = self.cannot_pick(block, pose) or self._at(conf)
            err = err or self._reaches(block, pose, grasp, conf)
            if err is None:
                self.picked(block, grasp)
            return err
        if name in ("place", "cook"):
            block, pose, plat, grasp, conf = args
            err = self.not_holding(block) or self._at(conf)
            if err is None and name == "cook" and block not in self.cleaned:
                err = f"{block} is cooked before it is cleaned"
            return err or self._put(name, block, pose, plat, grasp, conf)
        if name == "clean":
            block, plat = args
            pose = self.poses.get(block)
            if pose is None or self.geometry.platform(plat).kind != "sink":
                return f"{block} is not in the sink"
            err = self.on(block, pose, plat)
            if err is None:
                self.cleaned.add(block)
            return err
        return f"unknown action {name!r}"

    def _at(self, conf: Conf) -> str | None:
        if not _same_conf(self.conf, conf):
            return "the robot is not at the grasp configuration"
        return None

    def _put(
        self, name: str, block: str, pose: BlockPose, plat: str, grasp: Grasp, conf: Conf
    ) -> str | None:
        """Place or cook: the block rests on the platform, the gripper reaches it, and it stands
        clear of the other blocks once let go of."""
        err = self.on(block, pose, plat) or self._reaches(block, pose, grasp, conf)
        if err is None:
            self.put_down(block, pose)
            if self.world.block_collides(block, margin=0.0):
                err = f"{block} overlaps another block on {plat}"
        if err is None:
            self.placed(block, pose)
            if name == "cook":
                self.cleaned.discard(block)
                self.cooked.add(block)
        return err

    def _sync(self, conf: Conf, *, approach: bool = False) -> None:
        self.stage()
        self.world.set_conf(conf, approach=approach)

    def _reaches(self, block: str, pose: BlockPose, grasp: Grasp, conf: Conf) -> str | None:
        self._sync(conf)
        want = multiply(block_pose_to_pose(pose), grasp.tool_in_block)
        have = self.world.tool_pose()
        miss = math.dist(want[0], have[0])
        if miss > POSITION_TOLERANCE or angle_between(want[1], have[1]) > ANGLE_TOLERANCE:
            return f"the gripper misses {block} by {miss * 100:.1f} cm at {conf.base}"
        if self.world.robot_collides(ignore=(block,)):
            return f"the robot collides while grasping {block}"
        if conf.approach_arm is not None:
            self._sync(conf, approach=True)
            if self.world.robot_collides(ignore=(block,) if self.held else ()):
                return f"the robot collides in the approach pose for {block}"
        return None

    def move(
        self, q1: Conf, q2: Conf, traj: Trajectory, last_block: str | None, next_block: str | None
    ) -> str | None:
        if not _same_conf(self.conf, q1) or not _same_conf(traj.start, q1):
            return "the trajectory does not start where the robot is"
        if not _same_conf(traj.end, q2):
            return "the trajectory does not end at the target configuration"
        held = self.held[0] if self.held else None
        if traj.holding != held:
            return f"the trajectory carries {traj.holding}, the hand holds {held}"
        for j, seg in enumerate(traj.segments):
            straight = seg.kind == "arm" and len(seg.arm) == 2
            # Retreating from the last block or approaching the next one, the gripper touches it.
            near = (held, last_block, next_block)
            ignore = tuple(b for b in near if b is not None) if straight else ()
            if seg.kind == "arm":
                base = seg.base[0]
                points = path_points(seg.arm, ARM_STEP)
                confs = [Conf(base, q1.torso, a) for a in points]
            else:
                arm = seg.arm[0]
                points = path_points(seg.base, BASE_STEP, yaw_last=True)
                confs = [Conf((b[0], b[1], b[2]), q1.torso, arm) for b in points]
            for i, conf in enumerate(confs):
                self._sync(conf)
                if self.world.robot_collides(ignore=ignore):
                    return f"collision in segment {j} ({seg.kind}) at point {i} of {len(confs)}"
            self.seconds += seg.seconds
        self.conf = q2
        return None

    def on(self, block: str, pose: BlockPose, platform: str) -> str | None:
        plat = self.geometry.platform(platform)
        xmin, xmax, ymin, ymax = plat.footprint()
        size = self.geometry.block(block).size
        if not (xmin <= pose.x <= xmax and ymin <= pose.y <= ymax):
            return f"{block} at ({pose.x:.3f}, {pose.y:.3f}) is not over {platform}"
        if abs(pose.z - (plat.top + size / 2)) > 1e-3:
            return f"{block} does not rest on {platform} (z = {pose.z:.3f})"
        return None


def validate_plan(
    actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
) -> ValidationReport:
    """Replay ``actions`` with the bound ``values`` from the problem's initial state."""
    geometry = geometry_of(problem)
    with KitchenWorld(geometry, ARM) as world:
        r = _Replay(world, geometry, problem)
        failed = r.play(actions, values)
        if failed is not None:
            return ValidationReport(False, *failed, r.seconds)
        for lit in problem.goal:
            if lit.atom.predicate == "cooked" and lit.atom.args[0] not in r.cooked:
                return ValidationReport(
                    False, len(actions), f"goal: {lit.atom.args[0]} is not cooked", r.seconds
                )
        return ValidationReport(True, None, "valid", r.seconds)

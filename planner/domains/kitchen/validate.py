"""Replay a bound kitchen plan in pybullet and report the first violated condition."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from planner.abstract.skeleton import GroundAction
from planner.domains.kitchen.geometry import BlockPose, KitchenGeometry, block_pose_to_pose
from planner.domains.kitchen.problem import GEOMETRY_KEY
from planner.domains.kitchen.values import Conf, Grasp, Trajectory
from planner.domains.kitchen.world import KitchenWorld
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


def _interpolate(
    path: Sequence[Sequence[float]], step: float, *, yaw_last: bool = False
) -> list[tuple[float, ...]]:
    """Points along a piecewise-linear path, at most ``step`` apart in every coordinate.

    Arm paths are straight in joint space (OMPL plans in R^7); a base path's last coordinate is
    the yaw, which turns the short way round (``yaw_last``).
    """

    def delta(a: Sequence[float], b: Sequence[float]) -> list[float]:
        d = [y - x for x, y in zip(a, b, strict=True)]
        if yaw_last:
            d[-1] = wrap_angle(d[-1])
        return d

    out: list[tuple[float, ...]] = []
    for a, b in itertools.pairwise(path):
        d = delta(a, b)
        n = max(1, math.ceil(max(abs(x) for x in d) / step))
        out += [tuple(x + i / n * dx for x, dx in zip(a, d, strict=True)) for i in range(n)]
    out.append(tuple(path[-1]))
    return out


def _same_conf(a: Conf, b: Conf) -> bool:
    return (
        math.dist(a.base[:2], b.base[:2]) < 1e-6
        and abs(wrap_angle(a.base[2] - b.base[2])) < 1e-6
        and max(abs(x - y) for x, y in zip(a.arm, b.arm, strict=True)) < 1e-6
    )


class _Replay:
    def __init__(self, world: KitchenWorld, geometry: KitchenGeometry, problem: Problem) -> None:
        self.world = world
        self.geometry = geometry
        self.poses: dict[str, BlockPose] = {}
        for atom in problem.init:
            if atom.predicate == "at-pose":
                value = problem.values.get(atom.args[1])
                if isinstance(value, BlockPose):
                    self.poses[atom.args[0]] = value
        start = problem.values.get("q0")
        if not isinstance(start, Conf):
            raise ValueError("the problem has no start configuration q0")
        self.conf: Conf = start
        self.held: tuple[str, Grasp] | None = None
        self.cleaned: set[str] = set()
        self.cooked: set[str] = set()
        self.seconds = 0.0

    def _sync(self, conf: Conf, *, approach: bool = False) -> None:
        self.world.hold(None)
        self.world.set_blocks(self.poses)
        if self.held is not None:
            self.world.hold(*self.held)
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
                points = _interpolate(seg.arm, ARM_STEP)
                confs = [Conf(base, q1.torso, a) for a in points]
            else:
                arm = seg.arm[0]
                points = _interpolate(seg.base, BASE_STEP, yaw_last=True)
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
    geometry = problem.values.get(GEOMETRY_KEY)
    if not isinstance(geometry, KitchenGeometry):
        raise ValueError("validation needs a kitchen problem built from a scene")
    allv: dict[str, Any] = {o.name: o.name for o in problem.objects}
    allv.update(problem.values)
    allv.update(values)
    with KitchenWorld(geometry, "right") as world:
        r = _Replay(world, geometry, problem)

        def fail(step: int, message: str) -> ValidationReport:
            return ValidationReport(
                False, step, f"step {step} {actions[step]}: {message}", r.seconds
            )

        last_block: str | None = None
        for step, act in enumerate(actions):
            if step and actions[step - 1].name in ("pick", "place", "cook"):
                last_block = actions[step - 1].args[0]
            try:
                args = [allv[a] for a in act.args]
            except KeyError as exc:
                return fail(step, f"no value for {exc.args[0]}")
            name = act.name
            if name == "move":
                q1, q2, traj = args
                nxt = actions[step + 1] if step + 1 < len(actions) else None
                next_block = nxt.args[0] if nxt is not None and nxt.name != "move" else None
                if not (
                    isinstance(q1, Conf) and isinstance(q2, Conf) and isinstance(traj, Trajectory)
                ):
                    return fail(step, "expected two configurations and a trajectory")
                err = r.move(q1, q2, traj, last_block, next_block)
            elif name == "pick":
                block, pose, _plat, grasp, conf = args
                if r.held is not None:
                    err = f"the hand already holds {r.held[0]}"
                elif r.poses.get(block) != pose:
                    err = f"{block} is not at the pose to pick it from"
                elif not _same_conf(r.conf, conf):
                    err = "the robot is not at the grasp configuration"
                else:
                    err = r._reaches(block, pose, grasp, conf)
                    if err is None:
                        del r.poses[block]
                        r.held = (block, grasp)
            elif name in ("place", "cook"):
                block, pose, plat, grasp, conf = args
                if r.held is None or r.held[0] != block:
                    err = f"the hand does not hold {block}"
                elif not _same_conf(r.conf, conf):
                    err = "the robot is not at the grasp configuration"
                elif name == "cook" and block not in r.cleaned:
                    err = f"{block} is cooked before it is cleaned"
                else:
                    err = r.on(block, pose, plat) or r._reaches(block, pose, grasp, conf)
                    if err is None:
                        r.world.hold(None)
                        r.world.set_blocks({**r.poses, block: pose})
                        if r.world.block_collides(block, margin=0.0):
                            err = f"{block} overlaps another block on {plat}"
                    if err is None:
                        r.held = None
                        r.poses[block] = pose
                        if name == "cook":
                            r.cleaned.discard(block)
                            r.cooked.add(block)
            elif name == "clean":
                block, plat = args
                pose = r.poses.get(block)
                if pose is None or geometry.platform(plat).kind != "sink":
                    err = f"{block} is not in the sink"
                else:
                    err = r.on(block, pose, plat)
                    if err is None:
                        r.cleaned.add(block)
            else:
                err = f"unknown action {name!r}"
            if err is not None:
                return fail(step, err)
        for lit in problem.goal:
            if lit.atom.predicate == "cooked" and lit.atom.args[0] not in r.cooked:
                return ValidationReport(
                    False, len(actions), f"goal: {lit.atom.args[0]} is not cooked", r.seconds
                )
        return ValidationReport(True, None, "valid", r.seconds)

"""The kitchen in the 3D view (``DomainSpec.view``): platforms, blocks and the floor (meshes,
:mod:`planner.domains.kitchen.props`) and the generated PR2; the ghosts of sampled values; a bound
plan played by the robot.

Ghosts: a placement is a translucent block where it would stand (layer ``placements``), a grasp
the gripper around the block's initial pose (``grasps``), an IK result an arrow at the base pose
on the floor (``confs``), a motion the base's path (``motions``). A failed query is marked at its
input pose, else the configuration it was to reach, else the platform, else the block.

The plan: each ``move`` plays its trajectory's segments for their seconds (each waypoint step
takes its share in proportion to what the velocity limits make it take), ``pick`` takes the block
into the hand, ``place`` and ``cook`` put it down at their pose.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from planner.abstract.skeleton import GroundAction
from planner.domains.kitchen.geometry import BlockPose, KitchenGeometry, block_pose_to_pose
from planner.domains.kitchen.problem import ARM, GEOMETRY_KEY, initial_pose_name
from planner.domains.kitchen.props import block_shape, floor_body, platform_body
from planner.domains.kitchen.values import BaseConf, Conf, Grasp, Segment, Trajectory
from planner.pddl.structs import Problem
from planner.robots.pr2.model import (
    ARM_JOINTS,
    ARMS,
    BASE_VELOCITY,
    FINGER_TRAVEL,
    GRIPPER_JOINTS,
    REST_ARM_CONF,
    TOOL_LINK,
    TORSO_JOINT,
    URDF_PATH,
    VELOCITY_LIMITS,
)
from planner.sim.transforms import Pose, invert, multiply, planar_pose, wrap_angle
from planner.view import (
    ActionSteps,
    Body,
    BodyState,
    Focus,
    Marker,
    QueryView,
    SceneView,
    Urdf,
    Vec3,
)

T = TypeVar("T")
Held = tuple[str, Grasp]  # a block in the hand and how it is held

ROBOT = "pr2"  # the robot's body name
STILL_ACTIONS = ("clean",)  # actions that move nothing
PATH_Z = 0.02  # motion paths float this far above the floor
ARROW_Z = 0.01  # base markers too
FAILED_POSE_Z = 0.08  # a failed query about a block pose is marked this high above the block
FAILED_CONF_Z = 0.05  # one about a configuration this high over its base
FAILED_PLATFORM_Z = 0.03  # and one about a platform this far above its top face
# The gripper in its tool frame: fingers along +x reaching 3 cm past the tool point.
GRIPPER_PARTS: tuple[tuple[Vec3, Vec3], ...] = (
    ((-0.115, 0.0, 0.0), (0.13, 0.10, 0.04)),
    ((-0.01, 0.045, 0.0), (0.08, 0.012, 0.02)),
    ((-0.01, -0.045, 0.0), (0.08, 0.012, 0.02)),
)


def _geometry(problem: Problem) -> KitchenGeometry:
    geometry = problem.values.get(GEOMETRY_KEY)
    if not isinstance(geometry, KitchenGeometry):
        raise ValueError(f"problem {problem.name}: no kitchen geometry in its values")
    return geometry


def _initial(problem: Problem, geometry: KitchenGeometry) -> dict[str, BlockPose]:
    out = {}
    for block in geometry.blocks:
        pose = problem.values.get(initial_pose_name(block.name))
        if isinstance(pose, BlockPose):
            out[block.name] = pose
    return out


def robot_joints(torso: float, arm: Sequence[float], gripper: float) -> dict[str, float]:
    """The PR2's joint values: the working arm as given, the other tucked, fingers open by
    ``gripper`` each."""
    joints = {
        joint: value
        for side in ARMS
        if side != ARM
        for joint, value in zip(ARM_JOINTS[side], REST_ARM_CONF[side], strict=True)
    }
    joints[TORSO_JOINT] = torso
    joints.update(zip(ARM_JOINTS[ARM], arm, strict=True))
    joints.update((joint, gripper) for joint in GRIPPER_JOINTS[ARM])
    return joints


class KitchenView:
    """The kitchen's :class:`~planner.view.DomainView`."""

    def scene(self, problem: Problem) -> SceneView:
        geometry = _geometry(problem)
        robot = (geometry.robot.base[0], geometry.robot.base[1])
        bodies = [platform_body(plat, robot) for plat in geometry.platforms]
        for block in geometry.blocks:
            pose = _initial(problem, geometry).get(block.name)
            position, quat = block_pose_to_pose(pose) if pose else ((0.0, 0.0, 0.0), (0, 0, 0, 1))
            bodies.append(Body(block.name, block_shape(block), position, quat))
        base = planar_pose(*geometry.robot.base)
        joints = robot_joints(geometry.robot.torso, REST_ARM_CONF[ARM], FINGER_TRAVEL)
        bodies.append(Body(ROBOT, Urdf(URDF_PATH, joints), base[0], base[1]))
        xs = [x for p in geometry.platforms for x in p.footprint()[:2]] + [geometry.robot.base[0]]
        ys = [y for p in geometry.platforms for y in p.footprint()[2:]] + [geometry.robot.base[1]]
        cy = (min(ys) + max(ys)) / 2
        cx = (min(xs) + max(xs)) / 2
        camera = ((min(xs) - 1.9, cy - 1.5, 2.4), (cx + 0.5, cy, 0.9))
        return SceneView(tuple(bodies), camera=camera, floor=floor_body(geometry))

    def markers(self, query: QueryView, problem: Problem) -> Sequence[Marker]:
        geometry = _geometry(problem)
        blocks = {b.name: b for b in geometry.blocks}
        block = next((v for v in query.inputs if isinstance(v, str) and v in blocks), None)
        out = []
        for value in query.outputs:
            if isinstance(value, BlockPose):
                size = blocks[block].size if block else geometry.blocks[0].size
                position, quat = block_pose_to_pose(value)
                out.append(
                    Marker("placements", "box", position, quat, (size,) * 3, translucent=True)
                )
            elif isinstance(value, Grasp):
                initial = _initial(problem, geometry)
                if block is None or block not in initial:
                    continue
                position, quat = multiply(block_pose_to_pose(initial[block]), value.tool_in_block)
                out.append(
                    Marker("grasps", "boxes", position, quat, parts=GRIPPER_PARTS, translucent=True)
                )
            elif isinstance(value, Conf):
                position, quat = planar_pose(*value.base, z=ARROW_Z)
                out.append(Marker("confs", "arrow", position, quat))
            elif isinstance(value, Trajectory):
                path = _base_path(value)
                out.append(Marker("motions", "path", path[0], points=path))
        return out

    def failure_at(self, query: QueryView, problem: Problem) -> Vec3 | None:
        geometry = _geometry(problem)
        for v in query.inputs:
            if isinstance(v, BlockPose):
                return (v.x, v.y, v.z + FAILED_POSE_Z)
        confs = [v for v in query.inputs if isinstance(v, Conf)]
        if confs:
            x, y, _ = confs[-1].base
            return (x, y, FAILED_CONF_Z)
        platforms = {p.name: p for p in geometry.platforms}
        for v in query.inputs:
            if isinstance(v, str) and v in platforms:
                plat = platforms[v]
                return (plat.center[0], plat.center[1], plat.top + FAILED_PLATFORM_Z)
        initial = _initial(problem, geometry)
        for v in query.inputs:
            if isinstance(v, str) and v in initial:
                p = initial[v]
                return (p.x, p.y, p.z + FAILED_POSE_Z)
        return None

    def animate(
        self, actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
    ) -> KitchenTimeline:
        return plan_timeline(actions, values, problem)

    def focus(self, branch: Sequence[QueryView], problem: Problem) -> Focus:
        """The robot at the last configuration the branch bound: an IK result, or where a
        motion ends (at its start configuration before any)."""
        conf: Conf | None = None
        for query in branch:
            for value in query.outputs:
                if isinstance(value, Conf):
                    conf = value
                elif isinstance(value, Trajectory):
                    conf = value.end
        if conf is None:
            return Focus()
        base = planar_pose(*conf.base)
        joints = robot_joints(conf.torso, conf.arm, FINGER_TRAVEL)
        return Focus(bodies={ROBOT: BodyState(base[0], base[1], joints)})


def _base_path(traj: Trajectory) -> tuple[Vec3, ...]:
    """The base's positions along a trajectory, just above the floor, without repeats."""
    points: list[Vec3] = []
    for seg in traj.segments:
        for x, y, _ in seg.base:
            if not points or math.dist(points[-1][:2], (x, y)) > 1e-9:
                points.append((x, y, PATH_Z))
    if not points:
        x, y, _ = traj.start.base
        points.append((x, y, PATH_Z))
    return tuple(points)


# --- the plan in time --------------------------------------------------------------------------


@dataclass(frozen=True)
class RobotState:
    """The robot and the blocks at one moment of a plan."""

    base: BaseConf
    torso: float
    arm: tuple[float, ...]  # the working arm's seven joints
    held: Held | None
    blocks: Mapping[str, BlockPose]  # blocks standing somewhere (not the one in the hand)


@dataclass(frozen=True)
class _Phase:
    """One trajectory segment: waypoints and the second each is reached, from ``start``."""

    start: float
    seconds: float
    times: tuple[float, ...]
    bases: tuple[BaseConf, ...]
    arms: tuple[tuple[float, ...], ...]
    torso: float
    held: Held | None
    blocks: Mapping[str, BlockPose]


class KitchenTimeline:
    """The robot's and the blocks' states at every second of a plan (a
    :class:`~planner.view.Timeline`; :meth:`state_at` gives the kitchen's own state)."""

    def __init__(
        self,
        phases: Sequence[_Phase],
        initial: RobotState,
        final: RobotState,
        geometry: KitchenGeometry,
        steps: ActionSteps | None = None,
    ) -> None:
        self._phases = tuple(phases)
        self.steps = steps  # which action plays when
        self._starts = [p.start for p in self._phases]
        self.initial = initial
        self.final = final
        self._geometry = geometry
        self._duration = sum(p.seconds for p in self._phases)

    @property
    def duration(self) -> float:
        return self._duration

    def state_at(self, t: float) -> RobotState:
        """The state ``t`` seconds into the plan (clamped to the plan's span)."""
        if not self._phases or t >= self._duration:
            return self.final
        t = max(0.0, t)
        phase = self._phases[max(0, bisect.bisect_right(self._starts, t) - 1)]
        local = t - phase.start
        j = max(0, bisect.bisect_right(phase.times, local) - 1)
        if j >= len(phase.times) - 1:
            base, arm = phase.bases[-1], phase.arms[-1]
        else:
            t0, t1 = phase.times[j], phase.times[j + 1]
            f = 0.0 if t1 <= t0 else (local - t0) / (t1 - t0)
            base = _lerp_base(phase.bases[j], phase.bases[j + 1], f)
            arm = tuple(
                a + f * (b - a) for a, b in zip(phase.arms[j], phase.arms[j + 1], strict=True)
            )
        return RobotState(base, phase.torso, arm, phase.held, phase.blocks)

    def at(self, t: float) -> dict[str, BodyState]:
        state = self.state_at(t)
        # Each finger opens up to FINGER_TRAVEL; holding, they close on the block's faces.
        gripper = FINGER_TRAVEL
        if state.held is not None:
            gripper = min(FINGER_TRAVEL, self._geometry.block(state.held[0]).size / 2)
        base = planar_pose(*state.base)
        out = {ROBOT: BodyState(base[0], base[1], robot_joints(state.torso, state.arm, gripper))}
        for block in self._geometry.blocks:
            if state.held is not None and state.held[0] == block.name:
                rel: Pose = invert(state.held[1].tool_in_block)
                out[block.name] = BodyState(attached=(ROBOT, TOOL_LINK[ARM], rel[0], rel[1]))
            elif block.name in state.blocks:
                position, quat = block_pose_to_pose(state.blocks[block.name])
                out[block.name] = BodyState(position, quat)
            else:
                out[block.name] = BodyState(visible=False)
        return out


def plan_timeline(
    actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
) -> KitchenTimeline:
    """Replay a bound plan from the problem's initial state; ValueError names the action that
    does not fit."""
    geometry = _geometry(problem)
    blocks: dict[str, BlockPose] = _initial(problem, geometry)
    conf = Conf(geometry.robot.base, geometry.robot.torso, REST_ARM_CONF[ARM])
    initial = RobotState(conf.base, conf.torso, conf.arm, None, dict(blocks))
    held: Held | None = None
    phases: list[_Phase] = []
    starts: list[float] = []
    t = 0.0
    for step, act in enumerate(actions):
        starts.append(t)
        args = [values.get(a, a) for a in act.args]
        where = f"actions[{step}] {act}"
        if act.name == "move":
            traj = _arg(args, 2, Trajectory, where)
            for seg in traj.segments:
                phase = _phase(seg, t, traj.start.torso, held, dict(blocks))
                phases.append(phase)
                t += phase.seconds
            conf = traj.end
        elif act.name == "pick":
            block = _arg(args, 0, str, where)
            held = (block, _arg(args, 3, Grasp, where))
            blocks.pop(block, None)
        elif act.name in ("place", "cook"):
            blocks[_arg(args, 0, str, where)] = _arg(args, 1, BlockPose, where)
            held = None
        elif act.name not in STILL_ACTIONS:
            raise ValueError(f"{where}: unknown action {act.name!r}")
    final = RobotState(conf.base, conf.torso, conf.arm, held, dict(blocks))
    steps = ActionSteps(tuple(starts), tuple(str(a) for a in actions))
    return KitchenTimeline(phases, initial, final, geometry, steps)


def _arg(args: Sequence[Any], i: int, kind: type[T], where: str) -> T:
    if i >= len(args) or not isinstance(args[i], kind):
        raise ValueError(f"{where}: argument {i + 1} is not a {kind.__name__}")
    value: T = args[i]
    return value


def _phase(
    seg: Segment,
    start: float,
    torso: float,
    held: Held | None,
    blocks: Mapping[str, BlockPose],
) -> _Phase:
    """Waypoint times of a segment: each step takes its share of the segment's seconds in
    proportion to what the velocity limits make it take."""
    if not seg.arm or not seg.base:
        raise ValueError(f"a {seg.kind} segment needs a base pose and arm joints")
    if seg.kind == "arm":
        arms = seg.arm
        bases = (seg.base[0],) * len(arms)
        joints = ARM_JOINTS[ARM]
        weights = [
            max(abs(b - a) / VELOCITY_LIMITS[j] for a, b, j in zip(p, q, joints, strict=True))
            for p, q in itertools.pairwise(arms)
        ]
    else:
        bases = seg.base
        arms = (seg.arm[0],) * len(bases)
        linear, angular = BASE_VELOCITY
        weights = [
            max(math.dist(p[:2], q[:2]) / linear, abs(wrap_angle(q[2] - p[2])) / angular)
            for p, q in itertools.pairwise(bases)
        ]
    total = sum(weights)
    seconds = max(0.0, seg.seconds)
    times = [0.0]
    for i, w in enumerate(weights):
        share = w / total if total > 0 else 1.0 / len(weights)
        times.append(seconds if i == len(weights) - 1 else times[-1] + share * seconds)
    return _Phase(start, seconds, tuple(times), tuple(bases), tuple(arms), torso, held, blocks)


def _lerp_base(a: BaseConf, b: BaseConf, f: float) -> BaseConf:
    """Straight in x, y; the yaw turns the short way round."""
    return (
        a[0] + f * (b[0] - a[0]),
        a[1] + f * (b[1] - a[1]),
        wrap_angle(a[2] + f * wrap_angle(b[2] - a[2])),
    )

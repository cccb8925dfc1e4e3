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

import functools
import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any

from planner.abstract.skeleton import GroundAction
from planner.domains.kitchen.geometry import BlockPose, KitchenGeometry
from planner.domains.kitchen.problem import ARM, ROBOT, geometry_of
from planner.domains.kitchen.props import block_shape, floor_body, platform_body
from planner.domains.kitchen.values import BaseConf, Conf, Grasp, Segment, Trajectory
from planner.domains.manipulation.problem import start_poses
from planner.domains.manipulation.timeline import Held, PlanState, PlanTimeline, Playback, lerp
from planner.domains.manipulation.view import SceneBlocks, block_body, ghosts, last_output
from planner.pddl.structs import Problem
from planner.robots import get_robot
from planner.robots.base import step_seconds
from planner.robots.pr2.model import (
    ARM_JOINTS,
    ARMS,
    BASE_VELOCITY,
    FINGER_TRAVEL,
    GRIPPER_JOINTS,
    REST_ARM_CONF,
    TOOL_LINK,
    TORSO_JOINT,
)
from planner.sim.transforms import invert, planar_pose, wrap_angle
from planner.view import Body, BodyState, Focus, Marker, QueryView, SceneView, Urdf, Vec3

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


def _initial(problem: Problem, geometry: KitchenGeometry) -> dict[str, BlockPose]:
    return start_poses(problem, [b.name for b in geometry.blocks], BlockPose)


def _blocks(problem: Problem, geometry: KitchenGeometry) -> SceneBlocks:
    sizes = {b.name: (b.size, b.size, b.size) for b in geometry.blocks}
    return SceneBlocks(sizes, _initial(problem, geometry))


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
        geometry = geometry_of(problem)
        robot = (geometry.robot.base[0], geometry.robot.base[1])
        bodies = [platform_body(plat, robot) for plat in geometry.platforms]
        initial = _initial(problem, geometry)
        bodies += [block_body(b.name, block_shape(b), initial.get(b.name)) for b in geometry.blocks]
        base = planar_pose(*geometry.robot.base)
        joints = robot_joints(geometry.robot.torso, REST_ARM_CONF[ARM], FINGER_TRAVEL)
        urdf = Urdf(get_robot(ROBOT).view_urdf(), joints)
        bodies.append(Body(ROBOT, urdf, base[0], base[1]))
        xs = [x for p in geometry.platforms for x in p.footprint()[:2]] + [geometry.robot.base[0]]
        ys = [y for p in geometry.platforms for y in p.footprint()[2:]] + [geometry.robot.base[1]]
        cy = (min(ys) + max(ys)) / 2
        cx = (min(xs) + max(xs)) / 2
        camera = ((min(xs) - 1.9, cy - 1.5, 2.4), (cx + 0.5, cy, 0.9))
        return SceneView(tuple(bodies), camera=camera, floor=floor_body(geometry))

    def markers(self, query: QueryView, problem: Problem) -> Sequence[Marker]:
        blocks = _blocks(problem, geometry_of(problem))
        return ghosts(query, blocks, functools.partial(_ghost, blocks=blocks))

    def failure_at(self, query: QueryView, problem: Problem) -> Vec3 | None:
        geometry = geometry_of(problem)
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
        conf = last_output(branch, (Conf, Trajectory))
        if isinstance(conf, Trajectory):
            conf = conf.end
        if not isinstance(conf, Conf):
            return Focus()
        base = planar_pose(*conf.base)
        joints = robot_joints(conf.torso, conf.arm, FINGER_TRAVEL)
        return Focus(bodies={ROBOT: BodyState(base[0], base[1], joints)})


def _ghost(value: Any, block: str | None, *, blocks: SceneBlocks) -> Marker | None:
    """A grasp's gripper around the block's initial pose, an IK result's arrow at its base
    pose on the floor, a motion's base path."""
    if isinstance(value, Grasp):
        return blocks.grasp_ghost(block, value.tool_in_block, GRIPPER_PARTS)
    if isinstance(value, Conf):
        position, quat = planar_pose(*value.base, z=ARROW_Z)
        return Marker("confs", "arrow", position, quat)
    if isinstance(value, Trajectory):
        path = _base_path(value)
        return Marker("motions", "path", path[0], points=path)
    return None


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

RobotState = PlanState[Conf]  # the robot (base, torso, working arm) and the blocks at a moment


class KitchenTimeline(PlanTimeline[Conf]):
    """The robot's and the blocks' states at every second of a plan (a
    :class:`~planner.view.Timeline`; :meth:`state_at` gives the kitchen's own state)."""

    robot = ROBOT
    tool_link = TOOL_LINK[ARM]

    def between(self, a: Conf, b: Conf, f: float) -> Conf:
        return Conf(_lerp_base(a.base, b.base, f), a.torso, lerp(a.arm, b.arm, f))

    def robot_state(self, state: RobotState) -> BodyState:
        # Each finger opens up to FINGER_TRAVEL; holding, they close on the block's faces.
        gripper = FINGER_TRAVEL if state.held is None else state.held.fingers
        base = planar_pose(*state.conf.base)
        return BodyState(base[0], base[1], robot_joints(state.conf.torso, state.conf.arm, gripper))


def plan_timeline(
    actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
) -> KitchenTimeline:
    """Replay a bound plan from the problem's initial state; ValueError names the action that
    does not fit."""
    geometry = geometry_of(problem)
    start = Conf(geometry.robot.base, geometry.robot.torso, REST_ARM_CONF[ARM])
    play = Playback(start, _initial(problem, geometry))
    for act in play.actions(actions, values):
        if act.name == "move":
            traj = act.arg(2, Trajectory)
            for seg in traj.segments:
                play.move(*_waypoints(seg, traj.start.torso), seg.seconds)
            play.conf = traj.end
        elif act.name == "pick":
            block, grasp = act.arg(0, str), act.arg(3, Grasp)
            fingers = min(FINGER_TRAVEL, geometry.block(block).size / 2)
            play.take(Held(block, invert(grasp.tool_in_block), fingers))
        elif act.name in ("place", "cook"):
            play.put(act.arg(0, str), act.arg(1, BlockPose))
        elif act.name not in STILL_ACTIONS:
            raise ValueError(f"{act.where}: unknown action {act.name!r}")
    blocks = [b.name for b in geometry.blocks]
    return KitchenTimeline(play.phases, play.initial, play.final(), blocks, play.steps())


def _waypoints(seg: Segment, torso: float) -> tuple[list[Conf], list[float]]:
    """A segment's configurations, and the seconds each step between them takes under the
    velocity limits (the share of the segment's seconds it is given)."""
    if not seg.arm or not seg.base:
        raise ValueError(f"a {seg.kind} segment needs a base pose and arm joints")
    if seg.kind == "arm":
        velocities = get_robot(ROBOT).velocities(ARM_JOINTS[ARM])
        points = [Conf(seg.base[0], torso, arm) for arm in seg.arm]
        weights = [step_seconds(p, q, velocities) for p, q in itertools.pairwise(seg.arm)]
    else:
        points = [Conf(base, torso, seg.arm[0]) for base in seg.base]
        linear, angular = BASE_VELOCITY
        weights = [
            max(math.dist(p[:2], q[:2]) / linear, abs(wrap_angle(q[2] - p[2])) / angular)
            for p, q in itertools.pairwise(seg.base)
        ]
    return points, weights


def _lerp_base(a: BaseConf, b: BaseConf, f: float) -> BaseConf:
    """Straight in x, y; the yaw turns the short way round."""
    return (
        a[0] + f * (b[0] - a[0]),
        a[1] + f * (b[1] - a[1]),
        wrap_angle(a[2] + f * wrap_angle(b[2] - a[2])),
    )

"""The Panda tabletop in the 3D view (``DomainSpec.view``): the table on its legs, its regions
(the start area marked on the table, a tray's floor and rims, a shelf), the blocks and tall
obstacles as boxes at their seeded start poses, the Panda drawn with its own meshes
(:mod:`planner.domains.panda.visuals`) at its ready pose with the hand open, on a tiled floor;
the ghosts of sampled values; a bound plan played by the arm.

Ghosts: a placement is a translucent block where it would stand (layer ``placements``), a grasp
the hand's slim outline (finger pads on the block's faces, a bar above it, a stub towards the
flange: :func:`hand_ghost`) at the block's start pose (``grasps``), an IK result the open hand's
outline where the configuration puts it (``confs``), so that a crowd of them leaves the blocks
in sight; a motion the
tool's path through the trajectory (``motions``, the forward kinematics of its waypoints and of
points between them). A failed query is marked above its input pose, else at the hand of its
configuration, else above its region, else above the block.

The plan: each ``move`` plays its trajectory's waypoints over its seconds (each step taking its
share in proportion to what the joint velocity limits make it take); ``pick`` and
``pick-obstacle`` close the hand on the block, which then rides with the tool frame where the
grasp holds it; ``place`` opens the hand and leaves the block at its pose.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any

from planner.abstract.skeleton import GroundAction
from planner.domains.manipulation.problem import block_pose_to_pose, start_poses
from planner.domains.manipulation.timeline import Held, PlanState, PlanTimeline, Playback, lerp
from planner.domains.manipulation.view import SceneBlocks, block_body, ghosts, last_output
from planner.domains.panda.geometry import PandaGeometry
from planner.domains.panda.problem import ROBOT, START_CONF, geometry_of
from planner.domains.panda.props import floor_body, region_body, rgb, table_body
from planner.domains.panda.values import BlockPose, Conf, Grasp, Trajectory
from planner.pddl.structs import Problem
from planner.robots.base import step_seconds
from planner.robots.panda.model import (
    ARM_JOINTS,
    FINGER_JOINTS,
    FINGER_OPEN,
    READY,
    TOOL_LINK,
    VELOCITY,
    finger_joint,
)
from planner.robots.panda.visuals import panda_kinematics, viewer_urdf
from planner.sim.transforms import Pose, invert, multiply
from planner.view import Body, BodyState, Box, Focus, Marker, QueryView, SceneView, Urdf, Vec3

PICKS = ("pick", "pick-obstacle")
PATH_STEP = 0.1  # radians (largest joint change) between the points of a drawn tool path
FAILED_ABOVE = 0.06  # a failed query is marked this far above its block, hand or region
# The hand as a ghost, in the tool frame (panda_grasptarget: z along the fingers, which close
# along y): the two finger pads, a thin bar joining them above the block, and a stub towards
# the flange. Slim, so that a crowd of grasps leaves the block in sight (the whole hand's palm
# and flange, 20 cm across, buried a 4 cm block under its ghosts).
GHOST_PAD = (0.02, 0.006, 0.03)  # one finger pad: across the finger, thick, along it
OPEN_WIDTH = 0.05  # between the pads of the empty hand (FINGER_OPEN each, less the pads)


def hand_ghost(width: float) -> tuple[tuple[Vec3, Vec3], ...]:
    """The ghost's boxes ``(centre, size)`` with the pads ``width`` apart, inner face to inner
    face: a grasp's are on the block's faces."""
    y = width / 2 + GHOST_PAD[1] / 2
    return (
        ((0.0, y, -0.015), GHOST_PAD),
        ((0.0, -y, -0.015), GHOST_PAD),
        ((0.0, 0.0, -0.034), (0.006, 2 * y + GHOST_PAD[1], 0.006)),
        ((0.0, 0.0, -0.062), (0.006, 0.006, 0.05)),
    )


def robot_joints(arm: Sequence[float], fingers: float = FINGER_OPEN) -> dict[str, float]:
    """The Panda's joint values: the arm's seven, each finger at ``fingers``."""
    joints = dict(zip(ARM_JOINTS, arm, strict=True))
    joints.update((joint, fingers) for joint in FINGER_JOINTS)
    return joints


def tool_pose(arm: Sequence[float]) -> Pose:
    """Where the tool frame is (in the world: the base stands at the origin) for ``arm``."""
    return panda_kinematics().link_pose(TOOL_LINK, robot_joints(arm))


def _initial(problem: Problem, geometry: PandaGeometry) -> dict[str, BlockPose]:
    return start_poses(problem, [b.name for b in geometry.blocks], BlockPose)


def _start_arm(problem: Problem) -> tuple[float, ...]:
    conf = problem.values.get(START_CONF)
    return conf.arm if isinstance(conf, Conf) else READY


def _held_width(size: tuple[float, float, float], grasp: Grasp) -> float:
    """How wide the block is between the fingers: they close across its y faces when the
    grasp's yaw is a multiple of a half turn, across its x faces otherwise."""
    return size[1] if round(grasp.yaw / (math.pi / 2)) % 2 == 0 else size[0]


class PandaView:
    """The Panda tabletop's :class:`~planner.view.DomainView` (and
    :class:`~planner.view.FocusView`)."""

    def scene(self, problem: Problem) -> SceneView:
        from planner.domains.panda.world import TABLE_THICKNESS, fixture_boxes

        geometry = geometry_of(problem)
        table = geometry.table
        bodies = [table_body(table, TABLE_THICKNESS)]
        bodies += [region_body(r, table, fixture_boxes(r)) for r in geometry.regions]
        initial = _initial(problem, geometry)
        bodies += [
            block_body(b.name, Box(b.size), initial.get(b.name), rgb(b.color))
            for b in geometry.blocks
        ]
        joints = robot_joints(_start_arm(problem))
        bodies.append(Body(ROBOT, Urdf(viewer_urdf(), joints)))
        (cx, cy), sx = table.center, table.size[0]
        # From behind the arm's left, looking down over the table towards +x, where the view
        # stands the search tree's panel (beyond the farthest body), as the kitchen's does.
        camera = ((cx - sx / 2 - 1.2, cy - 1.6, 1.6), (cx + sx / 2, cy, 0.4))
        return SceneView(
            tuple(bodies), camera=camera, floor_z=-table.height, floor=floor_body(table)
        )

    def markers(self, query: QueryView, problem: Problem) -> Sequence[Marker]:
        geometry = geometry_of(problem)
        sizes = {b.name: b.size for b in geometry.blocks}
        blocks = SceneBlocks(sizes, _initial(problem, geometry))
        return ghosts(query, blocks, functools.partial(_ghost, blocks=blocks))

    def failure_at(self, query: QueryView, problem: Problem) -> Vec3 | None:
        geometry = geometry_of(problem)
        blocks = {b.name: b for b in geometry.blocks}
        block = next((v for v in query.inputs if isinstance(v, str) and v in blocks), None)
        for v in query.inputs:
            if isinstance(v, BlockPose):
                height = blocks[block].size[2] if block else 0.0
                return (v.x, v.y, v.z + height / 2 + FAILED_ABOVE)
        confs = [v for v in query.inputs if isinstance(v, Conf)]
        if confs:
            (x, y, z), _ = tool_pose(confs[-1].arm)
            return (x, y, z + FAILED_ABOVE)
        regions = {r.name: r for r in geometry.regions}
        for v in query.inputs:
            if isinstance(v, str) and v in regions:
                region = regions[v]
                top = region.top + region.rim
                return (region.center[0], region.center[1], top + FAILED_ABOVE)
        initial = _initial(problem, geometry)
        if block is not None and block in initial:
            p = initial[block]
            return (p.x, p.y, p.z + blocks[block].size[2] / 2 + FAILED_ABOVE)
        return None

    def focus(self, branch: Sequence[QueryView], problem: Problem) -> Focus:
        """The arm at the last configuration the branch bound: an IK result (the hand at the
        block), or where a motion ends."""
        value = last_output(branch, (Conf, Trajectory))
        if value is None:
            return Focus()
        arm = value.arm if isinstance(value, Conf) else value.path[-1]
        return Focus(bodies={ROBOT: BodyState(joints=robot_joints(arm))})

    def animate(
        self, actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
    ) -> PandaTimeline:
        return plan_timeline(actions, values, problem)


def _ghost(value: Any, block: str | None, *, blocks: SceneBlocks) -> Marker | None:
    """A grasp's hand outline on the block's faces at its start pose, an IK result's open hand
    where the configuration puts it, a motion's tool path."""
    if isinstance(value, Grasp):
        if block is None:
            return None
        parts = hand_ghost(_held_width(blocks.sizes[block], value))  # on its faces
        return blocks.grasp_ghost(block, value.tool_in_block(), parts)
    if isinstance(value, Conf):
        position, quat = tool_pose(value.arm)
        parts = hand_ghost(OPEN_WIDTH)
        return Marker("confs", "boxes", position, quat, parts=parts, translucent=True)
    if isinstance(value, Trajectory):
        points = tool_path(value.path)
        return Marker("motions", "path", points[0], points=points)
    return None


def _interpolated(path: Sequence[Sequence[float]], step: float) -> list[tuple[float, ...]]:
    """Joint-space points along a path, at most ``step`` apart in every joint."""
    out = [tuple(path[0])]
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(max(abs(y - x) for x, y in zip(a, b, strict=True)) / step))
        out += [
            tuple(x + i / n * (y - x) for x, y in zip(a, b, strict=True)) for i in range(1, n + 1)
        ]
    return out


def tool_path(path: Sequence[Sequence[float]]) -> tuple[Vec3, ...]:
    """The tool's positions along a joint-space path (each straight joint-space step curves at
    the hand: points at most PATH_STEP apart in every joint), without repeats."""
    points: list[Vec3] = []
    for arm in _interpolated(path, PATH_STEP):
        position = tool_pose(arm)[0]
        if not points or math.dist(points[-1], position) > 1e-6:
            points.append(position)
    return tuple(points)


# --- the plan in time --------------------------------------------------------------------------


class PandaTimeline(PlanTimeline[tuple[float, ...]]):
    """The arm's and the blocks' states at every second of a plan (a
    :class:`~planner.view.Timeline`; :meth:`state_at` gives the Panda's own state: its
    configuration is the arm's seven joints)."""

    robot = ROBOT
    tool_link = TOOL_LINK

    def between(self, a: tuple[float, ...], b: tuple[float, ...], f: float) -> tuple[float, ...]:
        return lerp(a, b, f)

    def robot_state(self, state: PlanState[tuple[float, ...]]) -> BodyState:
        fingers = state.held.fingers if state.held is not None else FINGER_OPEN
        return BodyState(joints=robot_joints(state.conf, fingers))


def plan_timeline(
    actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
) -> PandaTimeline:
    """Replay a bound plan from the problem's start; ValueError names the action that does not
    fit."""
    geometry = geometry_of(problem)
    play = Playback(_start_arm(problem), _initial(problem, geometry))
    known = {**problem.values, **values}  # the start's values (q0, start poses) and the plan's
    for act in play.actions(actions, known):
        if act.name == "move":
            traj = act.arg(2, Trajectory)
            path = tuple(tuple(q) for q in traj.path)
            if not path:
                raise ValueError("a trajectory needs waypoints")
            weights = [step_seconds(p, q, VELOCITY) for p, q in itertools.pairwise(path)]
            play.move(path, weights, traj.seconds)
            play.conf = traj.path[-1]
        elif act.name in PICKS:
            shift = 1 if act.name == "pick-obstacle" else 0
            block = act.arg(0, str)
            pose = play.blocks.pop(block, None) or act.arg(1 + shift, BlockPose)
            grasp, conf = act.arg(3 + shift, Grasp), act.arg(4 + shift, Conf)
            # The block where the hand at the grasp configuration holds it.
            in_tool = multiply(invert(tool_pose(conf.arm)), block_pose_to_pose(pose))
            width = _held_width(geometry.block(block).size, grasp)
            play.take(Held(block, in_tool, finger_joint(width)))
            play.conf = conf.arm
        elif act.name == "place":
            play.put(act.arg(0, str), act.arg(1, BlockPose))
            play.conf = act.arg(4, Conf).arm
        else:
            raise ValueError(f"{act.where}: unknown action {act.name!r}")
    blocks = [b.name for b in geometry.blocks]
    return PandaTimeline(play.phases, play.initial, play.final(), blocks, play.steps())

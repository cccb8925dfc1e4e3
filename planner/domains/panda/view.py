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

import bisect
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from planner.abstract.skeleton import GroundAction
from planner.domains.panda.geometry import PandaGeometry, block_pose_to_pose
from planner.domains.panda.problem import START_CONF, geometry_of, initial_pose_name
from planner.domains.panda.props import floor_body, region_body, rgb, table_body
from planner.domains.panda.values import BlockPose, Conf, Grasp, Trajectory
from planner.pddl.structs import Problem
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
from planner.view import (
    ActionSteps,
    Body,
    BodyState,
    Box,
    Focus,
    Marker,
    QueryView,
    SceneView,
    Urdf,
    Vec3,
)

T = TypeVar("T")

ROBOT = "panda"  # the robot's body name
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
    out = {}
    for block in geometry.blocks:
        pose = problem.values.get(initial_pose_name(block.name))
        if isinstance(pose, BlockPose):
            out[block.name] = pose
    return out


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
        for block in geometry.blocks:
            pose = initial.get(block.name)
            position, quat = block_pose_to_pose(pose) if pose else ((0.0, 0.0, 0.0), (0, 0, 0, 1))
            bodies.append(Body(block.name, Box(block.size), position, quat, rgb(block.color)))
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
        blocks = {b.name: b for b in geometry.blocks}
        block = next((v for v in query.inputs if isinstance(v, str) and v in blocks), None)
        out = []
        for value in query.outputs:
            if isinstance(value, BlockPose):
                size = blocks[block].size if block else geometry.blocks[0].size
                position, quat = block_pose_to_pose(value)
                out.append(Marker("placements", "box", position, quat, size, translucent=True))
            elif isinstance(value, Grasp):
                initial = _initial(problem, geometry)
                if block is None or block not in initial:
                    continue
                position, quat = multiply(block_pose_to_pose(initial[block]), value.tool_in_block())
                parts = hand_ghost(_held_width(blocks[block].size, value))  # on its faces
                out.append(Marker("grasps", "boxes", position, quat, parts=parts, translucent=True))
            elif isinstance(value, Conf):
                position, quat = tool_pose(value.arm)
                out.append(
                    Marker(
                        "confs",
                        "boxes",
                        position,
                        quat,
                        parts=hand_ghost(OPEN_WIDTH),
                        translucent=True,
                    )
                )
            elif isinstance(value, Trajectory):
                points = tool_path(value.path)
                out.append(Marker("motions", "path", points[0], points=points))
        return out

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
        arm: tuple[float, ...] | None = None
        for query in branch:
            for value in query.outputs:
                if isinstance(value, Conf):
                    arm = value.arm
                elif isinstance(value, Trajectory):
                    arm = value.path[-1]
        if arm is None:
            return Focus()
        return Focus(bodies={ROBOT: BodyState(joints=robot_joints(arm))})

    def animate(
        self, actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
    ) -> PandaTimeline:
        return plan_timeline(actions, values, problem)


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


@dataclass(frozen=True)
class Held:
    """A block in the hand: its pose in the tool frame, and the fingers closed on it."""

    block: str
    in_tool: Pose
    fingers: float


@dataclass(frozen=True)
class PlanState:
    """The arm and the blocks at one moment of a plan."""

    arm: tuple[float, ...]
    held: Held | None
    blocks: Mapping[str, BlockPose]  # blocks standing somewhere (not the one in the hand)


@dataclass(frozen=True)
class _Phase:
    """One move: its waypoints and the second each is reached, from ``start``."""

    start: float
    seconds: float
    times: tuple[float, ...]
    path: tuple[tuple[float, ...], ...]
    held: Held | None
    blocks: Mapping[str, BlockPose]


class PandaTimeline:
    """The arm's and the blocks' states at every second of a plan (a
    :class:`~planner.view.Timeline`; :meth:`state_at` gives the Panda's own state)."""

    def __init__(
        self,
        phases: Sequence[_Phase],
        initial: PlanState,
        final: PlanState,
        blocks: Sequence[str],
        steps: ActionSteps | None = None,
    ) -> None:
        self._phases = tuple(phases)
        self.steps = steps  # which action plays when
        self._starts = [p.start for p in self._phases]
        self.initial = initial
        self.final = final
        self._blocks = tuple(blocks)
        self._duration = sum(p.seconds for p in self._phases)

    @property
    def duration(self) -> float:
        return self._duration

    def state_at(self, t: float) -> PlanState:
        """The state ``t`` seconds into the plan (clamped to the plan's span)."""
        if not self._phases or t >= self._duration:
            return self.final
        t = max(0.0, t)
        phase = self._phases[max(0, bisect.bisect_right(self._starts, t) - 1)]
        local = t - phase.start
        j = max(0, bisect.bisect_right(phase.times, local) - 1)
        if j >= len(phase.times) - 1:
            arm = phase.path[-1]
        else:
            t0, t1 = phase.times[j], phase.times[j + 1]
            f = 0.0 if t1 <= t0 else (local - t0) / (t1 - t0)
            arm = tuple(
                a + f * (b - a) for a, b in zip(phase.path[j], phase.path[j + 1], strict=True)
            )
        return PlanState(arm, phase.held, phase.blocks)

    def at(self, t: float) -> dict[str, BodyState]:
        state = self.state_at(t)
        fingers = state.held.fingers if state.held is not None else FINGER_OPEN
        out = {ROBOT: BodyState(joints=robot_joints(state.arm, fingers))}
        for name in self._blocks:
            if state.held is not None and state.held.block == name:
                position, quat = state.held.in_tool
                out[name] = BodyState(attached=(ROBOT, TOOL_LINK, position, quat))
            elif name in state.blocks:
                position, quat = block_pose_to_pose(state.blocks[name])
                out[name] = BodyState(position, quat)
            else:
                out[name] = BodyState(visible=False)
        return out


def plan_timeline(
    actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
) -> PandaTimeline:
    """Replay a bound plan from the problem's start; ValueError names the action that does not
    fit."""
    geometry = geometry_of(problem)
    blocks: dict[str, BlockPose] = _initial(problem, geometry)
    arm = _start_arm(problem)
    initial = PlanState(arm, None, dict(blocks))
    held: Held | None = None
    phases: list[_Phase] = []
    t = 0.0
    known = {**problem.values, **values}  # the start's values (q0, start poses) and the plan's
    starts: list[float] = []
    for step, act in enumerate(actions):
        starts.append(t)
        args = [known.get(a, a) for a in act.args]
        where = f"actions[{step}] {act}"
        if act.name == "move":
            traj = _arg(args, 2, Trajectory, where)
            phase = _phase(traj, t, held, dict(blocks))
            phases.append(phase)
            t += phase.seconds
            arm = traj.path[-1]
        elif act.name in PICKS:
            shift = 1 if act.name == "pick-obstacle" else 0
            block = _arg(args, 0, str, where)
            pose = blocks.pop(block, None) or _arg(args, 1 + shift, BlockPose, where)
            grasp = _arg(args, 3 + shift, Grasp, where)
            conf = _arg(args, 4 + shift, Conf, where)
            # The block where the hand at the grasp configuration holds it.
            in_tool = multiply(invert(tool_pose(conf.arm)), block_pose_to_pose(pose))
            width = _held_width(geometry.block(block).size, grasp)
            held = Held(block, in_tool, finger_joint(width))
            arm = conf.arm
        elif act.name == "place":
            blocks[_arg(args, 0, str, where)] = _arg(args, 1, BlockPose, where)
            held = None
            arm = _arg(args, 4, Conf, where).arm
        else:
            raise ValueError(f"{where}: unknown action {act.name!r}")
    final = PlanState(arm, held, dict(blocks))
    steps = ActionSteps(tuple(starts), tuple(str(a) for a in actions))
    return PandaTimeline(phases, initial, final, [b.name for b in geometry.blocks], steps)


def _arg(args: Sequence[Any], i: int, kind: type[T], where: str) -> T:
    if i >= len(args) or not isinstance(args[i], kind):
        raise ValueError(f"{where}: argument {i + 1} is not a {kind.__name__}")
    value: T = args[i]
    return value


def _phase(
    traj: Trajectory, start: float, held: Held | None, blocks: Mapping[str, BlockPose]
) -> _Phase:
    """Waypoint times of a move: each step takes its share of the trajectory's seconds in
    proportion to what the joint velocity limits make it take."""
    path = tuple(tuple(q) for q in traj.path)
    if not path:
        raise ValueError("a trajectory needs waypoints")
    weights = [
        max(abs(b - a) / v for a, b, v in zip(p, q, VELOCITY, strict=True))
        for p, q in itertools.pairwise(path)
    ]
    total = sum(weights)
    seconds = max(0.0, traj.seconds)
    times = [0.0]
    for i, w in enumerate(weights):
        share = w / total if total > 0 else 1.0 / len(weights)
        times.append(seconds if i == len(weights) - 1 else times[-1] + share * seconds)
    return _Phase(start, seconds, tuple(times), path, held, blocks)

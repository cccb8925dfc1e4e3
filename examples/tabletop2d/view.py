"""The tabletop in the 3D view: the table, its regions and the blocks as boxes on a plane, the
gripper as a small box above the table; ghosts of sampled placements, gripper configurations
and paths; the plan played by keyframes (the gripper moves, a picked block goes with it).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from planner.abstract import GroundAction
from planner.pddl import Problem
from planner.view import (
    ActionSteps,
    Body,
    BodyState,
    Box,
    Focus,
    Keyframes,
    Marker,
    QueryView,
    SceneView,
    Vec3,
)

from .scene import START_CONF, Tabletop, start_pose_name, tabletop
from .values import Conf2D, Path2D, Pose2D

TABLE_TOP = 0.70  # height of the table's top face, metres
TABLE_THICKNESS = 0.04
REGION_THICKNESS = 0.004  # regions are drawn as thin coloured plates on the table
BLOCK_HEIGHT = 0.05
GRIPPER_Z = TABLE_TOP + 0.25  # the gripper moves at this height
GRIPPER_SIZE = (0.06, 0.03, 0.04)
GRIPPER = "gripper"  # its body name
GRASP_S = 0.5  # seconds a pick or a place takes in the animation


def _block_z() -> float:
    return TABLE_TOP + REGION_THICKNESS + BLOCK_HEIGHT / 2


class TabletopView:
    """The tabletop's :class:`~planner.view.DomainView`."""

    def scene(self, problem: Problem) -> SceneView:
        top = tabletop(problem)
        xmin, xmax, ymin, ymax = top.table
        bodies = [
            Body(
                "table",
                Box((xmax - xmin, ymax - ymin, TABLE_THICKNESS)),
                ((xmin + xmax) / 2, (ymin + ymax) / 2, TABLE_TOP - TABLE_THICKNESS / 2),
                color=(205, 180, 140),
            )
        ]
        for region in top.regions:
            rx0, rx1, ry0, ry1 = region.box
            bodies.append(
                Body(
                    f"region-{region.name}",
                    Box((rx1 - rx0, ry1 - ry0, REGION_THICKNESS)),
                    ((rx0 + rx1) / 2, (ry0 + ry1) / 2, TABLE_TOP + REGION_THICKNESS / 2),
                    color=region.color,
                    label=region.name,
                )
            )
        for block in top.blocks:
            pose = problem.values[start_pose_name(block.name)]
            assert isinstance(pose, Pose2D)
            bodies.append(
                Body(
                    block.name,
                    Box((*block.size, BLOCK_HEIGHT)),
                    (pose.x, pose.y, _block_z()),
                    color=block.color,
                )
            )
        bodies.append(Body(GRIPPER, Box(GRIPPER_SIZE), (*top.start, GRIPPER_Z), color=(60, 60, 60)))
        return SceneView(tuple(bodies))

    def markers(self, query: QueryView, problem: Problem) -> Sequence[Marker]:
        top = tabletop(problem)
        block = next((v for v in query.inputs if isinstance(v, str) and v in _names(top)), None)
        out = []
        for value in query.outputs:
            if isinstance(value, Pose2D) and block is not None:
                size = (*top.block(block).size, BLOCK_HEIGHT)
                out.append(
                    Marker(
                        "placements",
                        "box",
                        (value.x, value.y, _block_z()),
                        size=size,
                        translucent=True,
                    )
                )
            elif isinstance(value, Conf2D):
                out.append(Marker("confs", "box", (value.x, value.y, GRIPPER_Z), size=GRIPPER_SIZE))
            elif isinstance(value, Path2D):
                points = (
                    (value.start.x, value.start.y, GRIPPER_Z),
                    (value.end.x, value.end.y, GRIPPER_Z),
                )
                out.append(Marker("motions", "path", points[0], points=points))
        return out

    def failure_at(self, query: QueryView, problem: Problem) -> Vec3 | None:
        for value in query.inputs:
            if isinstance(value, Pose2D):
                return (value.x, value.y, _block_z() + BLOCK_HEIGHT)
            if isinstance(value, Conf2D):
                return (value.x, value.y, GRIPPER_Z)
        return None

    def focus(self, branch: Sequence[QueryView], problem: Problem) -> Focus:
        """The gripper at the last configuration the branch bound (a path's end counts)."""
        conf: Conf2D | None = None
        for query in branch:
            for value in query.outputs:
                if isinstance(value, Conf2D):
                    conf = value
                elif isinstance(value, Path2D):
                    conf = value.end
        if conf is None:
            return Focus()
        return Focus(bodies={GRIPPER: BodyState((conf.x, conf.y, GRIPPER_Z))})

    def animate(
        self, actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
    ) -> Keyframes:
        top = tabletop(problem)
        gripper = values.get(START_CONF, Conf2D(*top.start))
        assert isinstance(gripper, Conf2D)
        blocks: dict[str, BodyState] = {}
        for block in top.blocks:
            pose = values.get(
                start_pose_name(block.name), problem.values[start_pose_name(block.name)]
            )
            assert isinstance(pose, Pose2D)
            blocks[block.name] = BodyState((pose.x, pose.y, _block_z()))

        def frame() -> dict[str, BodyState]:
            return {GRIPPER: BodyState((gripper.x, gripper.y, GRIPPER_Z)), **blocks}

        times, states = [0.0], [frame()]
        starts: list[float] = []
        t = 0.0
        for act in actions:
            starts.append(t)
            if act.name == "move":
                path = values.get(act.args[2])
                if not isinstance(path, Path2D):
                    raise ValueError(f"{act}: {act.args[2]} is not a path")
                t += path.seconds
                gripper = path.end
            elif act.name == "pick":
                t += GRASP_S
                below = (0.0, 0.0, _block_z() - GRIPPER_Z)
                blocks[act.args[0]] = BodyState(attached=(GRIPPER, "", below, (0, 0, 0, 1)))
            elif act.name == "place":
                pose = values.get(act.args[1])
                if not isinstance(pose, Pose2D):
                    raise ValueError(f"{act}: {act.args[1]} is not a pose")
                t += GRASP_S
                blocks[act.args[0]] = BodyState((pose.x, pose.y, _block_z()))
            else:
                raise ValueError(f"unknown action {act.name!r}")
            times.append(t)
            states.append(frame())
        steps = ActionSteps(tuple(starts), tuple(str(a) for a in actions))
        return Keyframes(tuple(times), tuple(states), steps)


def _names(top: Tabletop) -> set[str]:
    return {b.name for b in top.blocks}

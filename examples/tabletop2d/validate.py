"""The tabletop's plan validator: the plan replayed in 2-D, step by step.

The gripper must start each path where it is, reach every configuration it picks or places
from, hold a block by its grasp, and put it inside its region clear of the blocks already there;
at the end every goal fact must hold. The first violation is reported with its step.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from planner.abstract import GroundAction
from planner.domains import PlanCheck
from planner.pddl import Problem

from .scene import START_CONF, overlap, start_pose_name, tabletop
from .values import Conf2D, Grasp2D, Path2D, Pose2D

TOLERANCE = 1e-6  # metres


def validate(
    actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
) -> PlanCheck:
    top = tabletop(problem)
    poses: dict[str, Pose2D] = {}
    where: dict[str, str] = {}
    for each in top.blocks:
        start_pose = problem.values[start_pose_name(each.name)]
        assert isinstance(start_pose, Pose2D)
        poses[each.name], where[each.name] = start_pose, each.start
    start = problem.values[START_CONF]
    assert isinstance(start, Conf2D)
    gripper, held, seconds = start, None, 0.0

    def value(name: str, kind: type, step: int, act: GroundAction) -> Any:
        v = values.get(name)
        if not isinstance(v, kind):
            raise _InvalidStepError(step, act, f"{name} is not a {kind.__name__}")
        return v

    try:
        for step, act in enumerate(actions):
            if act.name == "move":
                path = value(act.args[2], Path2D, step, act)
                if math.dist((path.start.x, path.start.y), (gripper.x, gripper.y)) > TOLERANCE:
                    raise _InvalidStepError(
                        step, act, "the path does not start where the gripper is"
                    )
                gripper, seconds = path.end, seconds + path.seconds
                continue
            block, pose_name, region, grasp_name, conf_name = act.args
            pose = value(pose_name, Pose2D, step, act)
            grasp = value(grasp_name, Grasp2D, step, act)
            conf = value(conf_name, Conf2D, step, act)
            if math.dist((gripper.x, gripper.y), (conf.x, conf.y)) > TOLERANCE:
                raise _InvalidStepError(step, act, "the gripper is not at the configuration")
            if math.dist((conf.x, conf.y), (pose.x + grasp.dx, pose.y)) > TOLERANCE:
                raise _InvalidStepError(
                    step, act, "the gripper does not hold the block by its grasp"
                )
            if not top.reaches(conf.x, conf.y):
                raise _InvalidStepError(step, act, "the configuration is out of reach")
            if act.name == "pick":
                if held is not None or poses.get(block) != pose:
                    raise _InvalidStepError(step, act, f"{block} is not free at {pose_name}")
                held = block
                del poses[block], where[block]
            elif act.name == "place":
                if held != block:
                    raise _InvalidStepError(step, act, f"{block} is not held")
                size = top.block(block).size
                half_w, half_d = size[0] / 2, size[1] / 2
                if not top.region(region).holds(
                    pose.x, pose.y, half_w - TOLERANCE, half_d - TOLERANCE
                ):
                    raise _InvalidStepError(step, act, f"{block} is not inside {region}")
                for other, at in poses.items():
                    if where[other] == region and overlap(pose, size, at, top.block(other).size):
                        raise _InvalidStepError(step, act, f"{block} overlaps {other}")
                poses[block], where[block], held = pose, region, None
            else:
                raise _InvalidStepError(step, act, f"unknown action {act.name!r}")
    except _InvalidStepError as bad:
        return PlanCheck(False, str(bad), seconds)
    for literal in problem.goal:
        atom = literal.atom
        if atom.predicate == "in" and where.get(atom.args[0]) != atom.args[1]:
            return PlanCheck(False, f"goal: {atom.args[0]} is not in {atom.args[1]}", seconds)
    return PlanCheck(True, "valid (replayed in 2-D)", seconds)


class _InvalidStepError(Exception):
    def __init__(self, step: int, act: GroundAction, why: str) -> None:
        super().__init__(f"step {step} {act}: {why}")

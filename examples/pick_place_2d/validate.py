"""The pick-and-place's plan validator: the plan replayed on the real values, step by step.

Each trajectory must start where the gripper is; the gripper must be at the configuration it
picks or places from, that configuration must hold the block by its grasp and lie within the
arm's reach; a block goes down clear of every block on the table; at the end every goal fact
holds. The first violation is reported with its step.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from planner.abstract import GroundAction
from planner.domains import PlanCheck
from planner.pddl import Problem

from .primitives import GRIP, TRAVEL_Y, Trajectory
from .scene import world_of

TOLERANCE = 1e-6


class _InvalidError(Exception):
    def __init__(self, step: int, action: GroundAction, why: str) -> None:
        super().__init__(f"step {step + 1} ({action}): {why}")


def validate(
    actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
) -> PlanCheck:
    world = world_of(problem)
    every = {**problem.values, **values}
    poses: dict[str, float] = {}
    for atom in problem.init:
        if atom.predicate == "atpose":
            poses[str(every.get(atom.args[0], atom.args[0]))] = float(every[atom.args[1]][0])
    gripper = (world.base_x, TRAVEL_Y)
    held: str | None = None
    seconds = 0.0
    try:
        for step, act in enumerate(actions):
            if act.name == "move":
                traj = every.get(act.args[1])
                if not isinstance(traj, Trajectory):
                    raise _InvalidError(step, act, f"{act.args[1]} is not a trajectory")
                if math.dist(traj.start, gripper) > TOLERANCE:
                    raise _InvalidError(step, act, "the trajectory does not start at the gripper")
                gripper, seconds = traj.end, seconds + traj.seconds
                continue
            block = str(every.get(act.args[0], act.args[0]))
            pose, grasp, conf = (every[a] for a in act.args[1:4])
            b = world.blocks[block]
            if math.dist(gripper, (float(conf[0]), float(conf[1]))) > TOLERANCE:
                raise _InvalidError(step, act, "the gripper is not at the configuration")
            expect = (float(pose[0]) + float(grasp), float(pose[1]) + b.height + GRIP)
            if math.dist(expect, (float(conf[0]), float(conf[1]))) > TOLERANCE:
                raise _InvalidError(
                    step, act, "the configuration does not hold the block by its grasp"
                )
            if abs(float(conf[0]) - world.base_x) > world.reach + TOLERANCE:
                raise _InvalidError(step, act, "the configuration is out of reach")
            if act.name == "pick":
                if held is not None or abs(poses.get(block, math.inf) - float(pose[0])) > TOLERANCE:
                    raise _InvalidError(step, act, f"{block} is not on the table at that pose")
                held = block
                del poses[block]
            else:
                if held != block:
                    raise _InvalidError(step, act, f"{block} is not held")
                x = float(pose[0])
                for other, x2 in poses.items():
                    if abs(x - x2) < (b.width + world.blocks[other].width) / 2 - TOLERANCE:
                        raise _InvalidError(step, act, f"{block} would overlap {other}")
                poses[block], held = x, None
    except _InvalidError as exc:
        return PlanCheck(False, str(exc))
    for lit in problem.goal:
        if lit.atom.predicate != "in" or not lit.positive:
            continue
        block = str(every.get(lit.atom.args[0], lit.atom.args[0]))
        lo, hi = world.regions[str(every.get(lit.atom.args[1], lit.atom.args[1]))]
        w = world.blocks[block].width
        end_x = poses.get(block)
        if end_x is None or not lo + w / 2 - TOLERANCE <= end_x <= hi - w / 2 + TOLERANCE:
            return PlanCheck(False, f"goal {lit.atom}: {block} does not end inside the region")
    return PlanCheck(True, f"valid (replayed in 2-D: {len(actions)} steps)", seconds)

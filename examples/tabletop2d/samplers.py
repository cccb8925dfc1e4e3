"""The tabletop's samplers, bound to the streams of stream.pddl by name.

Each is a plain Python function wrapped by an adapter: ``from_fn`` (a function returning one
output tuple, or a ``Failure`` saying why it found nothing), ``from_gen_fn`` (a generator: each
query takes its next item) and ``from_test`` (a boolean test of a stream with no outputs). With
``context=True`` the function also receives the :class:`~planner.streams.StreamContext`: the
symbolic state where the stream's output is needed and the values bound so far (the collision
test reads which blocks stand in the region at that point of the plan).

A sampler that raises is a failed query, not a crashed run; the planner records the error.
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterator, Mapping

from planner.pddl import Problem
from planner.streams import (
    Failure,
    StreamAdapter,
    StreamContext,
    from_fn,
    from_gen_fn,
    from_test,
)

from .scene import overlap, tabletop
from .values import Conf2D, Grasp2D, Path2D, Pose2D

LIFT_S = 1.0  # seconds to lift and lower the gripper around a move
GRASP_STEPS = (0.0, -0.5, 0.5, -0.25, 0.25)  # grasp offsets tried first, in half-widths


def bindings(problem: Problem, rng: random.Random) -> Mapping[str, StreamAdapter]:
    """Stream name -> sampler, for ``problem``; ``rng`` is the run's seeded generator."""
    top = tabletop(problem)

    def sample_grasp(block: str) -> Iterator[tuple[Grasp2D]]:
        half = top.block(block).size[0] / 2 * 0.8
        for step in GRASP_STEPS:
            yield (Grasp2D(step * half),)
        while True:
            yield (Grasp2D(rng.uniform(-half, half)),)

    def sample_pose(block: str, region: str) -> tuple[Pose2D] | Failure:
        xmin, xmax, ymin, ymax = top.region(region).box
        w, d = top.block(block).size
        if xmax - xmin < w or ymax - ymin < d:
            return Failure(f"region {region} is smaller than block {block}")
        x = rng.uniform(xmin + w / 2, xmax - w / 2)
        y = rng.uniform(ymin + d / 2, ymax - d / 2)
        return (Pose2D(x, y),)

    def test_cfree(
        block: str, pose: Pose2D, region: str, *, context: StreamContext
    ) -> bool | Failure:
        size = top.block(block).size
        inside = {args[0] for args in context.holds("in") if args[1] == region}
        for other, where in context.holds("at"):
            if other == block or other not in inside:
                continue
            other_pose = context.values.get(where)
            if isinstance(other_pose, Pose2D) and overlap(
                pose, size, other_pose, top.block(other).size
            ):
                return Failure(f"overlaps {other}")
        return True

    def inverse_kinematics(block: str, pose: Pose2D, grasp: Grasp2D) -> tuple[Conf2D] | Failure:
        x, y = pose.x + grasp.dx, pose.y
        distance = math.dist(top.base, (x, y))
        if distance > top.reach:
            return Failure(f"out of reach: {distance:.2f} m > {top.reach:.2f} m")
        return (Conf2D(x, y),)

    def plan_motion(start: Conf2D, end: Conf2D) -> tuple[Path2D]:
        length = math.dist((start.x, start.y), (end.x, end.y))
        return (Path2D(start, end, length / top.speed + LIFT_S),)

    return {
        "sample-grasp": from_gen_fn(sample_grasp),
        "sample-pose": from_fn(sample_pose),
        "test-cfree": from_test(test_cfree, context=True),
        "inverse-kinematics": from_fn(inverse_kinematics),
        "plan-motion": from_fn(plan_motion),
    }

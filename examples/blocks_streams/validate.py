"""The blocksworld's plan validator: the plan replayed on the stacks, step by step.

A block moves only when it is clear and on the support the step names, onto a clear support it
may stand on; its carry must start at its stack's top and end on the destination's, and the arm
must hold its weight that far out. At the end every goal fact holds. The first violation is
reported with its step; the seconds are the carries'.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from planner.abstract import GroundAction
from planner.domains import PlanCheck
from planner.pddl import Problem

from .primitives import Carry, column_and_top, get_fits_test, get_stackable_test
from .scene import world_of

TOLERANCE = 1e-6


def validate(
    actions: Sequence[GroundAction], values: Mapping[str, Any], problem: Problem
) -> PlanCheck:
    world = world_of(problem)
    every = {**problem.values, **values}

    def name(x: str) -> str:
        return str(every.get(x, x))

    on = {name(a.args[0]): name(a.args[1]) for a in problem.init if a.predicate == "on"}
    fits, stackable = get_fits_test(world), get_stackable_test(world)
    seconds = 0.0
    for step, act in enumerate(actions):
        where = f"step {step + 1} ({act})"
        b, x, y = (name(a) for a in act.args[:3])
        carry = every.get(act.args[3])
        covered = set(on.values())
        if on.get(b) != x:
            return PlanCheck(False, f"{where}: {b} is not on {x}")
        if b in covered or y in covered or y == b:
            return PlanCheck(False, f"{where}: {b} or {y} is not clear")
        ok = stackable(b, y) if y in world.blocks else fits(b, y)
        if not ok:
            return PlanCheck(False, f"{where}: {b} may not stand on {y}")
        if not isinstance(carry, Carry) or carry.block != b:
            return PlanCheck(False, f"{where}: {act.args[3]} is not a carry of {b}")
        start, end = column_and_top(world, on, x), column_and_top(world, on, y)
        if math.dist(start, carry.start) > TOLERANCE or math.dist(end, carry.end) > TOLERANCE:
            return PlanCheck(False, f"{where}: the carry does not go from {x}'s top to {y}'s")
        reach = max(abs(start[0] - world.base_x), abs(end[0] - world.base_x))
        if world.blocks[b].weight * reach > world.moment + TOLERANCE:
            return PlanCheck(False, f"{where}: {b} is too heavy to hold that far out")
        on[b] = y
        seconds += carry.seconds
    for lit in problem.goal:
        if lit.positive and lit.atom.predicate == "on":
            b, y = (name(a) for a in lit.atom.args)
            if on.get(b) != y:
                return PlanCheck(False, f"goal {lit.atom}: {b} ends on {on.get(b)}")
    return PlanCheck(True, f"valid (replayed: {len(actions)} carries)", seconds)

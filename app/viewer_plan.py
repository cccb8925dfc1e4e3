"""A bound kitchen plan as a timeline of the robot's state, for the 3D view to animate (no viser).

:func:`plan_animation` reads a plan file's dict (what
:func:`planner.domains.kitchen.plan_io.plan_to_dict` makes) and replays its actions from the
scene's initial state: each ``move`` plays its trajectory's segments for their seconds, ``pick``
takes the block into the hand, ``place`` and ``cook`` put it down at their pose.
:meth:`PlanAnimation.state_at` gives the base pose, arm joints, what the hand holds and where the
other blocks stand at any second of the plan.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from planner.abstract.skeleton import GroundAction
from planner.domains.kitchen import ARM
from planner.domains.kitchen.geometry import BlockPose, KitchenGeometry
from planner.domains.kitchen.plan_io import FORMAT, PlanFileError, decode
from planner.domains.kitchen.values import BaseConf, Conf, Grasp, Segment, Trajectory
from planner.sim.pr2_model import ARM_JOINTS, BASE_VELOCITY, REST_ARM_CONF, VELOCITY_LIMITS
from planner.sim.transforms import wrap_angle

Held = tuple[str, Grasp]  # a block in the hand and how it is held
T = TypeVar("T")

STILL_ACTIONS = ("clean",)  # kitchen actions that move nothing


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


class PlanAnimation:
    """The robot's state at every second of a plan (real time: a second of the plan is a
    second of the animation)."""

    def __init__(self, phases: Sequence[_Phase], initial: RobotState, final: RobotState) -> None:
        self._phases = tuple(phases)
        self._starts = [p.start for p in self._phases]
        self.initial = initial
        self.final = final
        self.duration = sum(p.seconds for p in self._phases)

    def state_at(self, t: float) -> RobotState:
        """The state ``t`` seconds into the plan (clamped to the plan's span)."""
        if not self._phases:
            return self.final
        if t >= self.duration:
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


def plan_animation(plan: Mapping[str, Any], geometry: KitchenGeometry, seed: int) -> PlanAnimation:
    """Replay ``plan`` from the scene's initial state; :class:`PlanFileError` names what is
    malformed."""
    if plan.get("format") != FORMAT:
        raise PlanFileError(f"format: expected {FORMAT!r}, got {plan.get('format')!r}")
    raw_actions = plan.get("actions")
    raw_values = plan.get("values", {})
    if not isinstance(raw_actions, list) or not all(isinstance(a, str) for a in raw_actions):
        raise PlanFileError("actions: expected a list of strings such as '(move ...)'")
    if not isinstance(raw_values, dict):
        raise PlanFileError("values: expected an object")
    values = {k: decode(v, f"values.{k}") for k, v in raw_values.items()}
    blocks: dict[str, BlockPose] = dict(geometry.initial_poses(seed))
    conf = Conf(geometry.robot.base, geometry.robot.torso, REST_ARM_CONF[ARM])
    initial = RobotState(conf.base, conf.torso, conf.arm, None, dict(blocks))
    held: Held | None = None
    phases: list[_Phase] = []
    t = 0.0
    for step, text in enumerate(raw_actions):
        try:
            act = GroundAction.parse(text)
        except ValueError as exc:
            raise PlanFileError(f"actions[{step}]: {exc}") from exc
        args = [values.get(a, a) for a in act.args]
        where = f"actions[{step}] {text}"
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
            raise PlanFileError(f"{where}: unknown action {act.name!r}")
    final = RobotState(conf.base, conf.torso, conf.arm, held, dict(blocks))
    return PlanAnimation(phases, initial, final)


def _arg(args: Sequence[Any], i: int, kind: type[T], where: str) -> T:
    if i >= len(args) or not isinstance(args[i], kind):
        raise PlanFileError(f"{where}: argument {i + 1} is not a {kind.__name__}")
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
        raise PlanFileError(f"a {seg.kind} segment needs a base pose and arm joints")
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

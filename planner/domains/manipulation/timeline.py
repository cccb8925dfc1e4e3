"""A bound plan played in time for the 3D view: each move's waypoints reached at their seconds
(a :class:`Phase`), the block in the hand riding with the tool, the other blocks where the plan
has put them. A domain's view plays its actions with a :class:`Playback` and gives a
:class:`PlanTimeline` of its own (how its robot's configurations are interpolated and drawn).
"""

from __future__ import annotations

import bisect
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Generic, TypeVar

from planner.abstract.skeleton import GroundAction
from planner.domains.manipulation.problem import UprightPose, block_pose_to_pose
from planner.sim.transforms import Pose
from planner.view import ActionSteps, BodyState

C = TypeVar("C")  # a domain's robot configuration at one moment
T = TypeVar("T")


@dataclass(frozen=True)
class Held:
    """A block in the hand: its pose in the tool frame, and the fingers' joint value closed on
    it."""

    block: str
    in_tool: Pose
    fingers: float


@dataclass(frozen=True)
class PlanState(Generic[C]):
    """The robot and the blocks at one moment of a plan."""

    conf: C
    held: Held | None
    blocks: Mapping[str, UprightPose]  # blocks standing somewhere (not the one in the hand)


@dataclass(frozen=True)
class Phase(Generic[C]):
    """One stretch of motion: its waypoints and the second each is reached, from ``start``;
    the hand and the blocks as they are meanwhile."""

    start: float
    seconds: float
    times: tuple[float, ...]
    points: tuple[C, ...]
    held: Held | None
    blocks: Mapping[str, UprightPose]


def lerp(a: Sequence[float], b: Sequence[float], f: float) -> tuple[float, ...]:
    """The point a share ``f`` of the way from ``a`` to ``b``, straight."""
    return tuple(x + f * (y - x) for x, y in zip(a, b, strict=True))


@dataclass(frozen=True)
class Played:
    """An action as it is played: its name, its arguments' values (a name without one stands
    for itself) and where it stands in the plan."""

    name: str
    args: tuple[Any, ...]
    where: str  # "actions[3] (pick b1 p0-b1 table g1 q1)"

    def arg(self, i: int, kind: type[T]) -> T:
        """Argument ``i``, which must be a ``kind``; a ValueError names the action if not."""
        if i >= len(self.args) or not isinstance(self.args[i], kind):
            raise ValueError(f"{self.where}: argument {i + 1} is not a {kind.__name__}")
        value: T = self.args[i]
        return value


class Playback(Generic[C]):
    """A bound plan played from the problem's start, action by action: the robot's
    configuration ``conf``, the block in the hand, where the others stand, and the phases of the
    moves so far, which end at second ``t``."""

    def __init__(self, conf: C, blocks: Mapping[str, UprightPose]) -> None:
        self.conf = conf
        self.held: Held | None = None
        self.blocks: dict[str, UprightPose] = dict(blocks)
        self.initial = PlanState(conf, None, dict(blocks))
        self.phases: list[Phase[C]] = []
        self.t = 0.0
        self._starts: list[float] = []
        self._labels: list[str] = []

    def actions(
        self, actions: Sequence[GroundAction], values: Mapping[str, Any]
    ) -> Iterator[Played]:
        """Each action as its turn comes, with its arguments' ``values``."""
        for step, act in enumerate(actions):
            self._starts.append(self.t)
            self._labels.append(str(act))
            yield Played(
                act.name, tuple(values.get(a, a) for a in act.args), f"actions[{step}] {act}"
            )

    def move(self, points: Sequence[C], weights: Sequence[float], seconds: float) -> None:
        """A move through ``points`` taking ``seconds``: each step takes its share of them in
        proportion to its weight (what the velocity limits make it take)."""
        total = sum(weights)
        seconds = max(0.0, seconds)
        times = [0.0]
        for i, w in enumerate(weights):
            share = w / total if total > 0 else 1.0 / len(weights)
            times.append(seconds if i == len(weights) - 1 else times[-1] + share * seconds)
        phase = Phase(self.t, seconds, tuple(times), tuple(points), self.held, dict(self.blocks))
        self.phases.append(phase)
        self.t += phase.seconds

    def take(self, held: Held) -> None:
        """The hand closes on ``held.block``, which leaves where it stood."""
        self.held = held
        self.blocks.pop(held.block, None)

    def put(self, block: str, pose: UprightPose) -> None:
        """The hand lets go of ``block`` at ``pose``."""
        self.blocks[block] = pose
        self.held = None

    def final(self) -> PlanState[C]:
        return PlanState(self.conf, self.held, dict(self.blocks))

    def steps(self) -> ActionSteps:
        """When each action played so far starts, and its text."""
        return ActionSteps(tuple(self._starts), tuple(self._labels))


class PlanTimeline(Generic[C]):
    """The robot's and the blocks' states at every second of a plan (a
    :class:`~planner.view.Timeline`; :meth:`state_at` gives the domain's own state). A domain
    names its robot's body and tool link, and says how its configurations are interpolated
    (:meth:`between`) and drawn (:meth:`robot_state`)."""

    robot: ClassVar[str]  # the robot's body name in the view
    tool_link: ClassVar[str]  # the link a held block rides with

    def __init__(
        self,
        phases: Sequence[Phase[C]],
        initial: PlanState[C],
        final: PlanState[C],
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

    def between(self, a: C, b: C, f: float) -> C:
        """The configuration a share ``f`` of the way from ``a`` to ``b``."""
        raise NotImplementedError

    def robot_state(self, state: PlanState[C]) -> BodyState:
        """How the robot is drawn at ``state``."""
        raise NotImplementedError

    def state_at(self, t: float) -> PlanState[C]:
        """The state ``t`` seconds into the plan (clamped to the plan's span)."""
        if not self._phases or t >= self._duration:
            return self.final
        t = max(0.0, t)
        phase = self._phases[max(0, bisect.bisect_right(self._starts, t) - 1)]
        local = t - phase.start
        j = max(0, bisect.bisect_right(phase.times, local) - 1)
        if j >= len(phase.times) - 1:
            conf = phase.points[-1]
        else:
            t0, t1 = phase.times[j], phase.times[j + 1]
            f = 0.0 if t1 <= t0 else (local - t0) / (t1 - t0)
            conf = self.between(phase.points[j], phase.points[j + 1], f)
        return PlanState(conf, phase.held, phase.blocks)

    def at(self, t: float) -> dict[str, BodyState]:
        state = self.state_at(t)
        out = {self.robot: self.robot_state(state)}
        for name in self._blocks:
            if state.held is not None and state.held.block == name:
                position, quat = state.held.in_tool
                out[name] = BodyState(attached=(self.robot, self.tool_link, position, quat))
            elif name in state.blocks:
                position, quat = block_pose_to_pose(state.blocks[name])
                out[name] = BodyState(position, quat)
            else:
                out[name] = BodyState(visible=False)
        return out

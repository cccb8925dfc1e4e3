"""Values the kitchen's samplers produce and consume (what optimistic objects get bound to)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from planner.sim.transforms import Pose

BaseConf = tuple[float, float, float]  # x, y, yaw of base_footprint in the world


@dataclass(frozen=True)
class Grasp:
    """Where the gripper's tool frame sits relative to the block, and how it gets there."""

    kind: Literal["top", "side"]
    tool_in_block: Pose  # the tool frame in the block's frame
    approach: float  # the tool backs off this far along its own x axis before closing


@dataclass(frozen=True)
class Conf:
    """The robot's base pose, torso height and the working arm's seven joints."""

    base: BaseConf
    torso: float
    arm: tuple[float, ...]
    approach_arm: tuple[float, ...] | None = None  # arm joints with the tool backed off

    def __post_init__(self) -> None:
        if len(self.arm) != 7 or (self.approach_arm is not None and len(self.approach_arm) != 7):
            raise ValueError("an arm configuration has 7 joints")


@dataclass(frozen=True)
class Segment:
    """One part of a trajectory: the arm moves with the base still, or the base with the arm
    still."""

    kind: Literal["arm", "base"]
    base: tuple[BaseConf, ...]  # one pose when the arm moves
    arm: tuple[tuple[float, ...], ...]  # one configuration when the base moves
    seconds: float  # duration under the PR2's velocity limits


@dataclass(frozen=True)
class Trajectory:
    start: Conf
    end: Conf
    segments: tuple[Segment, ...]
    holding: str | None  # the block carried, if any

    @property
    def seconds(self) -> float:
        return sum(s.seconds for s in self.segments)

"""What the Panda's samplers produce (block poses, grasps, configurations, trajectories) and their
value types: JSON codecs and feature encoders (``DomainSpec.value_types``).

JSON: ``{"type": "panda_pose", "x", "y", "z", "yaw"}``, ``{"type": "panda_grasp", "yaw",
"height"}``, ``{"type": "panda_conf", "arm", "raised"}`` and ``{"type": "panda_traj", "path",
"seconds", "holding"}``. Features: a pose ``[x, y, z, cos 4yaw, sin 4yaw]`` (a cube looks the
same every quarter turn); a grasp ``[cos yaw, sin yaw, height]``; a configuration its seven joint
angles; a trajectory ``[seconds, waypoints / 10]``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from planner.domains.manipulation.problem import UprightPose
from planner.sim.transforms import Pose, quat_from_euler
from planner.values import JSON, ValueDecodeError, ValueType, numbers

ARM_DOF = 7


@dataclass(frozen=True)
class BlockPose(UprightPose):
    """A block standing upright on the table, in a tray or on a shelf."""


@dataclass(frozen=True)
class Grasp:
    """A top grasp: the hand points down, turned ``yaw`` about the vertical relative to the
    block (its fingers close along the hand's y axis, across two faces of the block when yaw
    is a multiple of 90 degrees), its grasp point ``height`` above the block's centre."""

    yaw: float
    height: float

    def tool_in_block(self, flip: bool = False) -> Pose:
        """The tool frame in the block's frame: pointing down (its z axis along the block's
        -z), its x axis turned ``yaw`` from the block's (a half turn more with ``flip``: the
        hand is symmetric, so either holds the block alike); the fingers close along its y
        axis."""
        yaw = self.yaw + (math.pi if flip else 0.0)
        return ((0.0, 0.0, self.height), quat_from_euler(math.pi, 0.0, yaw))


@dataclass(frozen=True)
class Conf:
    """The arm's seven joint angles holding a block, and the same hand raised above it (the
    trajectories run between raised configurations; the start has ``raised == arm``)."""

    arm: tuple[float, ...]
    raised: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.arm) != ARM_DOF or len(self.raised) != ARM_DOF:
            raise ValueError(f"a Panda configuration has {ARM_DOF} joint angles")


@dataclass(frozen=True)
class Trajectory:
    """Joint-space waypoints from one raised configuration to another, and how long they take
    under the Panda's joint velocity limits."""

    path: tuple[tuple[float, ...], ...]
    seconds: float
    holding: str | None  # the block carried, if any


def _decode_pose(d: Mapping[str, JSON]) -> BlockPose:
    try:
        return BlockPose(*(float(d[k]) for k in ("x", "y", "z", "yaw")))
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueDecodeError(f"expected numbers x, y, z and yaw ({exc})") from None


def _pose_features(d: Mapping[str, JSON]) -> list[float]:
    p = _decode_pose(d)
    return [p.x, p.y, p.z, math.cos(4 * p.yaw), math.sin(4 * p.yaw)]


def _decode_grasp(d: Mapping[str, JSON]) -> Grasp:
    try:
        return Grasp(float(d["yaw"]), float(d["height"]))
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueDecodeError(f"expected numbers yaw and height ({exc})") from None


def _grasp_features(d: Mapping[str, JSON]) -> list[float]:
    g = _decode_grasp(d)
    return [math.cos(g.yaw), math.sin(g.yaw), g.height]


def _decode_conf(d: Mapping[str, JSON]) -> Conf:
    return Conf(
        tuple(numbers(d.get("arm"), ARM_DOF, "arm")),
        tuple(numbers(d.get("raised"), ARM_DOF, "raised")),
    )


def _decode_traj(d: Mapping[str, JSON]) -> Trajectory:
    raw = d.get("path")
    if not isinstance(raw, list) or len(raw) < 2:
        raise ValueDecodeError("path: expected a list of at least two configurations")
    path = tuple(tuple(numbers(q, ARM_DOF, f"path[{i}]")) for i, q in enumerate(raw))
    seconds = d.get("seconds")
    if isinstance(seconds, bool) or not isinstance(seconds, int | float) or seconds < 0:
        raise ValueDecodeError(f"seconds: expected a number >= 0, got {seconds!r}")
    holding = d.get("holding")
    return Trajectory(path, float(seconds), holding if isinstance(holding, str) else None)


def _traj_features(d: Mapping[str, JSON]) -> list[float]:
    path = d.get("path")
    return [float(d.get("seconds", 0.0)), len(path) / 10 if isinstance(path, list) else 0.0]


def _rounded(values: Sequence[float]) -> list[float]:
    return [round(float(v), 6) for v in values]


POSE = ValueType(
    "panda_pose",
    BlockPose,
    lambda p: {"x": p.x, "y": p.y, "z": p.z, "yaw": p.yaw},
    _decode_pose,
    _pose_features,
    5,
    label=lambda d: f"pose x {float(d['x']):.3f} y {float(d['y']):.3f} z {float(d['z']):.3f}",
)
GRASP = ValueType(
    "panda_grasp",
    Grasp,
    lambda g: {"yaw": g.yaw, "height": g.height},
    _decode_grasp,
    _grasp_features,
    3,
    label=lambda d: f"top grasp, yaw {math.degrees(float(d['yaw'])):.0f} deg",
)
CONF = ValueType(
    "panda_conf",
    Conf,
    lambda c: {"arm": _rounded(c.arm), "raised": _rounded(c.raised)},
    _decode_conf,
    lambda d: numbers(d.get("arm"), ARM_DOF, "arm"),
    ARM_DOF,
    label=lambda d: "arm " + " ".join(f"{v:.2f}" for v in numbers(d.get("arm"), 7, "arm")),
)
TRAJECTORY = ValueType(
    "panda_traj",
    Trajectory,
    lambda t: {"path": [_rounded(q) for q in t.path], "seconds": t.seconds, "holding": t.holding},
    _decode_traj,
    _traj_features,
    2,
    label=lambda d: f"trajectory {float(d.get('seconds', 0.0)):.2f} s",
)
VALUE_TYPES = (POSE, GRASP, CONF, TRAJECTORY)


def as_pose(value: Any, where: str) -> BlockPose:
    if not isinstance(value, BlockPose):
        raise TypeError(f"{where}: expected a block pose, got {type(value).__name__}")
    return value

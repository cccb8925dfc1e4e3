"""What every robot tells the rest of the project: :class:`Robot`.

A robot's package (``planner/robots/pr2``, ``planner/robots/panda``) exports one, ``ROBOT``, and
keeps everything else about the robot to itself: its model and URDF, meshes, kinematics (IK),
dimensions and how it is drawn. The registry (:mod:`planner.robots`) finds it by name.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True)
class Robot:
    """A robot as a domain names it and generic code uses it."""

    name: str  # what domains call it (``get_robot(name)``)
    description: str  # one line for listings
    # The URDF the planner's pybullet world loads (its collision shapes are what is checked);
    # a function, so that a file made or found on first use is only looked for when needed.
    urdf: Callable[[], Path]
    # The URDF the 3D view and ``tamp render`` draw (its visual meshes); the planner's may be it.
    view_urdf: Callable[[], Path]
    # Joint name -> (lower, upper) position limits (rad or m), and -> velocity limit (rad/s or
    # m/s): what trajectories are timed with.
    joint_limits: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    velocity_limits: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.name.replace("-", "_").isidentifier():
            raise ValueError(f"robot name {self.name!r}: letters, digits, '-' and '_' only")
        for joint, (lo, hi) in self.joint_limits.items():
            if not lo <= hi:
                raise ValueError(f"robot {self.name}: joint {joint} has limits [{lo}, {hi}]")
        for joint, v in self.velocity_limits.items():
            if not v > 0:
                raise ValueError(f"robot {self.name}: joint {joint} has velocity limit {v}")

    def velocities(self, joints: Sequence[str]) -> tuple[float, ...]:
        """The velocity limits of ``joints``, in their order."""
        return tuple(self.velocity_limits[j] for j in joints)


def step_seconds(a: Sequence[float], b: Sequence[float], velocities: Sequence[float]) -> float:
    """Seconds to go straight from joint values ``a`` to ``b`` at the pace of the slowest joint
    under its velocity limit (``velocities``, in the same order)."""
    return max(abs(y - x) / v for x, y, v in zip(a, b, velocities, strict=True))


def path_seconds(path: Sequence[Sequence[float]], velocities: Sequence[float]) -> float:
    """Seconds to follow joint-space waypoints, each step as :func:`step_seconds` times it."""
    seconds = 0.0
    for a, b in itertools.pairwise(path):
        seconds += step_seconds(a, b, velocities)
    return seconds

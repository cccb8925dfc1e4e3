"""Robots as plug-ins: a small explicit registry (docs/sim.md).

A robot is a package whose ``robot`` module exports a :class:`~planner.robots.base.Robot` as
``ROBOT``; the package holds all that is particular to the robot: its model or URDF, meshes,
kinematics, dimensions and visuals. Files it ships (the PR2's URDF and meshes) are package data,
installed with the wheel.
Two come with the project:

- ``pr2``: :mod:`planner.robots.pr2`, the generated PR2 and its IKFast arms (the kitchen's);
- ``panda``: :mod:`planner.robots.panda`, pybullet_data's Franka Panda (the Panda tabletop's).

A domain names its robot (``get_robot("pr2")``); generic code reaches robots only through here
and never imports a particular one. A robot of another package joins with
:func:`register_robot`. Asking for an unknown name raises :class:`UnknownRobotError`, which lists
the known ones.
"""

from __future__ import annotations

import importlib

from planner.robots.base import Robot

# name -> "module:attribute" of its Robot, imported when first asked for.
_BUILT_IN: dict[str, str] = {
    "panda": "planner.robots.panda.robot:ROBOT",
    "pr2": "planner.robots.pr2.robot:ROBOT",
}
_REGISTERED: dict[str, Robot] = {}


class UnknownRobotError(LookupError):
    """No robot of that name; the message lists the known ones."""


def known_robots() -> tuple[str, ...]:
    """The names :func:`get_robot` knows, sorted."""
    return tuple(sorted({*_BUILT_IN, *_REGISTERED}))


def register_robot(robot: Robot) -> None:
    """Make ``robot`` known by its name (a robot of a package outside the project). A name
    already taken by another robot raises ValueError; registering the same robot again does
    nothing."""
    if not isinstance(robot, Robot):
        raise TypeError(f"register_robot takes a Robot, got {type(robot).__name__}")
    if robot.name in _BUILT_IN or _REGISTERED.get(robot.name, robot) is not robot:
        raise ValueError(f"robot name {robot.name!r} is already taken")
    _REGISTERED[robot.name] = robot


def get_robot(name: str) -> Robot:
    """The robot called ``name``; :class:`UnknownRobotError` lists the known names."""
    found = _REGISTERED.get(name)
    if found is not None:
        return found
    ref = _BUILT_IN.get(name)
    if ref is None:
        raise UnknownRobotError(
            f"unknown robot {name!r} (known robots: {', '.join(known_robots())})"
        )
    module, _, attribute = ref.partition(":")
    robot = getattr(importlib.import_module(module), attribute)
    if not isinstance(robot, Robot) or robot.name != name:
        raise TypeError(f"{ref} is not the Robot {name!r}")
    return robot


__all__ = ["Robot", "UnknownRobotError", "get_robot", "known_robots", "register_robot"]

"""The Panda as the registry (:mod:`planner.robots`) hands it out."""

from __future__ import annotations

from pathlib import Path

from planner.robots.base import Robot
from planner.robots.panda.model import JOINT_LIMITS, VELOCITY_LIMITS, urdf_path


def _view_urdf() -> Path:
    from planner.robots.panda.visuals import viewer_urdf  # trimesh: only when drawn

    return viewer_urdf()


ROBOT = Robot(
    name="panda",
    description="a Franka Panda on a fixed base: a 7-DOF arm and a parallel gripper",
    urdf=urdf_path,
    view_urdf=_view_urdf,
    joint_limits=JOINT_LIMITS,
    velocity_limits=VELOCITY_LIMITS,
)

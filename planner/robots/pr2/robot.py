"""The PR2 as the registry (:mod:`planner.robots`) hands it out."""

from __future__ import annotations

from planner.robots.base import Robot
from planner.robots.pr2.model import JOINT_LIMITS, URDF_PATH, VELOCITY_LIMITS

ROBOT = Robot(
    name="pr2",
    description="a PR2 on its mobile base: torso lift, two 7-DOF arms, IKFast",
    urdf=lambda: URDF_PATH,
    view_urdf=lambda: URDF_PATH,  # drawn with the meshes beside it
    joint_limits=JOINT_LIMITS,
    velocity_limits=VELOCITY_LIMITS,
)

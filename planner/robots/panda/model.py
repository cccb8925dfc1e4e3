"""The Franka Panda of ``pybullet_data`` (``franka_panda/panda.urdf``, Apache 2.0, its meshes
beside it; pybullet installs it): joint names, limits and velocities, the hand's geometry, and
the ready configuration.

Limits are the Panda's own (the URDF's ``safety_controller`` soft limits, a little inside its
``limit`` tags); velocities are the URDF's (2.175 rad/s for joints 1-4, 2.61 for 5-7).
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

from planner.robots.base import path_seconds

ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
FINGER_JOINTS = ("panda_finger_joint1", "panda_finger_joint2")
LOWER = (-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973)
UPPER = (2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973)
VELOCITY = (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61)  # rad/s
# The arm over the table, the hand pointing down with its fingers along the world's y axis:
# where the arm starts, and where inverse kinematics starts its first search.
READY = (0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4)

TOOL_LINK = "panda_grasptarget"  # between the fingertips' pads, 0.105 m past the hand's frame
HAND_LINKS = ("panda_hand", "panda_leftfinger", "panda_rightfinger")
BASE_LINK = "panda_link0"  # stands on the table
# A finger's pad is this far inside its joint value: a finger at ``w / 2 + FINGER_PAD`` touches
# a block ``w`` wide (measured at READY: pads at 0.0159 m from the centre with the joint at 0.02).
FINGER_PAD = 0.0041
FINGER_OPEN = 0.029  # each finger with the hand empty: pads 5 cm apart, 5 mm off a 4 cm block
FINGER_MAX = 0.04
FINGER_VELOCITY = 0.2  # m/s, each finger (the URDF's)
JOINT_LIMITS: dict[str, tuple[float, float]] = {
    **{j: (lo, hi) for j, lo, hi in zip(ARM_JOINTS, LOWER, UPPER, strict=True)},
    **{j: (0.0, FINGER_MAX) for j in FINGER_JOINTS},
}
VELOCITY_LIMITS: dict[str, float] = {
    **dict(zip(ARM_JOINTS, VELOCITY, strict=True)),
    **{j: FINGER_VELOCITY for j in FINGER_JOINTS},
}


def finger_joint(width: float) -> float:
    """Each finger's joint value closed on a block ``width`` wide (at most fully open)."""
    return min(FINGER_MAX, width / 2 + FINGER_PAD)


@functools.cache
def urdf_path() -> Path:
    """The Panda's URDF in the installed ``pybullet_data``."""
    import pybullet_data

    path = Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: pybullet_data has no franka_panda (pybullet >= 3.2)")
    return path


def duration(path: list[tuple[float, ...]] | tuple[tuple[float, ...], ...]) -> float:
    """Seconds to follow the arm's joint-space waypoints, each segment at the pace of its slowest
    joint under :data:`VELOCITY`."""
    return path_seconds(path, VELOCITY)


def within_limits(conf: tuple[float, ...] | list[float], tolerance: float = 1e-6) -> bool:
    return all(
        lo - tolerance <= q <= hi + tolerance for q, lo, hi in zip(conf, LOWER, UPPER, strict=True)
    )

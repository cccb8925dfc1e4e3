"""Rigid transforms as (position, quaternion) pairs. Quaternions are pybullet's ``xyzw``;
:func:`to_wxyz` is the one place that converts to viser's ``wxyz``."""

from __future__ import annotations

import math
from collections.abc import Sequence

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # x, y, z, w
Pose = tuple[Vec3, Quat]

IDENTITY: Pose = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))


def to_wxyz(q: Quat) -> tuple[float, float, float, float]:
    """pybullet ``xyzw`` -> viser ``wxyz``."""
    return (q[3], q[0], q[1], q[2])


def quat_multiply(a: Quat, b: Quat) -> Quat:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quat_conjugate(q: Quat) -> Quat:
    return (-q[0], -q[1], -q[2], q[3])


def rotate(q: Quat, v: Sequence[float]) -> Vec3:
    x, y, z, _ = quat_multiply(quat_multiply(q, (v[0], v[1], v[2], 0.0)), quat_conjugate(q))
    return (x, y, z)


def multiply(a: Pose, b: Pose) -> Pose:
    """``a * b``: b expressed in a's frame, brought to a's parent frame."""
    pa, qa = a
    pb, qb = b
    r = rotate(qa, pb)
    return ((pa[0] + r[0], pa[1] + r[1], pa[2] + r[2]), quat_multiply(qa, qb))


def invert(a: Pose) -> Pose:
    p, q = a
    qi = quat_conjugate(q)
    r = rotate(qi, p)
    return ((-r[0], -r[1], -r[2]), qi)


def quat_from_euler(roll: float, pitch: float, yaw: float) -> Quat:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def quat_from_yaw(yaw: float) -> Quat:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def planar_pose(x: float, y: float, yaw: float, z: float = 0.0) -> Pose:
    return ((x, y, z), quat_from_yaw(yaw))


def angle_between(a: Quat, b: Quat) -> float:
    """Rotation angle from a to b, radians."""
    dot = abs(sum(x * y for x, y in zip(a, b, strict=True)))
    return 2 * math.acos(min(1.0, dot))


def wrap_angle(a: float) -> float:
    return math.remainder(a, 2 * math.pi)

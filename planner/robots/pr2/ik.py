"""Inverse kinematics of the PR2 arms: IKFast (``pr2-ikfast``) plus joint-limit filtering.

The solvers in ``pr2_ikfast.ikLeft`` / ``pr2_ikfast.ikRight`` are

- ``get_ik(rotation, position, [torso, upper_arm_roll])``: ``rotation`` is the tool frame's 3x3
  rotation as a list of rows, ``position`` its origin; both in **base_link**, which sits
  :data:`~planner.robots.pr2.dimensions.BASE_LINK_HEIGHT` above ``base_footprint``. The torso
  lift and the upper arm roll are the two free parameters. Returns ``None`` or up to 8 lists
  ``[torso, 7 arm joints]``; joint limits are not checked and continuous joints are not wrapped.
- ``get_fk([torso, 7 arm joints])``: ``[position, rotation rows]`` of the tool frame
  (``{l,r}_gripper_tool_frame``, 0.18 m past the wrist roll joint) in base_link.

This module speaks the rest of the project's language: poses in ``base_footprint``,
quaternions ``xyzw`` like pybullet, solutions within
:data:`~planner.robots.pr2.model.JOINT_LIMITS`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from typing import Any

from pr2_ikfast import ikLeft, ikRight

from planner.robots.pr2.dimensions import BASE_LINK_HEIGHT
from planner.robots.pr2.model import (
    ARM_JOINTS,
    ARMS,
    CONTINUOUS_JOINTS,
    JOINT_LIMITS,
    TORSO_JOINT,
)

logger = logging.getLogger(__name__)

Position = tuple[float, float, float]
Quaternion = tuple[float, float, float, float]  # x, y, z, w (pybullet's order)
Matrix = tuple[Position, Position, Position]  # rows

DEFAULT_ROLL_SAMPLES = 9  # upper arm roll values tried when the caller does not fix it
FK_TOLERANCE = 1e-6  # m (and rotation-matrix entries): IKFast answers that miss by more are dropped
_LIMIT_SLACK = 1e-9  # solutions this close outside a limit are clamped onto it
_DEDUPE_DECIMALS = 9  # solutions equal to this many decimals are reported once

_SOLVERS: dict[str, Any] = {"left": ikLeft, "right": ikRight}


def _check_arm(arm: str) -> None:
    if arm not in ARMS:
        raise ValueError(f"unknown arm {arm!r}; known arms: {', '.join(ARMS)}")


def _check_torso(torso: float) -> None:
    lo, hi = JOINT_LIMITS[TORSO_JOINT]
    if not lo - _LIMIT_SLACK <= torso <= hi + _LIMIT_SLACK:
        raise ValueError(f"torso {torso} outside {TORSO_JOINT} limits [{lo}, {hi}]")


def _quat_to_matrix(quat_xyzw: Sequence[float]) -> Matrix:
    """Rotation matrix (rows) of a quaternion ``xyzw``; it is normalised first."""
    if len(quat_xyzw) != 4:
        raise ValueError(f"quaternion needs 4 values (x, y, z, w), got {len(quat_xyzw)}")
    norm = math.sqrt(sum(v * v for v in quat_xyzw))
    if norm < 1e-9:
        raise ValueError(f"quaternion {tuple(quat_xyzw)} has zero length")
    x, y, z, w = (v / norm for v in quat_xyzw)
    return (
        (1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)),
        (2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)),
        (2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)),
    )


def _matrix_to_quat(rows: Sequence[Sequence[float]]) -> Quaternion:
    """Quaternion ``xyzw`` (with ``w >= 0``) of a rotation matrix given as rows."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = rows
    trace = m00 + m11 + m22
    if trace > 0:
        s = 2 * math.sqrt(trace + 1)
        q = ((m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, s / 4)
    elif m00 > m11 and m00 > m22:
        s = 2 * math.sqrt(1 + m00 - m11 - m22)
        q = (s / 4, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s)
    elif m11 > m22:
        s = 2 * math.sqrt(1 + m11 - m00 - m22)
        q = ((m01 + m10) / s, s / 4, (m12 + m21) / s, (m02 - m20) / s)
    else:
        s = 2 * math.sqrt(1 + m22 - m00 - m11)
        q = ((m02 + m20) / s, (m12 + m21) / s, s / 4, (m10 - m01) / s)
    sign = -1.0 if q[3] < 0 else 1.0
    x, y, z, w = (sign * v for v in q)
    return (x, y, z, w)


def _raw_fk(arm: str, joints: Sequence[float], torso: float) -> tuple[Position, Matrix]:
    """IKFast forward kinematics, in base_link."""
    position, rows = _SOLVERS[arm].get_fk([float(torso), *(float(j) for j in joints)])
    px, py, pz = (float(v) for v in position)
    r0, r1, r2 = (tuple(float(v) for v in row) for row in rows)
    return (px, py, pz), (
        (r0[0], r0[1], r0[2]),
        (r1[0], r1[1], r1[2]),
        (r2[0], r2[1], r2[2]),
    )


def arm_fk(arm: str, joints: Sequence[float], *, torso: float) -> tuple[Position, Quaternion]:
    """Pose of ``arm``'s tool frame in base_footprint: (position, quaternion ``xyzw``)."""
    _check_arm(arm)
    if len(joints) != 7:
        raise ValueError(f"{arm} arm needs 7 joint values {ARM_JOINTS[arm]}, got {len(joints)}")
    (x, y, z), rows = _raw_fk(arm, joints, torso)
    return (x, y, z + BASE_LINK_HEIGHT), _matrix_to_quat(rows)


def _wrap(angle: float) -> float:
    """The angle in [-pi, pi]."""
    return math.remainder(angle, math.tau)


def _within_limits(arm: str, joints: Sequence[float]) -> tuple[float, ...] | None:
    """``joints`` with continuous joints wrapped and tiny overshoots clamped, or None."""
    out = []
    for name, value in zip(ARM_JOINTS[arm], joints, strict=True):
        lo, hi = JOINT_LIMITS[name]
        if name in CONTINUOUS_JOINTS:
            value = _wrap(value)
        if not lo - _LIMIT_SLACK <= value <= hi + _LIMIT_SLACK:
            return None
        out.append(min(max(value, lo), hi))
    return tuple(out)


def _distance(arm: str, a: Sequence[float], b: Sequence[float]) -> float:
    total = 0.0
    for name, u, v in zip(ARM_JOINTS[arm], a, b, strict=True):
        d = _wrap(u - v) if name in CONTINUOUS_JOINTS else u - v
        total += d * d
    return math.sqrt(total)


def _roll_values(arm: str, upper_arm_roll: float | None, samples: int) -> list[float]:
    name = ARM_JOINTS[arm][2]
    lo, hi = JOINT_LIMITS[name]
    if upper_arm_roll is not None:
        if not lo <= upper_arm_roll <= hi:
            raise ValueError(f"upper_arm_roll {upper_arm_roll} outside {name} limits [{lo}, {hi}]")
        return [float(upper_arm_roll)]
    if samples < 1:
        raise ValueError(f"roll_samples must be at least 1, got {samples}")
    return [lo + (hi - lo) * (i + 0.5) / samples for i in range(samples)]


def arm_ik(
    arm: str,
    position: Sequence[float],
    quat_xyzw: Sequence[float],
    *,
    torso: float,
    upper_arm_roll: float | None = None,
    roll_samples: int = DEFAULT_ROLL_SAMPLES,
    nearest_to: Sequence[float] | None = None,
) -> list[tuple[float, ...]]:
    """Arm configurations (7 joints, ARM_JOINTS order) that put ``arm``'s tool frame at a pose.

    The pose is in base_footprint (position in metres, quaternion ``xyzw``). ``torso`` is the
    torso lift, which IKFast treats as given. With ``upper_arm_roll=None``, ``roll_samples``
    evenly spaced values across that joint's range are tried (deterministically). Solutions are
    within JOINT_LIMITS (continuous joints wrapped into [-pi, pi]), verified by forward
    kinematics, without duplicates, and sorted: nearest to ``nearest_to`` first if given, else
    lexicographically. An unreachable pose gives an empty list.
    """
    _check_arm(arm)
    _check_torso(torso)
    if len(position) != 3:
        raise ValueError(f"position needs 3 values (x, y, z), got {len(position)}")
    if nearest_to is not None and len(nearest_to) != 7:
        raise ValueError(f"nearest_to needs 7 joint values, got {len(nearest_to)}")
    rows = _quat_to_matrix(quat_xyzw)
    target = (float(position[0]), float(position[1]), float(position[2]) - BASE_LINK_HEIGHT)
    solver = _SOLVERS[arm]
    found: dict[tuple[float, ...], tuple[float, ...]] = {}
    raw_count = 0
    for roll in _roll_values(arm, upper_arm_roll, roll_samples):
        answers = solver.get_ik([list(r) for r in rows], list(target), [float(torso), roll])
        for answer in answers or ():
            raw_count += 1
            joints = _within_limits(arm, [float(v) for v in answer[1:8]])
            if joints is None or not _reaches(arm, joints, torso, target, rows):
                continue
            found.setdefault(tuple(round(v, _DEDUPE_DECIMALS) for v in joints), joints)
    solutions = sorted(found.values())
    if nearest_to is not None:
        reference = nearest_to
        solutions.sort(key=lambda q: _distance(arm, q, reference))
    logger.debug("%s arm IK: %d IKFast answers, %d within limits", arm, raw_count, len(solutions))
    return solutions


def _reaches(
    arm: str, joints: Sequence[float], torso: float, target: Position, rows: Matrix
) -> bool:
    position, got = _raw_fk(arm, joints, torso)
    if math.dist(position, target) > FK_TOLERANCE:
        return False
    return all(
        abs(a - b) <= FK_TOLERANCE
        for ra, rb in zip(got, rows, strict=True)
        for a, b in zip(ra, rb, strict=True)
    )

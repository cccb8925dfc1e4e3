"""A generated PR2 model whose arm kinematics match the ``pr2-ikfast`` solver.

No PR2 URDF with meshes can be installed here, so the project builds its own from the robot's
published dimensions (the public ``pr2_description`` kinematics, in
:mod:`planner.robots.pr2.dimensions`) and joint limits. Each link's collision geometry is a few
boxes, cylinders and spheres (what the planner checks); what is drawn is a set of meshes shaped
and coloured like the PR2 (:mod:`planner.robots.pr2.visuals`, ``meshes/`` beside the URDF). The
kinematic chain
(``base_footprint`` -> ``base_link`` -> torso -> shoulder -> ... -> ``{l,r}_gripper_tool_frame``)
uses the same joint origins as the IKFast solver, so forward kinematics in pybullet and
``pr2_ikfast`` agree (checked by ``tests/sim/test_pr2_model.py``).

The base moves in the plane by setting the pose of ``base_footprint`` in the simulator; the URDF
has no planar joints.

``python -m planner.robots.pr2.model --write`` writes ``pr2.urdf`` and its meshes into this
package (they ship in the wheel); ``--check`` exits 1 when a committed file differs from what the
generator makes (or a mesh file is left over).
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal
from xml.sax.saxutils import quoteattr

# What the meshes are built from too; still importable from here.
from planner.robots.pr2.dimensions import (
    BASE_LINK,
    BASE_LINK_HEIGHT,
    BASE_SIZE,
    FINGER_LENGTH,
    FINGER_ORIGIN_X,
    FOREARM_LENGTH,
    HEAD_PAN_ORIGIN,
    HEAD_TILT_ORIGIN,
    MATERIALS,
    PACKAGE_DIR,
    ROOT_LINK,
    SHOULDER_LIFT_X,
    SHOULDER_Y,
    TOOL_LENGTH,
    TORSO_LINK,
    TORSO_ORIGIN,
    UPPER_ARM_LENGTH,
    Vec3,
)

logger = logging.getLogger(__name__)

URDF_PATH = PACKAGE_DIR / "pr2.urdf"

# ---------------------------------------------------------------------------------------------
# Names
# ---------------------------------------------------------------------------------------------

ARMS: tuple[str, ...] = ("left", "right")
_PREFIX = {"left": "l", "right": "r"}

TORSO_JOINT = "torso_lift_joint"
HEAD_JOINTS: tuple[str, ...] = ("head_pan_joint", "head_tilt_joint")

_ARM_JOINT_SUFFIXES = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "upper_arm_roll_joint",
    "elbow_flex_joint",
    "forearm_roll_joint",
    "wrist_flex_joint",
    "wrist_roll_joint",
)
# Seven joints per arm, in the order pr2_ikfast uses (after the torso).
ARM_JOINTS: dict[str, tuple[str, ...]] = {
    arm: tuple(f"{p}_{s}" for s in _ARM_JOINT_SUFFIXES) for arm, p in _PREFIX.items()
}
GRIPPER_JOINTS: dict[str, tuple[str, ...]] = {
    arm: (f"{p}_gripper_l_finger_joint", f"{p}_gripper_r_finger_joint")
    for arm, p in _PREFIX.items()
}
TOOL_LINK: dict[str, str] = {arm: f"{p}_gripper_tool_frame" for arm, p in _PREFIX.items()}
# Links of each arm that move with it (shoulder pan link outward), for collision checks.
ARM_LINKS: dict[str, tuple[str, ...]] = {
    arm: (
        f"{p}_shoulder_pan_link",
        f"{p}_shoulder_lift_link",
        f"{p}_upper_arm_roll_link",
        f"{p}_elbow_flex_link",
        f"{p}_forearm_roll_link",
        f"{p}_wrist_flex_link",
        f"{p}_wrist_roll_link",
        f"{p}_gripper_palm_link",
        f"{p}_gripper_l_finger_link",
        f"{p}_gripper_r_finger_link",
        f"{p}_gripper_tool_frame",
    )
    for arm, p in _PREFIX.items()
}
# The links rigid below each wrist (the fingers at a fixed opening): placed by the tool's pose.
GRIPPER_LINKS: dict[str, tuple[str, ...]] = {
    arm: (f"{p}_gripper_palm_link", f"{p}_gripper_l_finger_link", f"{p}_gripper_r_finger_link")
    for arm, p in _PREFIX.items()
}
# Joints without limits; JOINT_LIMITS gives them (-pi, pi), the range angles are wrapped into.
CONTINUOUS_JOINTS: frozenset[str] = frozenset(
    f"{p}_{s}" for p in _PREFIX.values() for s in ("forearm_roll_joint", "wrist_roll_joint")
)

# ---------------------------------------------------------------------------------------------
# Limits: position (rad or m) and velocity (rad/s or m/s), as on the real robot.
# ---------------------------------------------------------------------------------------------

_HALF_PI = math.pi / 2
_ARM_LIMITS: dict[str, tuple[float, float]] = {
    "shoulder_pan_joint": (-0.714601836603, 2.2853981634),  # left arm; mirrored for right
    "shoulder_lift_joint": (-0.5236, 1.3963),
    "upper_arm_roll_joint": (-0.8, 3.9),  # left arm; mirrored for right
    "elbow_flex_joint": (-2.3213, 0.0),
    "forearm_roll_joint": (-math.pi, math.pi),  # continuous
    "wrist_flex_joint": (-2.18, 0.0),
    "wrist_roll_joint": (-math.pi, math.pi),  # continuous
}
_MIRRORED = frozenset({"shoulder_pan_joint", "upper_arm_roll_joint"})
_ARM_VELOCITIES: dict[str, float] = {
    "shoulder_pan_joint": 2.088,
    "shoulder_lift_joint": 2.082,
    "upper_arm_roll_joint": 3.27,
    "elbow_flex_joint": 3.3,
    "forearm_roll_joint": 3.6,
    "wrist_flex_joint": 3.078,
    "wrist_roll_joint": 3.6,
}
_ARM_EFFORTS: dict[str, float] = {
    "shoulder_pan_joint": 30.0,
    "shoulder_lift_joint": 30.0,
    "upper_arm_roll_joint": 30.0,
    "elbow_flex_joint": 30.0,
    "forearm_roll_joint": 30.0,
    "wrist_flex_joint": 10.0,
    "wrist_roll_joint": 10.0,
}
FINGER_TRAVEL = 0.045  # each finger; the gripper opens 0.09 m like the real PR2


def _arm_limit(arm: str, suffix: str) -> tuple[float, float]:
    lo, hi = _ARM_LIMITS[suffix]
    return (-hi, -lo) if arm == "right" and suffix in _MIRRORED else (lo, hi)


JOINT_LIMITS: dict[str, tuple[float, float]] = {
    TORSO_JOINT: (0.0, 0.33),
    "head_pan_joint": (-3.007, 3.007),
    "head_tilt_joint": (-0.471238, 1.39626),
    **{
        f"{_PREFIX[arm]}_{suffix}": _arm_limit(arm, suffix)
        for arm in ARMS
        for suffix in _ARM_JOINT_SUFFIXES
    },
    **{joint: (0.0, FINGER_TRAVEL) for arm in ARMS for joint in GRIPPER_JOINTS[arm]},
}
VELOCITY_LIMITS: dict[str, float] = {
    TORSO_JOINT: 0.013,  # m/s: the real torso is slow
    "head_pan_joint": 6.0,
    "head_tilt_joint": 5.0,
    **{f"{p}_{s}": v for p in _PREFIX.values() for s, v in _ARM_VELOCITIES.items()},
    **{joint: 0.2 for arm in ARMS for joint in GRIPPER_JOINTS[arm]},  # m/s per finger
}
# Planar base: (linear m/s, angular rad/s), the usual navigation limits (hardware: ~1 m/s).
BASE_VELOCITY: tuple[float, float] = (0.5, 1.0)

# Arms folded in front of the shoulders (upper arm down, forearm folded back up along it, gripper
# pointing up), clear of the base, torso, head and each other by >2 cm and inside the base
# footprint at any torso height: the pose to carry while the base moves. Ordered as ARM_JOINTS;
# the right arm mirrors the left.
REST_ARM_CONF: dict[str, tuple[float, ...]] = {
    "left": (0.0, 1.17, 3.34, -2.25, 0.0, -1.7, 0.0),
    "right": (0.0, 1.17, -3.34, -2.25, 0.0, -1.7, 0.0),
}

# ---------------------------------------------------------------------------------------------
# Model description
# ---------------------------------------------------------------------------------------------

ShapeKind = Literal["box", "cylinder", "sphere"]
JointKind = Literal["fixed", "revolute", "continuous", "prismatic"]


@dataclass(frozen=True)
class Shape:
    """One collision primitive of a link, in the link frame; cylinders run along their local z
    axis. (What is drawn is the link's meshes, :mod:`planner.robots.pr2.visuals`.)"""

    kind: ShapeKind
    size: tuple[float, ...]  # box: (x, y, z); cylinder: (radius, length); sphere: (radius,)
    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        expected = {"box": 3, "cylinder": 2, "sphere": 1}[self.kind]
        if len(self.size) != expected or any(s <= 0 for s in self.size):
            raise ValueError(f"{self.kind} needs {expected} positive sizes, got {self.size}")


@dataclass(frozen=True)
class Link:
    name: str
    mass: float  # kg, roughly the real link's; inertia is a small diagonal (the sim is kinematic)
    shapes: tuple[Shape, ...] = ()

    def __post_init__(self) -> None:
        if self.mass <= 0:
            raise ValueError(f"link {self.name}: mass must be positive, got {self.mass}")


@dataclass(frozen=True)
class Joint:
    name: str
    kind: JointKind
    parent: str
    child: str
    xyz: Vec3 = (0.0, 0.0, 0.0)
    axis: Vec3 = (0.0, 0.0, 1.0)
    effort: float = 0.0  # N or N m (ignored for fixed joints)

    def __post_init__(self) -> None:
        if self.kind != "fixed" and self.name not in VELOCITY_LIMITS:
            raise ValueError(f"joint {self.name}: no velocity limit")
        if self.kind in ("revolute", "prismatic") and self.name not in JOINT_LIMITS:
            raise ValueError(f"joint {self.name}: no position limits")
        if self.kind == "continuous" and self.name not in CONTINUOUS_JOINTS:
            raise ValueError(f"joint {self.name}: not listed in CONTINUOUS_JOINTS")


@dataclass(frozen=True)
class RobotModel:
    name: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]

    def __post_init__(self) -> None:
        names = [link.name for link in self.links]
        if len(set(names)) != len(names):
            raise ValueError("duplicate link names")
        children = [joint.child for joint in self.joints]
        if sorted(children) != sorted(names[1:]) or names[0] in children:
            raise ValueError("every link but the first must be the child of exactly one joint")
        known = set(names)
        for joint in self.joints:
            if joint.parent not in known:
                raise ValueError(f"joint {joint.name}: unknown parent {joint.parent}")


def _cyl_x(radius: float, length: float, x: float) -> Shape:
    """A cylinder along the link's x axis, centred at ``x``."""
    return Shape("cylinder", (radius, length), (x, 0.0, 0.0), (0.0, _HALF_PI, 0.0))


def _cyl_y(radius: float, length: float) -> Shape:
    """A cylinder along the link's y axis, centred at the origin."""
    return Shape("cylinder", (radius, length), rpy=(_HALF_PI, 0.0, 0.0))


def _base_parts() -> tuple[list[Link], list[Joint]]:
    bx, by, bz = BASE_SIZE
    wheel_z = 0.04 - BASE_LINK_HEIGHT  # wheels of radius 0.04 touch the floor
    casters = tuple(
        Shape("cylinder", (0.04, 0.03), (sx * 0.24, sy * 0.24, wheel_z), (_HALF_PI, 0, 0))
        for sx in (1, -1)
        for sy in (1, -1)
    )
    base = Link(
        BASE_LINK,
        116.0,
        (
            Shape("box", (bx, by, bz), (0.0, 0.0, 0.12)),
            Shape("box", (bx + 0.01, by + 0.01, 0.04), (0.0, 0.0, 0.0)),  # bumper
            Shape("box", (0.06, 0.1, 0.04), (bx / 2 - 0.02, 0.0, 0.29)),  # base laser
            *casters,
        ),
    )
    torso = Link(
        TORSO_LINK,
        36.0,
        (
            Shape("box", (0.22, 0.3, 0.9), (-0.15, 0.0, -0.28)),  # spine
            Shape("box", (0.3, 0.56, 0.06), (-0.08, 0.0, 0.2)),  # top
        ),
    )
    links = [Link(ROOT_LINK, 0.01), base, torso]
    joints = [
        Joint("base_footprint_joint", "fixed", ROOT_LINK, BASE_LINK, (0.0, 0.0, BASE_LINK_HEIGHT)),
        Joint(TORSO_JOINT, "prismatic", BASE_LINK, TORSO_LINK, TORSO_ORIGIN, effort=10000.0),
    ]
    return links, joints


def _head_parts() -> tuple[list[Link], list[Joint]]:
    pan = Link(
        "head_pan_link",
        6.3,
        (Shape("cylinder", (0.05, 0.15), (0.0, 0.0, -0.075)),),
    )
    tilt = Link(
        "head_tilt_link",
        4.5,
        (
            Shape("box", (0.14, 0.32, 0.1), (0.0, 0.0, 0.03)),
            Shape("box", (0.07, 0.28, 0.045), (0.01, 0.0, 0.105)),  # depth camera
        ),
    )
    joints = [
        Joint("head_pan_joint", "revolute", TORSO_LINK, pan.name, HEAD_PAN_ORIGIN, effort=2.6),
        Joint(
            "head_tilt_joint",
            "revolute",
            pan.name,
            tilt.name,
            HEAD_TILT_ORIGIN,
            (0.0, 1.0, 0.0),
            effort=18.0,
        ),
    ]
    return [pan, tilt], joints


def _arm_parts(arm: str) -> tuple[list[Link], list[Joint]]:
    p = _PREFIX[arm]
    side = 1.0 if arm == "left" else -1.0
    x_axis, y_axis, z_axis = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    fy = FINGER_LENGTH
    links = [
        Link(
            f"{p}_shoulder_pan_link",
            25.8,
            (Shape("cylinder", (0.09, 0.3), (0.0, 0.0, -0.08)),),
        ),
        Link(f"{p}_shoulder_lift_link", 2.3, (Shape("sphere", (0.085,)),)),
        Link(
            f"{p}_upper_arm_roll_link",
            6.1,
            (
                _cyl_x(0.065, 0.28, 0.2),
                _cyl_x(0.075, 0.06, 0.06),
            ),
        ),
        Link(f"{p}_elbow_flex_link", 1.9, (_cyl_y(0.055, 0.12),)),
        Link(
            f"{p}_forearm_roll_link",
            2.7,
            (_cyl_x(0.05, 0.22, 0.16), _cyl_x(0.055, 0.05, 0.05)),
        ),
        Link(f"{p}_wrist_flex_link", 0.6, (_cyl_y(0.04, 0.08),)),
        Link(f"{p}_wrist_roll_link", 0.1, (_cyl_x(0.035, 0.03, 0.015),)),
        Link(
            f"{p}_gripper_palm_link",
            0.58,
            (Shape("box", (0.1, 0.1, 0.05), (0.08, 0.0, 0.0)),),
        ),
        Link(
            f"{p}_gripper_l_finger_link",
            0.17,
            (Shape("box", (fy, 0.012, 0.025), (fy / 2, 0.006, 0.0)),),
        ),
        Link(
            f"{p}_gripper_r_finger_link",
            0.17,
            (Shape("box", (fy, 0.012, 0.025), (fy / 2, -0.006, 0.0)),),
        ),
        Link(f"{p}_gripper_tool_frame", 0.001),
    ]
    names = [link.name for link in links]
    kinds: tuple[JointKind, ...] = (
        "revolute",
        "revolute",
        "revolute",
        "revolute",
        "continuous",
        "revolute",
        "continuous",
    )
    origins: tuple[Vec3, ...] = (
        (0.0, side * SHOULDER_Y, 0.0),
        (SHOULDER_LIFT_X, 0.0, 0.0),
        (0.0, 0.0, 0.0),
        (UPPER_ARM_LENGTH, 0.0, 0.0),
        (0.0, 0.0, 0.0),
        (FOREARM_LENGTH, 0.0, 0.0),
        (0.0, 0.0, 0.0),
    )
    axes = (z_axis, y_axis, x_axis, y_axis, x_axis, y_axis, x_axis)
    parents = [TORSO_LINK, *names[:6]]
    joints = [
        Joint(name, kind, parent, child, xyz, axis, _ARM_EFFORTS[suffix])
        for name, suffix, kind, parent, child, xyz, axis in zip(
            ARM_JOINTS[arm],
            _ARM_JOINT_SUFFIXES,
            kinds,
            parents,
            names[:7],
            origins,
            axes,
            strict=True,
        )
    ]
    palm, lf, rf, tool = names[7:]
    l_joint, r_joint = GRIPPER_JOINTS[arm]
    joints += [
        Joint(f"{p}_gripper_palm_joint", "fixed", names[6], palm),
        Joint(l_joint, "prismatic", palm, lf, (FINGER_ORIGIN_X, 0.0, 0.0), y_axis, 100.0),
        Joint(r_joint, "prismatic", palm, rf, (FINGER_ORIGIN_X, 0.0, 0.0), (0.0, -1.0, 0.0), 100.0),
        Joint(f"{p}_gripper_tool_joint", "fixed", palm, tool, (TOOL_LENGTH, 0.0, 0.0)),
    ]
    return links, joints


def pr2_model() -> RobotModel:
    """The PR2 as links and joints (the source of the generated URDF)."""
    links, joints = _base_parts()
    for part in (_head_parts(), *(_arm_parts(arm) for arm in ARMS)):
        links += part[0]
        joints += part[1]
    return RobotModel("pr2", tuple(links), tuple(joints))


# ---------------------------------------------------------------------------------------------
# URDF text
# ---------------------------------------------------------------------------------------------


def _num(value: float) -> str:
    """Shortest text that reads back as the same float (so the URDF holds the exact limits)."""
    text = repr(round(float(value), 12)).removesuffix(".0")
    return "0" if text == "-0" else text


def _nums(values: Sequence[float]) -> str:
    return " ".join(_num(v) for v in values)


def _geometry(shape: Shape) -> str:
    if shape.kind == "box":
        return f'<box size="{_nums(shape.size)}"/>'
    if shape.kind == "cylinder":
        radius, length = shape.size
        return f'<cylinder radius="{_num(radius)}" length="{_num(length)}"/>'
    return f'<sphere radius="{_num(shape.size[0])}"/>'


def _link_xml(link: Link, visuals: Sequence[tuple[str, str]]) -> list[str]:
    """A link's element: its inertia, its ``visuals`` (mesh file, material) and its collision
    shapes."""
    inertia = _num(0.01 * link.mass)
    lines = [
        f"  <link name={quoteattr(link.name)}>",
        "    <inertial>",
        f'      <mass value="{_num(link.mass)}"/>',
        f'      <inertia ixx="{inertia}" ixy="0" ixz="0" iyy="{inertia}" iyz="0" izz="{inertia}"/>',
        "    </inertial>",
    ]
    for mesh, material in visuals:
        lines += [
            "    <visual>",
            '      <origin xyz="0 0 0" rpy="0 0 0"/>',
            f"      <geometry><mesh filename={quoteattr(mesh)}/></geometry>",
            f"      <material name={quoteattr(material)}/>",
            "    </visual>",
        ]
    for shape in link.shapes:
        lines += [
            "    <collision>",
            f'      <origin xyz="{_nums(shape.xyz)}" rpy="{_nums(shape.rpy)}"/>',
            f"      <geometry>{_geometry(shape)}</geometry>",
            "    </collision>",
        ]
    lines.append("  </link>")
    return lines


def _joint_xml(joint: Joint) -> list[str]:
    lines = [
        f"  <joint name={quoteattr(joint.name)} type={quoteattr(joint.kind)}>",
        f"    <parent link={quoteattr(joint.parent)}/>",
        f"    <child link={quoteattr(joint.child)}/>",
        f'    <origin xyz="{_nums(joint.xyz)}" rpy="0 0 0"/>',
    ]
    if joint.kind != "fixed":
        lines.append(f'    <axis xyz="{_nums(joint.axis)}"/>')
        effort, velocity = _num(joint.effort), _num(VELOCITY_LIMITS[joint.name])
        if joint.kind == "continuous":
            lines.append(f'    <limit effort="{effort}" velocity="{velocity}"/>')
        else:
            lo, hi = JOINT_LIMITS[joint.name]
            lines.append(
                f'    <limit lower="{_num(lo)}" upper="{_num(hi)}" '
                f'effort="{effort}" velocity="{velocity}"/>'
            )
    lines.append("  </joint>")
    return lines


def generate_pr2_urdf() -> str:
    """The URDF text of :func:`pr2_model`, drawn with the meshes of
    :mod:`planner.robots.pr2.visuals`; deterministic, so the committed file can be checked."""
    from planner.robots.pr2.visuals import link_visuals  # trimesh: only the generator needs it

    model = pr2_model()
    lines = [
        '<?xml version="1.0"?>',
        "<!-- Generated by planner/robots/pr2/model.py; do not edit.",
        "     Regenerate with: python -m planner.robots.pr2.model (option: write) -->",
        f"<robot name={quoteattr(model.name)}>",
    ]
    for name, rgba in MATERIALS.items():
        lines.append(f'  <material name="{name}"><color rgba="{_nums(rgba)}"/></material>')
    for link in model.links:
        lines += _link_xml(link, link_visuals(link.name))
    for joint in model.joints:
        lines += _joint_xml(joint)
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def generated_files() -> dict[Path, str]:
    """Every file the generator writes (the URDF and its meshes) -> its text."""
    from planner.robots.pr2.visuals import MESH_DIR, mesh_texts

    files = {URDF_PATH: generate_pr2_urdf()}
    files.update({MESH_DIR / name: text for name, text in mesh_texts().items()})
    return files


def _shown(path: Path) -> str:
    """A generated file's path from the folder that holds ``planner/``."""
    return str(path.relative_to(PACKAGE_DIR.parents[2]))


def stale_files() -> list[str]:
    """What differs from the generator: files missing or out of date, and mesh files it no
    longer makes; empty when everything is up to date."""
    from planner.robots.pr2.visuals import MESH_DIR

    files = generated_files()
    out = [
        f"{_shown(path)} is stale or missing"
        for path, text in files.items()
        if not path.is_file() or path.read_text(encoding="utf-8") != text
    ]
    if MESH_DIR.is_dir():
        out += [
            f"{_shown(path)} is no longer generated"
            for path in sorted(MESH_DIR.iterdir())
            if path not in files
        ]
    return out


def write_files() -> list[Path]:
    """Write the URDF and its meshes, remove mesh files no longer generated; the paths written."""
    from planner.robots.pr2.visuals import MESH_DIR

    files = generated_files()
    MESH_DIR.mkdir(parents=True, exist_ok=True)
    for path in sorted(MESH_DIR.iterdir()):
        if path not in files:
            path.unlink()
    for path, text in files.items():
        path.write_text(text, encoding="utf-8")
    return list(files)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m planner.robots.pr2.model",
        description="Generate the PR2's URDF and its meshes (planner/robots/pr2/).",
    )
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", action="store_true", help=f"write {URDF_PATH} and its meshes")
    mode.add_argument("--check", action="store_true", help="exit 1 if a file is stale")
    args = parser.parse_args(argv)
    if args.write:
        written = write_files()
        print(f"wrote {URDF_PATH} and {len(written) - 1} meshes")
        return 0
    stale = stale_files()
    for line in stale:
        print(f"{line}; run: python -m planner.robots.pr2.model --write", file=sys.stderr)
    if stale:
        return 1
    print(f"{URDF_PATH} and its meshes are up to date")
    return 0


if __name__ == "__main__":
    sys.exit(main())

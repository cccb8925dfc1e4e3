"""What the generated PR2 looks like: each link's visual meshes, from the robot's published
dimensions, in its colours (``meshes/*.obj`` in this package, referenced by ``pr2.urdf``).

Drawn only: the collision geometry of :mod:`planner.robots.pr2.model` is what the planner checks,
and every mesh stays within about 2 cm of its link's collision shapes
(``tests/sim/test_pr2_visuals.py``), so what is seen is what collides. The shapes:

- the base: a square shell with rounded edges over a lower body cut back at the corners,
  where the four casters (a swivel housing and two wheels each) stand; a dark bumper round
  the bottom; the base laser at the front;
- the torso: the lift column with its front panel, and the plate that carries the shoulders;
- the head: the pan neck and plate, the tilting sensor head with its stereo pairs and the
  camera between them behind a dark face plate, the depth camera on top;
- each arm: the white shoulder shell, the shoulder lift joint, the upper arm (a grey roll
  collar, a tapering white shell), the elbow, the forearm (collar and shell), the wrist flex
  and roll joints, the palm and two fingers with their pads.

One mesh per link and colour; the arms' links share theirs (``l_`` and ``r_`` are the same
shapes). ``python -m planner.robots.pr2.model --write`` writes them with the URDF.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import trimesh

from planner.robots.pr2.dimensions import (
    BASE_LINK,
    BASE_LINK_HEIGHT,
    BASE_SIZE,
    FINGER_LENGTH,
    MATERIALS,
    PACKAGE_DIR,
    ROOT_LINK,
    TORSO_LINK,
)
from planner.sim import meshes as m

MESH_FOLDER = "meshes"  # beside pr2.urdf, which names its files relative to itself
MESH_DIR = PACKAGE_DIR / MESH_FOLDER
ARM_SECTIONS = 14  # segments round the arms' round parts
DETAIL_SECTIONS = 10  # and round small details (lenses, caps, wheels)
CASTER_XY = 0.24  # the casters stand this far from the base's centre along x and y
WHEEL_RADIUS = 0.04
CORNER_CUT = 0.2  # the lower base is cut back this far round each corner, for the casters

Parts = dict[str, list[trimesh.Trimesh]]  # material -> meshes in the link's frame


def _notched_square(half: float, notch: float, segments: int = 4) -> list[tuple[float, float]]:
    """A square's outline with a quarter circle of radius ``notch`` cut round each corner,
    counter-clockwise (star-shaped about the centre, as :func:`meshes.prism` needs)."""
    out = []
    for q, (sx, sy) in enumerate(((1, 1), (-1, 1), (-1, -1), (1, -1))):
        start = math.radians(270 + 90 * q)
        for k in range(segments + 1):
            a = start - math.pi / 2 * k / segments
            out.append((sx * half + notch * math.cos(a), sy * half + notch * math.sin(a)))
    return out


def _base() -> Parts:
    bx, _, bz = BASE_SIZE
    top = 0.12 + bz / 2  # the collision box's top (base_link frame)
    floor = -BASE_LINK_HEIGHT
    wheel_z = floor + WHEEL_RADIUS
    waist = 0.09  # lower body below, shell above
    parts: Parts = {
        "light_grey": [
            m.rounded_box((bx, bx, top - waist), 0.03, at=(0.0, 0.0, (top + waist) / 2)),
            m.prism(_notched_square(bx / 2 - 0.005, CORNER_CUT), -0.03, waist),
        ],
        "dark_grey": [m.prism(_notched_square(bx / 2 + 0.005, CORNER_CUT - 0.01), -0.02, 0.02)],
        "black": [
            m.rounded_box(
                (0.06, 0.1, 0.04), 0.01, at=(bx / 2 - 0.02, 0.0, 0.29), segments=1
            ),  # base laser
        ],
    }
    for sx in (1, -1):
        for sy in (1, -1):
            x, y = sx * CASTER_XY, sy * CASTER_XY
            swivel = (x, y, (waist + wheel_z) / 2)
            parts["dark_grey"] += [
                m.cylinder(0.028, waist - wheel_z, at=swivel, sections=DETAIL_SECTIONS),
                m.cylinder(0.012, 0.05, at=(x, y, wheel_z), axis="y", sections=DETAIL_SECTIONS),
            ]
            parts["black"] += [
                m.cylinder(WHEEL_RADIUS, 0.016, at=(x, y + dy, wheel_z), axis="y", sections=14)
                for dy in (0.021, -0.021)
            ]
    return parts


def _torso() -> Parts:
    return {
        "light_grey": [m.rounded_box((0.22, 0.3, 0.9), 0.02, at=(-0.15, 0.0, -0.28))],  # column
        "dark_grey": [
            m.rounded_box((0.012, 0.18, 0.62), 0.004, at=(-0.037, 0.0, -0.25), segments=1)
        ],
        "white": [m.rounded_box((0.3, 0.56, 0.06), 0.02, at=(-0.08, 0.0, 0.2))],  # shoulder plate
    }


def _head_pan() -> Parts:
    return {
        "dark_grey": [m.cylinder(0.04, 0.13, at=(0.0, 0.0, -0.085), bevel=0.005)],
        "grey": [m.cylinder(0.05, 0.02, at=(0.0, 0.0, -0.01), bevel=0.004)],
    }


def _head_tilt() -> Parts:
    stereo = (0.045, -0.045, 0.11, -0.11)  # the narrow and the wide pair
    lens = DETAIL_SECTIONS
    return {
        "grey": [
            m.rounded_box((0.14, 0.32, 0.1), 0.025, at=(0.0, 0.0, 0.03)),
            *(
                m.cylinder(0.019, 0.008, at=(0.074, y, 0.03), axis="x", sections=lens)
                for y in stereo
            ),
            *(  # the depth camera's projector and cameras
                m.cylinder(0.008, 0.004, at=(0.046, y, 0.105), axis="x", sections=lens)
                for y in (0.06, 0.0, -0.03)
            ),
        ],
        "black": [
            m.rounded_box(
                (0.006, 0.3, 0.06), 0.002, at=(0.071, 0.0, 0.03), segments=1
            ),  # face plate
            *(
                m.cylinder(0.013, 0.01, at=(0.078, y, 0.03), axis="x", sections=lens)
                for y in stereo
            ),
            m.cylinder(0.02, 0.012, at=(0.077, 0.0, 0.03), axis="x", sections=lens),  # camera
            m.rounded_box((0.07, 0.28, 0.045), 0.012, at=(0.01, 0.0, 0.105)),  # depth camera
        ],
    }


def _shoulder_pan() -> Parts:
    return {"white": [m.capsule(0.09, 0.3, at=(0.0, 0.0, -0.08), sections=ARM_SECTIONS)]}


def _flex_joint(
    radius: float, length: float, bevel: float, cap: tuple[float, float], colours: tuple[str, str]
) -> Parts:
    """A joint turning about the link's y axis: a drum with bevelled rims and a cap of (radius,
    thickness) on each end, in (drum, caps) colours."""
    drum, caps = colours
    y = length / 2 + cap[1] / 2
    return {
        drum: [m.cylinder(radius, length, axis="y", bevel=bevel, sections=ARM_SECTIONS)],
        caps: [
            m.cylinder(cap[0], cap[1], at=(0.0, side * y, 0.0), axis="y", sections=DETAIL_SECTIONS)
            for side in (1, -1)
        ],
    }


def _roll_link(collar: tuple[float, float, float], shell: list[tuple[float, float]]) -> Parts:
    """A link turning about its x axis: a grey collar of (radius, length, x) at the joint and a
    white shell of (radius, x) points along the rest."""
    radius, length, x = collar
    ends = [(0.0, shell[0][1]), *shell, (0.0, shell[-1][1])]
    return {
        "grey": [m.cylinder(radius, length, at=(x, 0.0, 0.0), axis="x", bevel=radius * 0.15)],
        "white": [m.lathe(ends, axis="x", sections=ARM_SECTIONS)],
    }


def _shoulder_lift() -> Parts:
    return _flex_joint(0.085, 0.15, 0.025, (0.05, 0.01), ("grey", "dark_grey"))


def _upper_arm() -> Parts:
    shell = [(0.064, 0.09), (0.065, 0.14), (0.062, 0.26), (0.055, 0.31), (0.035, 0.337)]
    return _roll_link((0.075, 0.06, 0.06), shell)


def _elbow() -> Parts:
    return _flex_joint(0.055, 0.1, 0.01, (0.035, 0.01), ("dark_grey", "grey"))


def _forearm() -> Parts:
    shell = [(0.049, 0.075), (0.05, 0.11), (0.046, 0.22), (0.04, 0.255), (0.03, 0.268)]
    return _roll_link((0.055, 0.05, 0.05), shell)


def _wrist_flex() -> Parts:
    return _flex_joint(0.04, 0.07, 0.008, (0.025, 0.006), ("dark_grey", "grey"))


def _wrist_roll() -> Parts:
    return {
        "dark_grey": [
            m.cylinder(
                0.035, 0.03, at=(0.015, 0.0, 0.0), axis="x", bevel=0.005, sections=ARM_SECTIONS
            )
        ]
    }


def _palm() -> Parts:
    return {
        "black": [m.rounded_box((0.1, 0.1, 0.05), 0.012, at=(0.08, 0.0, 0.0))],
        "dark_grey": [  # the flange between wrist and palm
            m.cylinder(0.04, 0.01, at=(0.035, 0.0, 0.0), axis="x", sections=ARM_SECTIONS)
        ],
    }


def _finger(side: float) -> Parts:
    """A finger along x from its joint, on the ``side`` (+1 left, -1 right) of the palm; the
    pad on its inner face, where it meets the block."""
    f = FINGER_LENGTH
    return {
        "dark_grey": [
            m.rounded_box((f, 0.012, 0.025), 0.004, at=(f / 2, side * 0.006, 0.0), segments=1)
        ],
        "black": [
            m.rounded_box((0.03, 0.004, 0.02), 0.0015, at=(0.063, side * 0.001, 0.0), segments=1)
        ],
    }


def _left_finger() -> Parts:
    return _finger(1.0)


def _right_finger() -> Parts:
    return _finger(-1.0)


_PARTS: dict[str, Callable[[], Parts]] = {
    BASE_LINK: _base,
    TORSO_LINK: _torso,
    "head_pan_link": _head_pan,
    "head_tilt_link": _head_tilt,
    "shoulder_pan_link": _shoulder_pan,
    "shoulder_lift_link": _shoulder_lift,
    "upper_arm_roll_link": _upper_arm,
    "elbow_flex_link": _elbow,
    "forearm_roll_link": _forearm,
    "wrist_flex_link": _wrist_flex,
    "wrist_roll_link": _wrist_roll,
    "gripper_palm_link": _palm,
    "gripper_l_finger_link": _left_finger,
    "gripper_r_finger_link": _right_finger,
}
UNDRAWN = frozenset({ROOT_LINK})  # links without a body of their own (and the tool frames)


def visual_shape(link: str) -> str | None:
    """The name of the shape a link is drawn with (an arm's links drop their ``l_``/``r_``);
    None for links that are only frames."""
    shape = link[2:] if link[:2] in ("l_", "r_") else link
    return shape if shape in _PARTS and link not in UNDRAWN else None


@functools.cache
def shape_meshes(shape: str) -> dict[str, trimesh.Trimesh]:
    """Material -> one mesh, in the frame of the links drawn as ``shape``."""
    parts = _PARTS[shape]()
    unknown = set(parts) - set(MATERIALS)
    if unknown:
        raise ValueError(
            f"{shape}: unknown materials {sorted(unknown)}; known: {sorted(MATERIALS)}"
        )
    return {name: m.combine(parts[name]) for name in MATERIALS if name in parts}


def mesh_file(shape: str, material: str) -> str:
    """A mesh's file name, relative to the URDF."""
    return f"{MESH_FOLDER}/{shape}-{material}.obj"


def link_visuals(link: str) -> tuple[tuple[str, str], ...]:
    """(mesh file relative to the URDF, material) of each visual of ``link``."""
    shape = visual_shape(link)
    if shape is None:
        return ()
    return tuple((mesh_file(shape, material), material) for material in shape_meshes(shape))


def mesh_texts() -> dict[str, str]:
    """Every mesh file's name (in :data:`MESH_DIR`) -> its OBJ text."""
    out = {}
    for shape in _PARTS:
        for material, mesh in shape_meshes(shape).items():
            comment = (
                f"Generated by planner/robots/pr2/visuals.py; do not edit.\nPR2 {shape}, {material}"
            )
            out[f"{shape}-{material}.obj"] = m.obj_text(mesh, comment=comment)
    return out

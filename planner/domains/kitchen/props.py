"""The kitchen's fixtures, blocks and floor as meshes for the 3D view and ``tamp render``.

Each platform is drawn as what its kind is, over exactly its footprint and up to exactly its
top (the box the planner checks), so a block stands on what is drawn and nothing drawn sticks
out into the robot's way:

- a table: a wooden top on four legs joined by an apron;
- a sink: a cabinet with a door, a steel counter and the basin set into it, with its drain;
- a stove: a cabinet with an oven door and a knob per burner, a black cooktop with its burners
  (one per 15 cm or so of each side).

Each faces the robot's start with its front (the side with the doors). Blocks are cubes with
rounded edges. The floor is tiled in 50 cm squares, 1.5 m beyond the fixtures and the robot.
The meshes are made with :mod:`planner.sim.meshes` when a scene is first shown and kept in its
cache (named by their content, so a scene of the same sizes reuses them).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import trimesh

from planner.domains.kitchen.geometry import Block, KitchenGeometry, Platform
from planner.domains.manipulation.props import tiled_floor
from planner.sim import meshes as m
from planner.view import Body, Mesh, Meshes, Rgb, yaw_quat

FLOOR_MARGIN = 1.5  # the floor reaches this far beyond the fixtures and the robot's start
STEEL: Rgb = (192, 196, 200)
BASIN: Rgb = (128, 134, 140)
BLACK: Rgb = (22, 22, 24)
BURNER: Rgb = (168, 52, 34)  # a burner's coils, warm
BURNER_PITCH = 0.15  # a stove has about one burner per this much of each side
BLOCK_ROUNDING = 0.1  # a block's edges are rounded by this share of its size
RECESS = 0.012  # a cabinet's front is set back this far for its doors, knobs and handles
HANDLE = 0.005  # radius of a door's handle, which reaches the footprint's front


def _rgb(color: Sequence[float]) -> Rgb:
    return (int(color[0] * 255), int(color[1] * 255), int(color[2] * 255))


def _shade(rgb: Rgb, factor: float) -> Rgb:
    r, g, b = (min(255, int(c * factor)) for c in rgb)
    return (r, g, b)


def _facing(plat: Platform, toward: tuple[float, float]) -> float:
    """The yaw (a multiple of 90 degrees) that turns the platform's front towards ``toward``."""
    dx, dy = toward[0] - plat.center[0], toward[1] - plat.center[1]
    return max(
        (0.0, math.pi / 2, math.pi, -math.pi / 2),
        key=lambda yaw: dx * math.cos(yaw) + dy * math.sin(yaw),
    )


def platform_body(plat: Platform, toward: tuple[float, float]) -> Body:
    """A platform drawn as its kind, its front towards ``toward`` (the robot's start)."""
    yaw = _facing(plat, toward)
    sx, sy, h = plat.size
    depth, width = (sy, sx) if abs(math.sin(yaw)) > 0.5 else (sx, sy)
    parts = _PLATFORMS[plat.kind](round(depth, 6), round(width, 6), round(h, 6), _rgb(plat.color))
    return Body(
        f"platform-{plat.name}",
        Meshes(tuple(parts)),
        (plat.center[0], plat.center[1], 0.0),
        yaw_quat(yaw),
        color=_rgb(plat.color),
        label=plat.name,
    )


def _mesh(stem: str, parts: Sequence[trimesh.Trimesh], rgb: Rgb) -> Mesh:
    return Mesh(m.cached_obj(m.combine(parts), f"kitchen-{stem}"), color=rgb)


# Each platform is built in a frame on the floor under its centre, its front along +x:
# ``depth`` along x, ``width`` along y, ``height`` its top.


def _table(depth: float, width: float, height: float, rgb: Rgb) -> list[Mesh]:
    slab, leg, inset = 0.04, 0.05, 0.05
    x, y = depth / 2 - inset, width / 2 - inset
    legs = [
        m.rounded_box(
            (leg, leg, height - slab), 0.01, at=(sx * x, sy * y, (height - slab) / 2), segments=1
        )
        for sx in (1, -1)
        for sy in (1, -1)
    ]
    apron_z = height - slab - 0.04
    apron = [
        m.rounded_box((2 * x, 0.02, 0.08), 0.005, at=(0.0, sy * y, apron_z), segments=1)
        for sy in (1, -1)
    ] + [
        m.rounded_box((0.02, 2 * y, 0.08), 0.005, at=(sx * x, 0.0, apron_z), segments=1)
        for sx in (1, -1)
    ]
    top = m.rounded_box((depth, width, slab), 0.012, at=(0.0, 0.0, height - slab / 2))
    return [
        _mesh("table-top", [top], rgb),
        _mesh("table-legs", legs + apron, _shade(rgb, 0.72)),
    ]


def _cabinet(depth: float, width: float, height: float, front: float) -> trimesh.Trimesh:
    """The body of a cabinet up to ``height``, its front set back by ``front`` for doors."""
    return m.rounded_box(
        (depth - front, width, height), 0.008, at=(-front / 2, 0.0, height / 2), segments=1
    )


def _door(depth: float, width: float, height: float, z: float) -> trimesh.Trimesh:
    """A door panel in a cabinet's recessed front, its handle's thickness short of the front."""
    thickness = RECESS - HANDLE
    return m.rounded_box(
        (thickness, width, height),
        0.003,
        at=(depth / 2 - RECESS + thickness / 2, 0.0, z),
        segments=1,
    )


def _sink(depth: float, width: float, height: float, rgb: Rgb) -> list[Mesh]:
    counter = 0.03
    body = _cabinet(depth, width, height - counter, RECESS)
    panel = _door(depth, width - 0.04, height - counter - 0.12, (height - counter) / 2 + 0.02)
    handle = m.capsule(
        HANDLE,
        0.1,
        at=(depth / 2 - HANDLE, width / 2 - 0.06, height - counter - 0.12),
        sections=10,
    )
    top = m.rounded_box(
        (depth, width, counter), 0.006, at=(0.0, 0.0, height - counter / 2), segments=1
    )
    basin = m.prism(
        m.rounded_rectangle((depth - 0.07, width - 0.07), 0.03), height - 0.001, height + 0.001
    )
    drain = m.ring(0.008, 0.02, 0.002, at=(0.0, 0.0, height + 0.001))
    return [
        _mesh("sink-cabinet", [body], rgb),
        _mesh("sink-door", [panel], _shade(rgb, 1.12)),
        _mesh("sink-steel", [top, handle], STEEL),
        _mesh("sink-basin", [basin], BASIN),
        _mesh("sink-drain", [drain], BLACK),
    ]


def _burners(depth: float, width: float) -> list[tuple[float, float, float]]:
    """(x, y, radius) of each burner on a cooktop."""
    nx, ny = max(1, round(depth / BURNER_PITCH)), max(1, round(width / BURNER_PITCH))
    radius = 0.38 * min(depth / nx, width / ny)
    return [
        (-depth / 2 + (i + 0.5) * depth / nx, -width / 2 + (j + 0.5) * width / ny, radius)
        for i in range(nx)
        for j in range(ny)
    ]


def _stove(depth: float, width: float, height: float, rgb: Rgb) -> list[Mesh]:
    top = 0.02
    body = _cabinet(depth, width, height - top, RECESS)
    oven = _door(depth, width - 0.04, 0.45 * height, 0.3 * height)
    cooktop = m.rounded_box((depth, width, top), 0.004, at=(0.0, 0.0, height - top / 2), segments=1)
    burners = _burners(depth, width)
    coils = [
        m.ring(0.55 * r, r, 0.002, at=(x, y, height + 0.001), sections=14) for x, y, r in burners
    ] + [m.cylinder(0.3 * r, 0.002, at=(x, y, height + 0.001), sections=10) for x, y, r in burners]
    span = width - 0.08  # the knobs sit in a row under the cooktop, one per burner
    knobs = [
        m.cylinder(
            0.011,
            RECESS,
            at=(depth / 2 - RECESS / 2, (k + 0.5) * span / len(burners) - span / 2, height - 0.065),
            axis="x",
            sections=10,
        )
        for k in range(len(burners))
    ]
    handle = m.capsule(
        HANDLE, width - 0.08, at=(depth / 2 - HANDLE, 0.0, 0.49 * height), axis="y", sections=10
    )
    return [
        _mesh("stove-cabinet", [body], rgb),
        _mesh("stove-front", [oven], BLACK),
        _mesh("stove-top", [cooktop], BLACK),
        _mesh("stove-burners", coils, BURNER),
        _mesh("stove-steel", [*knobs, handle], STEEL),
    ]


_PLATFORMS = {"table": _table, "sink": _sink, "stove": _stove}


def block_shape(block: Block) -> Mesh:
    """A block's cube with rounded edges, in its colour (one file for every block of its size)."""
    size = round(block.size, 6)
    cube = m.rounded_box((size, size, size), BLOCK_ROUNDING * size)
    return _mesh("block", [cube], _rgb(block.color))


def floor_body(geometry: KitchenGeometry) -> Body:
    """The tiled floor under the fixtures and the robot's start, FLOOR_MARGIN beyond them."""
    xs = [x for p in geometry.platforms for x in p.footprint()[:2]] + [geometry.robot.base[0]]
    ys = [y for p in geometry.platforms for y in p.footprint()[2:]] + [geometry.robot.base[1]]
    return tiled_floor((min(xs), max(xs), min(ys), max(ys)), FLOOR_MARGIN, _mesh)

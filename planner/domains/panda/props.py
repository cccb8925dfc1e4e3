"""The Panda's table, its regions and the floor as bodies of the 3D view and ``tamp render``.

The table is a wooden top (its face at z = 0, the slab the planner checks below it) on four
legs joined by an apron, down to the floor ``table.height`` below; the start area is a thin
lighter plate on it; a tray is its floor and rims, a shelf its block (exactly the boxes of
:func:`planner.domains.panda.world.fixture_boxes`). The floor is tiled in 50 cm squares, a metre
beyond the table. The meshes are made with :mod:`planner.sim.meshes` and kept in its cache.
"""

from __future__ import annotations

from collections.abc import Sequence

import trimesh

from planner.domains.manipulation.props import tiled_floor
from planner.domains.panda.geometry import Color, Region, Table
from planner.sim import meshes as m
from planner.view import Body, Box, Mesh, Meshes, Rgb

FLOOR_MARGIN = 1.0  # the floor reaches this far beyond the table
LEG = 0.05  # the legs' square section, metres
LEG_INSET = 0.06  # the legs stand this far inside the top's edges
APRON = 0.08  # the apron under the top is this deep
PLATE = 0.002  # the start area's plate is this thick on the table top
PLATE_TINT = 1.15  # and this much lighter than the table
FIXTURE_ROUNDING = 0.003  # a tray's and a shelf's edges are rounded this much


def rgb(color: Color | Sequence[float]) -> Rgb:
    """A scene colour (0-1) as 0-255."""
    return (round(color[0] * 255), round(color[1] * 255), round(color[2] * 255))


def _shade(color: Rgb, factor: float) -> Rgb:
    r, g, b = (min(255, round(c * factor)) for c in color)
    return (r, g, b)


def _mesh(stem: str, parts: Sequence[trimesh.Trimesh], color: Rgb) -> Mesh:
    return Mesh(m.cached_obj(m.combine(parts), f"panda-{stem}"), color=color)


def table_body(table: Table, thickness: float) -> Body:
    """The table: its top (the planner's slab, ``thickness`` below z = 0) on legs and an apron
    down to the floor."""
    sx, sy = round(table.size[0], 6), round(table.size[1], 6)
    floor = -table.height
    under = -thickness
    top = m.rounded_box((sx, sy, thickness), 0.008, at=(0.0, 0.0, -thickness / 2))
    x, y = sx / 2 - LEG_INSET, sy / 2 - LEG_INSET
    parts = []
    if under - floor > LEG:
        length = under - floor
        parts += [
            m.rounded_box((LEG, LEG, length), 0.008, at=(sx_ * x, sy_ * y, floor + length / 2))
            for sx_ in (1, -1)
            for sy_ in (1, -1)
        ]
        depth = min(APRON, length / 2)
        z = under - depth / 2
        parts += [
            m.rounded_box((2 * x, 0.02, depth), 0.004, at=(0.0, s * y, z), segments=1)
            for s in (1, -1)
        ]
        parts += [
            m.rounded_box((0.02, 2 * y, depth), 0.004, at=(s * x, 0.0, z), segments=1)
            for s in (1, -1)
        ]
    color = rgb(table.color)
    shapes = [_mesh("table-top", [top], color)]
    if parts:
        shapes.append(_mesh("table-legs", parts, _shade(color, 0.72)))
    return Body(
        "table",
        Meshes(tuple(shapes)),
        (table.center[0], table.center[1], 0.0),
        color=color,
    )


def region_body(
    region: Region,
    table: Table,
    boxes: Sequence[tuple[tuple[float, float, float], tuple[float, float, float]]],
) -> Body:
    """A region: part of the table as a thin lighter plate; a tray or a shelf as its ``boxes``
    (half extents, centre: :func:`~planner.domains.panda.world.fixture_boxes`)."""
    (cx, cy), (sx, sy) = region.center, region.size
    name = f"region-{region.name}"
    if not boxes:
        color = _shade(rgb(table.color), PLATE_TINT)
        return Body(
            name,
            Box((sx, sy, PLATE)),
            (cx, cy, region.top + PLATE / 2),
            color=color,
            label=region.name,
        )
    parts = [
        m.rounded_box(
            (2 * half[0], 2 * half[1], 2 * half[2]),
            FIXTURE_ROUNDING,
            at=(center[0] - cx, center[1] - cy, center[2]),
            segments=1,
        )
        for half, center in boxes
    ]
    color = rgb(region.color)
    return Body(
        name,
        Meshes((_mesh(f"{region.kind}", parts, color),)),
        (cx, cy, 0.0),
        color=color,
        label=region.name,
    )


def floor_body(table: Table) -> Body:
    """The tiled floor under the table, FLOOR_MARGIN beyond it, ``table.height`` below its top."""
    (cx, cy), (sx, sy) = table.center, table.size
    area = (cx - sx / 2, cx + sx / 2, cy - sy / 2, cy + sy / 2)
    return tiled_floor(area, FLOOR_MARGIN, _mesh, (0.0, 0.0, -table.height))

"""What a manipulation domain's props share: the tiled floor under its scene, in squares of
:data:`TILE`, made with :mod:`planner.sim.meshes` and kept in its cache."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import trimesh

from planner.view import Body, Mesh, Meshes, Rgb, Vec3

TILE = 0.5  # floor tiles, metres
TILE_RGB: tuple[Rgb, Rgb] = ((216, 211, 200), (184, 177, 164))
Footprint = tuple[float, float, float, float]  # xmin, xmax, ymin, ymax
MeshMaker = Callable[[str, Sequence[trimesh.Trimesh], Rgb], Mesh]  # stem, parts, colour


def tiled_floor(
    area: Footprint,
    margin: float,
    mesh: MeshMaker,
    position: Vec3 = (0.0, 0.0, 0.0),
) -> Body:
    """The floor: tiles in two colours, checkered, covering ``area`` and ``margin`` beyond it,
    whole tiles on the grid through the origin; ``mesh`` makes each colour's mesh (its stem
    ``floor-0`` or ``floor-1``), and the floor stands at ``position``."""
    xmin, xmax, ymin, ymax = area
    x0, x1 = math.floor((xmin - margin) / TILE), math.ceil((xmax + margin) / TILE)
    y0, y1 = math.floor((ymin - margin) / TILE), math.ceil((ymax + margin) / TILE)
    parts = []
    for parity, color in enumerate(TILE_RGB):
        corners = [
            (i * TILE, j * TILE)
            for i in range(x0, x1)
            for j in range(y0, y1)
            if (i + j) % 2 == parity
        ]
        parts.append(mesh(f"floor-{parity}", [_tiles(corners)], color))
    return Body("floor", Meshes(tuple(parts)), position)


def _tiles(corners: Sequence[tuple[float, float]]) -> trimesh.Trimesh:
    """Square tiles of side TILE at z = 0 facing up, from their lower-left corners."""
    vertices: list[tuple[float, float, float]] = []
    faces: list[tuple[int, int, int]] = []
    for x, y in corners:
        k = len(vertices)
        vertices += [(x, y, 0.0), (x + TILE, y, 0.0), (x + TILE, y + TILE, 0.0), (x, y + TILE, 0.0)]
        faces += [(k, k + 1, k + 2), (k, k + 2, k + 3)]
    return trimesh.Trimesh(np.array(vertices), np.array(faces), process=False)

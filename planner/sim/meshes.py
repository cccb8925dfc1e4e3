"""Simple shapes as triangle meshes (trimesh), and mesh files written the same way every time.

The shapes (:func:`rounded_box`, :func:`cylinder`, :func:`capsule`, :func:`lathe`,
:func:`sphere`, :func:`ring`, :func:`prism`) are built with :mod:`trimesh.creation` where it
has them and placed in a part's frame: centred on ``at``, round shapes along ``axis``. Parts
of one colour are joined with :func:`combine` and written as Wavefront OBJ, which pybullet,
trimesh and yourdfpy all read, by :func:`obj_text`: fixed decimals and one normal per vertex,
smooth across gentle edges and split across sharp ones (a box's corners, a cylinder's rim), so
the same mesh always gives the same bytes and looks right in any viewer that shades by vertex
normals.

Meshes generated at run time (a domain's fixtures, whose sizes come from scene files) go to a
cache folder through :func:`cached_obj`, named by a digest of their text: a file is written once
and never goes stale.
"""

from __future__ import annotations

import hashlib
import logging
import math
import os
import tempfile
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.typing as npt
import trimesh

log = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]
Axis = Literal["x", "y", "z"]
ORIGIN: Vec3 = (0.0, 0.0, 0.0)

SECTIONS = 20  # segments round a cylinder, capsule or lathe shape
CREASE_DEG = 50.0  # faces meeting at a sharper angle than this get their own normals
POSITION_DECIMALS = 5  # 0.01 mm
NORMAL_DECIMALS = 4
CACHE_ENV = "TAMP_MESH_CACHE"  # overrides where generated meshes are cached

# Rotations taking a shape's own z axis to the named axis.
_TO_AXIS: dict[str, npt.NDArray[np.float64]] = {
    "z": np.eye(4),
    "x": np.array([[0.0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1]]),  # +90 about y
    "y": np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]]),  # -90 about x
}


def _placed(mesh: trimesh.Trimesh, at: Vec3, axis: Axis = "z") -> trimesh.Trimesh:
    transform = _TO_AXIS[axis].copy()
    transform[:3, 3] = at
    mesh.apply_transform(transform)
    return mesh


def _positive(*values: float) -> None:
    if any(not math.isfinite(v) or v <= 0 for v in values):
        raise ValueError(f"sizes must be positive, got {values}")


def rounded_box(
    size: Vec3, radius: float, *, at: Vec3 = ORIGIN, segments: int = 2
) -> trimesh.Trimesh:
    """A box of ``size`` whose edges and corners are rounded with ``radius`` (``segments``
    steps per quarter circle); a box with sharp edges when ``radius`` is 0."""
    _positive(*size)
    if radius <= 0:
        return _placed(trimesh.creation.box(extents=size), at)
    radius = min(radius, *(s / 2 for s in size))
    half = [s / 2 - radius for s in size]
    # Rings of latitude from the bottom pole to the top one; the equator ring twice (bottom
    # and top half), each ring a loop of longitudes with each quadrant's ends doubled, so the
    # flat faces between the rounded corners are strips of quads.
    lats = [(-math.pi / 2 + math.pi / 2 * k / segments, -1) for k in range(segments + 1)]
    lats += [(math.pi / 2 * k / segments, 1) for k in range(segments + 1)]
    quadrants = ((1, 1), (-1, 1), (-1, -1), (1, -1))
    longs = [
        (q * math.pi / 2 + math.pi / 2 * k / segments, sx, sy)
        for q, (sx, sy) in enumerate(quadrants)
        for k in range(segments + 1)
    ]
    vertices = [
        (
            sx * half[0] + radius * math.cos(lat) * math.cos(lon),
            sy * half[1] + radius * math.cos(lat) * math.sin(lon),
            sz * half[2] + radius * math.sin(lat),
        )
        for lat, sz in lats
        for lon, sx, sy in longs
    ]
    n = len(longs)
    faces = []
    for i in range(len(lats) - 1):
        for j in range(n):
            a, b = i * n + j, i * n + (j + 1) % n
            c, d = a + n, b + n
            faces += [(a, b, d), (a, d, c)]
    top = (len(lats) - 1) * n
    corners = [k * (segments + 1) for k in range(4)]  # one vertex of each quadrant at a pole
    faces += [(corners[0], corners[3], corners[2]), (corners[0], corners[2], corners[1])]
    faces += [
        (top + corners[0], top + corners[1], top + corners[2]),
        (top + corners[0], top + corners[2], top + corners[3]),
    ]
    mesh = trimesh.Trimesh(np.array(vertices), np.array(faces), process=True)
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.remove_unreferenced_vertices()
    return _placed(mesh, at)


def lathe(
    profile: Sequence[tuple[float, float]],
    *,
    at: Vec3 = ORIGIN,
    axis: Axis = "z",
    sections: int = SECTIONS,
) -> trimesh.Trimesh:
    """A solid of revolution: ``profile`` is (radius, height) points from the bottom of the
    axis (radius 0) to its top (radius 0); heights are along ``axis`` from ``at``."""
    if len(profile) < 3 or profile[0][0] != 0 or profile[-1][0] != 0:
        raise ValueError("a lathe profile runs from radius 0 to radius 0 over 3 points or more")
    mesh = trimesh.creation.revolve(np.array(profile, dtype=np.float64), sections=sections)
    return _placed(mesh, at, axis)


def cylinder(
    radius: float,
    length: float,
    *,
    at: Vec3 = ORIGIN,
    axis: Axis = "z",
    bevel: float = 0.0,
    sections: int = SECTIONS,
) -> trimesh.Trimesh:
    """A cylinder centred on ``at`` along ``axis``, its rims cut at 45 degrees by ``bevel``."""
    _positive(radius, length)
    h = length / 2
    b = min(max(bevel, 0.0), radius / 2, h / 2)
    if b == 0:
        profile = [(0.0, -h), (radius, -h), (radius, h), (0.0, h)]
    else:
        profile = [(0.0, -h), (radius - b, -h), (radius, b - h), (radius, h - b)]
        profile += [(radius - b, h), (0.0, h)]
    return lathe(profile, at=at, axis=axis, sections=sections)


def capsule(
    radius: float,
    length: float,
    *,
    at: Vec3 = ORIGIN,
    axis: Axis = "z",
    sections: int = SECTIONS,
) -> trimesh.Trimesh:
    """A cylinder with hemispherical ends, ``length`` long in all, centred on ``at``."""
    _positive(radius, length)
    mesh = trimesh.creation.capsule(
        height=max(length - 2 * radius, 1e-6), radius=radius, count=[sections, sections // 2]
    )
    return _placed(mesh, at, axis)


def sphere(radius: float, *, at: Vec3 = ORIGIN, sections: int = SECTIONS) -> trimesh.Trimesh:
    _positive(radius)
    mesh = trimesh.creation.uv_sphere(radius=radius, count=[sections, sections // 2])
    return _placed(mesh, at)


def ring(
    inner: float,
    outer: float,
    height: float,
    *,
    at: Vec3 = ORIGIN,
    axis: Axis = "z",
    sections: int = SECTIONS,
) -> trimesh.Trimesh:
    """A flat ring (a burner, a drain) of ``height`` between radii ``inner`` and ``outer``."""
    _positive(inner, outer - inner, height)
    return _placed(trimesh.creation.annulus(inner, outer, height, sections=sections), at, axis)


def prism(outline: Sequence[tuple[float, float]], bottom: float, top: float) -> trimesh.Trimesh:
    """``outline`` (x, y points, counter-clockwise, star-shaped about their mean) extruded from
    height ``bottom`` to ``top``."""
    _positive(top - bottom)
    points = np.array(outline, dtype=np.float64)
    centre = points.mean(axis=0)
    n = len(points)
    vertices = np.vstack([centre, points])
    faces = np.array([(0, 1 + i, 1 + (i + 1) % n) for i in range(n)])
    mesh = trimesh.creation.extrude_triangulation(vertices, faces, top - bottom)
    mesh.apply_translation((0.0, 0.0, bottom))
    return mesh


def rounded_rectangle(
    size: tuple[float, float], radius: float, *, segments: int = 4
) -> list[tuple[float, float]]:
    """The outline of a rectangle centred on the origin with rounded corners, counter-clockwise."""
    hx, hy = size[0] / 2, size[1] / 2
    radius = min(radius, hx, hy)
    out = []
    for q, (sx, sy) in enumerate(((1, 1), (-1, 1), (-1, -1), (1, -1))):
        cx, cy = sx * (hx - radius), sy * (hy - radius)
        for k in range(segments + 1):
            a = q * math.pi / 2 + math.pi / 2 * k / segments
            out.append((cx + radius * math.cos(a), cy + radius * math.sin(a)))
    return out


def combine(parts: Iterable[trimesh.Trimesh]) -> trimesh.Trimesh:
    """One mesh of several parts (of one colour)."""
    meshes = list(parts)
    if not meshes:
        raise ValueError("nothing to combine")
    joined = trimesh.util.concatenate(meshes)
    assert isinstance(joined, trimesh.Trimesh)
    return joined


def triangles(path: Path) -> int:
    """How many triangles a mesh file holds."""
    mesh = trimesh.load(str(path), force="mesh")
    if not isinstance(mesh, trimesh.Trimesh):
        raise ValueError(f"{path} is not a single mesh")
    return len(mesh.faces)


# --- files -------------------------------------------------------------------------------------


def _corner_normals(mesh: trimesh.Trimesh) -> npt.NDArray[np.float64]:
    """A normal for each corner of each face (faces x 3 x 3): the area-weighted mean of the
    normals of the faces round its vertex that meet this face's at less than CREASE_DEG."""
    normals = np.asarray(mesh.face_normals, dtype=np.float64)
    weighted = normals * np.asarray(mesh.area_faces, dtype=np.float64)[:, None]
    corner_vertex = np.asarray(mesh.faces, dtype=np.int64).ravel()
    corner_face = np.repeat(np.arange(len(mesh.faces)), 3)
    # Pair every corner with every corner at the same vertex (itself included).
    order = np.argsort(corner_vertex, kind="stable")
    counts = np.bincount(corner_vertex, minlength=len(mesh.vertices))
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    size = counts[corner_vertex]
    corner = np.repeat(np.arange(len(corner_vertex)), size)
    offset = np.arange(len(corner)) - np.repeat(np.cumsum(size) - size, size)
    partner = order[starts[corner_vertex[corner]] + offset]
    f, g = corner_face[corner], corner_face[partner]
    near = np.einsum("ij,ij->i", normals[f], normals[g]) > math.cos(math.radians(CREASE_DEG))
    out = np.zeros((len(corner_vertex), 3))
    np.add.at(out, corner[near], weighted[g[near]])
    length = np.linalg.norm(out, axis=1)
    flat = length <= 0
    out[~flat] /= length[~flat, None]
    out[flat] = normals[corner_face[flat]]
    return out.reshape(-1, 3, 3)


def _lines(prefix: str, rows: npt.NDArray[np.float64], decimals: int) -> list[str]:
    # Adding 0.0 after rounding turns -0.0 into 0.0, so a value prints one way only.
    rows = np.round(rows, decimals) + 0.0
    return [f"{prefix} {a:.{decimals}f} {b:.{decimals}f} {c:.{decimals}f}" for a, b, c in rows]


def obj_text(mesh: trimesh.Trimesh, *, comment: str = "") -> str:
    """The mesh as OBJ text: one line per vertex (position) and normal, fixed decimals; a
    vertex on a sharp edge appears once per side."""
    mesh = trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)
    mesh.update_faces(mesh.nondegenerate_faces())
    positions = np.round(np.asarray(mesh.vertices, dtype=np.float64), POSITION_DECIMALS)
    normals = np.round(_corner_normals(mesh), NORMAL_DECIMALS).reshape(-1, 3)
    corners = np.column_stack([np.asarray(mesh.faces).ravel(), normals])
    # One vertex per (position, normal), numbered in order of first use.
    _, first, inverse = np.unique(corners, axis=0, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    number = rank[inverse.ravel()] + 1
    used = np.sort(first)
    v_lines = _lines("v", positions[corners[used, 0].astype(np.int64)], POSITION_DECIMALS)
    n_lines = _lines("vn", normals[used], NORMAL_DECIMALS)
    f_lines = [f"f {a}//{a} {b}//{b} {c}//{c}" for a, b, c in number.reshape(-1, 3)]
    head = [f"# {line}" for line in comment.splitlines()]
    head.append(f"# {len(used)} vertices, {len(f_lines)} triangles")
    body = [line for pair in zip(v_lines, n_lines, strict=True) for line in pair]
    return "\n".join([*head, *body, *f_lines]) + "\n"


def cache_dir() -> Path:
    """Where generated meshes are kept: ``$TAMP_MESH_CACHE``, else the user's cache folder."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "guided-tamp" / "meshes"


def cached_obj(mesh: trimesh.Trimesh, stem: str, *, comment: str = "") -> Path:
    """The mesh's OBJ file in :func:`cache_dir`, written if it is not there yet; its name is
    ``stem`` and a digest of its text, so the same mesh always maps to the same file."""
    text = obj_text(mesh, comment=comment)
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    folder = cache_dir()
    path = folder / f"{stem}-{digest}.obj"
    if not path.exists():
        folder.mkdir(parents=True, exist_ok=True)
        # Written beside and renamed, so another process never reads half a file.
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            out.write(text)
        os.replace(tmp, path)
        log.debug("wrote %s", path)
    return path

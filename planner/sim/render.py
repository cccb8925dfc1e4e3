"""Render a domain's scene to a PNG, headless, with pybullet's software renderer.

The bodies of the scene description (:class:`planner.view.SceneView`, a domain's ``view`` hook)
are built at their start poses (boxes, .obj and .stl meshes in their colours, URDFs with their
visual meshes); the scene's floor, or a grey one, is added and a camera is placed looking down at
about 45 degrees, far enough back that every body fits.
The PNG is written with ``zlib`` and ``struct`` (no imaging library needed).
"""

from __future__ import annotations

import logging
import math
import struct
import time
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pybullet as p
import trimesh

from planner.sim import bodies
from planner.sim.transforms import Vec3
from planner.view import Body, Box, Mesh, Meshes, SceneView

log = logging.getLogger(__name__)

FOV_DEG = 35.0  # vertical field of view of the camera; narrow enough to keep boxes boxy
PITCH_DEG = 45.0  # the camera looks down this far below the horizontal
HEADING_DEG = 210.0  # direction the camera looks in, from +x; 180 = from behind the table at +x
FIT_MARGIN = 1.1  # the camera backs off this much further than the tightest fit
FLOOR_BORDER = 12.0  # the floor reaches this far (m) beyond the scene's bounding box
FLOOR_COLOR = (0.7, 0.7, 0.68, 1.0)  # mid grey, so light fixtures and dark ones both stand out
BACKGROUND = (235, 238, 242)  # light grey-blue where no body is seen
LIGHT_DIRECTION = (0.9, 0.4, 2.0)  # towards the light: high, on the camera's side, from +x
LIGHT_AMBIENT = 0.55  # ambient coefficient of the tiny renderer's Phong model
LIGHT_DIFFUSE = 0.5  # diffuse coefficient
LIGHT_SPECULAR = 0.05  # specular coefficient: little shine on the flat-coloured boxes
SHADOWS = False  # the tiny renderer's shadow map smears long false shadows over a large floor


@dataclass(frozen=True)
class RenderInfo:
    """What :func:`render_scene` wrote and how much of each named body the image shows."""

    path: Path
    width: int
    height: int
    pixels: Mapping[str, int]  # body name -> pixels it covers

    def hidden(self, min_pixels: int = 1) -> tuple[str, ...]:
        """Names of the bodies covering fewer than ``min_pixels`` pixels."""
        return tuple(name for name, n in self.pixels.items() if n < min_pixels)


def render_scene(view: SceneView, *, out: Path, width: int = 960, height: int = 720) -> RenderInfo:
    """Render a domain's scene description (its ``view`` hook's :class:`SceneView`: boxes,
    meshes, URDFs at their start poses, on its floor) and write a PNG to ``out``.

    Raises :class:`ValueError` when ``out``'s directory does not exist, the size is not
    positive or a body cannot be built (a mesh or URDF that does not load).
    """
    out = Path(out)
    if not out.parent.is_dir():
        raise ValueError(f"cannot write {out}: directory {out.parent} does not exist")
    if width <= 0 or height <= 0:
        raise ValueError(f"image size must be positive, got {width}x{height}")
    if not view.bodies:
        raise ValueError("the scene description has no bodies to render")
    start = time.perf_counter()
    client = bodies.connect()
    try:
        named = {body.name: _build(client, body) for body in view.bodies}
        if view.floor is not None:
            _build(client, view.floor)
        corners = np.vstack([_corners(client, built) for built in named.values()])
        floor = view.floor_z if view.floor is None else None
        rgb, seg = _render(client, corners, width, height, floor)
    finally:
        bodies.disconnect(client)
    _write_png(out, rgb)
    ids, counts = np.unique(seg, return_counts=True)
    by_id = dict(zip(ids.tolist(), counts.tolist(), strict=True))
    pixels = {name: sum(int(by_id.get(b, 0)) for b in built.ids) for name, built in named.items()}
    log.info("rendered to %s (%dx%d) in %.2f s", out, width, height, time.perf_counter() - start)
    info = RenderInfo(out, width, height, pixels)
    if info.hidden():
        log.warning("not visible in %s: %s", out, ", ".join(info.hidden()))
    return info


@dataclass(frozen=True)
class _Built:
    """The pybullet bodies drawing one scene body, and the corners of what they draw."""

    ids: tuple[int, ...]
    corners: npt.NDArray[np.float64] | None = None  # meshes: from the files; else pybullet's


def _build(client: int, body: Body) -> _Built:
    """The pybullet bodies for a scene body (static, at its start pose)."""
    pose = (body.position, body.quat)
    shape = body.shape
    if isinstance(shape, Box):
        half = (shape.size[0] / 2, shape.size[1] / 2, shape.size[2] / 2)
        return _Built((bodies.add_box(client, half, pose, _rgba(body.color)),))
    if isinstance(shape, Mesh | Meshes):
        parts = shape.parts if isinstance(shape, Meshes) else (shape,)
        ids = tuple(_add_mesh(client, body, part) for part in parts)
        corners = np.vstack([_mesh_corners(part, pose) for part in parts])
        return _Built(ids, corners)
    if not shape.path.is_file():
        raise ValueError(f"body {body.name}: no URDF file {shape.path}")
    try:
        uid = p.loadURDF(
            str(shape.path),
            basePosition=pose[0],
            baseOrientation=pose[1],
            useFixedBase=True,
            physicsClientId=client,
        )
    except p.error as exc:
        raise ValueError(f"body {body.name}: pybullet cannot load {shape.path}: {exc}") from exc
    joints = bodies.joint_indices(client, uid)
    for name, value in shape.joints.items():
        if name in joints:
            p.resetJointState(uid, joints[name], value, physicsClientId=client)
    return _Built((int(uid),))


def _rgba(rgb: tuple[int, int, int]) -> bodies.Color:
    return (rgb[0] / 255, rgb[1] / 255, rgb[2] / 255, 1.0)


def _add_mesh(client: int, body: Body, mesh: Mesh) -> int:
    if not mesh.path.is_file():
        raise ValueError(f"body {body.name}: no mesh file {mesh.path}")
    visual = p.createVisualShape(
        p.GEOM_MESH,
        fileName=str(mesh.path),
        meshScale=[mesh.scale] * 3,
        rgbaColor=_rgba(mesh.color or body.color),
        physicsClientId=client,
    )
    if visual < 0:
        raise ValueError(f"body {body.name}: pybullet cannot read mesh {mesh.path}")
    return int(
        p.createMultiBody(
            baseVisualShapeIndex=visual,
            basePosition=body.position,
            baseOrientation=body.quat,
            physicsClientId=client,
        )
    )


def _mesh_corners(
    mesh: Mesh, pose: tuple[Vec3, tuple[float, float, float, float]]
) -> npt.NDArray[np.float64]:
    """The corners of a mesh file's bounding box, placed at ``pose`` (pybullet knows no bounds
    of a body that only draws)."""
    bounds = np.asarray(trimesh.load(str(mesh.path), force="mesh").bounds) * mesh.scale
    local = np.array([(x, y, z) for x in bounds[:, 0] for y in bounds[:, 1] for z in bounds[:, 2]])
    rotation = np.array(p.getMatrixFromQuaternion(pose[1])).reshape(3, 3)
    placed: npt.NDArray[np.float64] = local @ rotation.T + np.array(pose[0])
    return placed


# --- camera ----------------------------------------------------------------------------------


def _corners(client: int, built: _Built) -> npt.NDArray[np.float64]:
    """The corners of what a scene body draws: its meshes' boxes, or every link's
    axis-aligned bounding box (one row each)."""
    if built.corners is not None:
        return built.corners
    corners: list[tuple[float, float, float]] = []
    for body in built.ids:
        for link in range(-1, p.getNumJoints(body, physicsClientId=client)):
            lo, hi = p.getAABB(body, link, physicsClientId=client)
            corners += [
                (x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])
            ]
    return np.array(corners, dtype=np.float64)


def _camera(points: npt.NDArray[np.float64], aspect: float) -> tuple[Vec3, Vec3, Vec3]:
    """Eye, target and up vector of a camera that sees all ``points`` (rows of x, y, z)."""
    heading, pitch = math.radians(HEADING_DEG), math.radians(PITCH_DEG)
    forward = np.array(
        [
            math.cos(pitch) * math.cos(heading),
            math.cos(pitch) * math.sin(heading),
            -math.sin(pitch),
        ]
    )
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    tan_v = math.tan(math.radians(FOV_DEG) / 2)
    tan_h = tan_v * aspect
    target = points.mean(axis=0)
    # Centre the points across the view (exact for an orthographic view, close for this one).
    across, vertical = (points - target) @ right, (points - target) @ up
    target = target + right * (across.max() + across.min()) / 2
    target = target + up * (vertical.max() + vertical.min()) / 2
    offsets = points - target
    across, vertical, depth = offsets @ right, offsets @ up, offsets @ forward
    # A point at depth d + v.f is in view when |v.right| <= (d + v.f) tan(h / 2), same for up.
    distance = max(
        float(np.max(np.abs(across) / tan_h - depth)),
        float(np.max(np.abs(vertical) / tan_v - depth)),
    )
    eye = target - forward * distance * FIT_MARGIN
    return _vec(eye), _vec(target), _vec(up)


def _vec(a: npt.NDArray[np.float64]) -> Vec3:
    return (float(a[0]), float(a[1]), float(a[2]))


def _render(
    client: int,
    points: npt.NDArray[np.float64],
    width: int,
    height: int,
    floor_z: float | None = 0.0,
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.int32]]:
    """RGB image (height x width x 3) and segmentation mask (body id per pixel, -1 for none) of
    a camera that sees all ``points``; a grey floor at ``floor_z`` unless it is None (the scene
    has its own)."""
    eye, target, up = _camera(points, width / height)
    lo, hi = points.min(axis=0), points.max(axis=0)
    floor = None
    if floor_z is not None:
        half = ((hi[0] - lo[0]) / 2 + FLOOR_BORDER, (hi[1] - lo[1]) / 2 + FLOOR_BORDER, 0.005)
        centre = ((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, floor_z - half[2])
        floor = bodies.add_box(client, half, (centre, (0.0, 0.0, 0.0, 1.0)), FLOOR_COLOR)
    try:
        distance = math.dist(eye, target)
        view = p.computeViewMatrix(eye, target, up, physicsClientId=client)
        projection = p.computeProjectionMatrixFOV(
            FOV_DEG, width / height, 0.05, distance * 4, physicsClientId=client
        )
        _, _, rgba, _, seg = p.getCameraImage(
            width,
            height,
            viewMatrix=view,
            projectionMatrix=projection,
            lightDirection=LIGHT_DIRECTION,
            lightColor=(1.0, 1.0, 1.0),
            lightAmbientCoeff=LIGHT_AMBIENT,
            lightDiffuseCoeff=LIGHT_DIFFUSE,
            lightSpecularCoeff=LIGHT_SPECULAR,
            shadow=int(SHADOWS),
            renderer=p.ER_TINY_RENDERER,
            physicsClientId=client,
        )
    finally:
        if floor is not None:
            p.removeBody(floor, physicsClientId=client)
    rgb = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3].copy()
    mask = np.asarray(seg, dtype=np.int32).reshape(height, width)
    rgb[mask < 0] = BACKGROUND
    return rgb, mask


# --- PNG -------------------------------------------------------------------------------------


def _chunk(kind: bytes, data: bytes) -> bytes:
    return (
        struct.pack(">I", len(data))
        + kind
        + data
        + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    )


def _write_png(path: Path, rgb: npt.NDArray[np.uint8]) -> None:
    """An 8-bit RGB PNG; every row uses filter 0 (none)."""
    height, width, _ = rgb.shape
    rows = np.concatenate([np.zeros((height, 1), dtype=np.uint8), rgb.reshape(height, -1)], axis=1)
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + _chunk(b"IHDR", header)
        + _chunk(b"IDAT", zlib.compress(rows.tobytes(), 6))
        + _chunk(b"IEND", b"")
    )

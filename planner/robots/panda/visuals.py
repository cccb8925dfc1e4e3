"""The Franka Panda as the 3D view draws it: pybullet_data's ``franka_panda/panda.urdf`` with
light, flat-coloured meshes, in a URDF that the view's loader (yourdfpy) reads.

pybullet_data's URDF names its meshes ``package://meshes/...``, which yourdfpy cannot resolve,
and its visual meshes are textured OBJ files of several parts, about 100k triangles in all.
:func:`viewer_urdf` writes, when it is first asked for, a URDF with exactly pybullet's links and
joints (names, origins, axes, limits: the view's forward kinematics is pybullet's) whose visuals
are OBJ files made with trimesh:

- each part of a link's mesh (one per material) gets one flat colour, its material's diffuse
  colour times the mean colour its texture shows on it (white shells, dark grey joint covers and
  hand parts, a blue light on the wrist); a mesh without materials (the base, the flange) takes
  its colour from the URDF;
- a link's parts of one colour are joined and decimated (quadric edge collapse, the
  ``fast-simplification`` package through trimesh) to their share of :data:`TRIANGLES` for the
  whole arm; small parts (a light, a ring) stay whole;
- the OBJ files go to the mesh cache (:func:`planner.sim.meshes.cached_obj`, named by their
  content), and the URDF beside them, named by a digest of what it is made from (the source URDF
  and meshes, this module's and the OBJ writer's code, the libraries' versions): a second call,
  or another process, finds it there.

The collisions keep pybullet_data's meshes (by absolute path), so pybullet loads the URDF too
(``tamp render``). :class:`Kinematics` is a URDF's forward kinematics, for the view's ghosts and
its plan.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import math
import os
import re
import tempfile
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np
import numpy.typing as npt
import trimesh

from planner.robots.panda.model import urdf_path
from planner.sim import meshes as m
from planner.sim.transforms import IDENTITY, Pose, Quat, multiply, quat_from_euler

log = logging.getLogger(__name__)

Rgb = tuple[int, int, int]
Vec3 = tuple[float, float, float]
_Key = tuple[Path, bytes, bytes]  # a visual's mesh file, its fallback colour and its scale

TRIANGLES = 16_000  # the drawn arm's meshes are decimated to about this many triangles in all
WHOLE = 150  # a part of at most this many triangles is kept whole (a light, a ring)
SHADE = 0.92  # every colour is scaled by this: the white shells stay a shade off white
COLOR_STEP = 16  # colours are rounded to this step (of 255), so a link has a few meshes
FALLBACK_RGB: Rgb = (235, 235, 235)  # a visual without a colour in its file or its URDF
STEM = "panda"  # the cached files' names start with this
LIBRARIES = ("trimesh", "fast-simplification")  # their versions are part of the URDF's name


def _resolve(filename: str, folder: Path) -> Path:
    """A URDF's mesh file name as a path: ``package://`` and relative names are taken from the
    URDF's folder (each of pybullet_data's robots is its own package)."""
    name = filename.removeprefix("package://").removeprefix("file://")
    path = Path(name)
    return path if path.is_absolute() else folder / path


def _rounded(rgb: npt.NDArray[np.float64]) -> Rgb:
    """A colour in 0-1 as 0-255, shaded by SHADE and rounded to COLOR_STEP."""
    steps = np.round(np.clip(rgb, 0.0, 1.0) * SHADE * 255 / COLOR_STEP) * COLOR_STEP
    r, g, b = (int(min(255, c)) for c in steps)
    return (r, g, b)


def _part_rgb(part: trimesh.Trimesh, fallback: npt.NDArray[np.float64]) -> Rgb:
    """A part's flat colour: its material's diffuse colour times the mean colour of its texture
    where the part's texture coordinates fall; ``fallback`` (0-1) without a material."""
    visual = part.visual
    if not isinstance(visual, trimesh.visual.TextureVisuals) or visual.material is None:
        return _rounded(fallback)
    material = visual.material
    diffuse = np.asarray(material.main_color[:3], dtype=np.float64) / 255
    texture = np.ones(3)
    image = getattr(material, "image", None)
    if image is not None and visual.uv is not None and len(visual.uv):
        colors = np.asarray(trimesh.visual.color.uv_to_color(visual.uv, image), dtype=np.float64)
        texture = colors[:, :3].mean(axis=0) / 255
    return _rounded(diffuse * texture)


def _parts_by_color(path: Path, fallback: npt.NDArray[np.float64]) -> dict[Rgb, trimesh.Trimesh]:
    """A mesh file's parts, joined by colour (without texture coordinates or normals)."""
    scene = trimesh.load(str(path), force="scene", group_material=True)
    if not isinstance(scene, trimesh.Scene):
        raise ValueError(f"{path} is not a mesh file trimesh reads")
    groups: dict[Rgb, list[trimesh.Trimesh]] = {}
    for node in sorted(scene.graph.nodes_geometry):
        transform, name = scene.graph[node]
        geometry = scene.geometry[name]
        if not isinstance(geometry, trimesh.Trimesh) or not len(geometry.faces):
            continue
        # Positions and faces alone: vertices split for texture seams are joined again.
        part = trimesh.Trimesh(geometry.vertices, geometry.faces, process=True)
        part.apply_transform(transform)
        groups.setdefault(_part_rgb(geometry, fallback), []).append(part)
    return {rgb: m.combine(groups[rgb]) for rgb in sorted(groups)}


def _decimated(mesh: trimesh.Trimesh, ratio: float) -> trimesh.Trimesh:
    """The mesh with about ``ratio`` of its triangles (at least WHOLE; a small mesh as it is)."""
    target = max(WHOLE, round(len(mesh.faces) * ratio))
    if target >= len(mesh.faces):
        return mesh
    try:
        return mesh.simplify_quadric_decimation(face_count=target)
    except ImportError:  # fast-simplification is not installed: the full mesh, slower to draw
        log.warning("cannot decimate the Panda's meshes (pip install fast-simplification)")
        return mesh


def _material_colors(robot: ET.Element) -> dict[str, npt.NDArray[np.float64]]:
    """Material name -> rgb (0-1) of every material the URDF gives a colour, where it is."""
    out = {}
    for material in robot.iter("material"):
        color = material.find("color")
        name = material.get("name")
        if name and color is not None and color.get("rgba"):
            out[name] = np.array([float(v) for v in color.get("rgba", "").split()[:3]])
    return out


def _visual_fallback(
    visual: ET.Element, colors: Mapping[str, npt.NDArray[np.float64]]
) -> npt.NDArray[np.float64]:
    material = visual.find("material")
    if material is not None:
        color = material.find("color")
        if color is not None and color.get("rgba"):
            return np.array([float(v) for v in color.get("rgba", "").split()[:3]])
        if material.get("name") in colors:
            return colors[material.get("name", "")]
    return np.array(FALLBACK_RGB, dtype=np.float64) / 255 / SHADE


def _material_name(rgb: Rgb) -> str:
    return "rgb-{:02x}{:02x}{:02x}".format(*rgb)


def _scale(mesh_element: ET.Element) -> npt.NDArray[np.float64] | None:
    raw = mesh_element.get("scale")
    return None if raw is None else np.array([float(v) for v in raw.split()])


def build_urdf(source: Path) -> tuple[str, int]:
    """The viewer URDF's text for the URDF at ``source`` (its meshes written to the mesh cache)
    and how many triangles its visuals draw."""
    robot = ET.parse(source).getroot()
    folder = source.parent
    colors = _material_colors(robot)
    visuals: list[tuple[ET.Element, ET.Element, _Key, dict[Rgb, trimesh.Trimesh]]] = []
    loaded: dict[_Key, dict[Rgb, trimesh.Trimesh]] = {}
    for link in robot.findall("link"):
        for visual in link.findall("visual"):
            mesh_element = visual.find("geometry/mesh")
            if mesh_element is None:
                continue  # a box, cylinder or sphere: yourdfpy draws it as it is
            path = _resolve(mesh_element.get("filename", ""), folder)
            fallback = _visual_fallback(visual, colors)
            scale = _scale(mesh_element)
            key = (path, fallback.tobytes(), b"" if scale is None else scale.tobytes())
            if key not in loaded:
                parts = _parts_by_color(path, fallback)
                if scale is not None:
                    stretch = np.diag([*scale, 1.0])
                    parts = {rgb: mesh.apply_transform(stretch) for rgb, mesh in parts.items()}
                loaded[key] = parts
            visuals.append((link, visual, key, loaded[key]))
    total = sum(len(mesh.faces) for *_, parts in visuals for mesh in parts.values())
    ratio = min(1.0, TRIANGLES / max(1, total))
    written: dict[tuple[_Key, Rgb], tuple[Path, int]] = {}
    used: set[Rgb] = set()
    drawn = 0
    for link, visual, key, parts in visuals:
        at = list(link).index(visual)
        link.remove(visual)
        path = key[0]
        for rgb, mesh in parts.items():
            if (key, rgb) not in written:
                small = _decimated(mesh, ratio)
                comment = (
                    f"Made by planner/robots/panda/visuals.py from {path.name}\n"
                    f"colour {rgb}: {len(small.faces)} of its {len(mesh.faces)} triangles"
                )
                written[key, rgb] = (
                    m.cached_obj(
                        small, f"{STEM}-{path.stem}-{_material_name(rgb)}", comment=comment
                    ),
                    len(small.faces),
                )
            obj, faces = written[key, rgb]
            drawn += faces
            used.add(rgb)
            new = ET.Element("visual")
            origin = visual.find("origin")
            if origin is not None:
                new.append(origin)
            geometry = ET.SubElement(new, "geometry")
            ET.SubElement(geometry, "mesh", filename=str(obj))
            ET.SubElement(new, "material", name=_material_name(rgb))
            link.insert(at, new)
            at += 1
    for collision in robot.iter("collision"):
        mesh_element = collision.find("geometry/mesh")
        if mesh_element is not None:
            filename = _resolve(mesh_element.get("filename", ""), folder).resolve()
            mesh_element.set("filename", str(filename))
    for i, rgb in enumerate(sorted(used)):
        material = ET.Element("material", name=_material_name(rgb))
        rgba = " ".join(f"{c / 255:.4f}" for c in rgb) + " 1"
        ET.SubElement(material, "color", rgba=rgba)
        robot.insert(i, material)
    ET.indent(robot)
    head = (
        '<?xml version="1.0"?>\n'
        f"<!-- Made by planner/robots/panda/visuals.py from {source}: its links and joints, "
        f"flat-coloured decimated visuals ({drawn} triangles). -->\n"
    )
    return head + ET.tostring(robot, encoding="unicode") + "\n", drawn


# --- the cached viewer URDF ---------------------------------------------------------------------

_LOCK = threading.Lock()
_BUILT: dict[Path, Path] = {}  # cache folder -> the viewer URDF found or written there


def _digest(source: Path) -> str:
    """A digest of what the viewer URDF is made from: the source URDF, every file in its
    folder's ``meshes`` tree, this module's and the OBJ writer's code, the libraries' versions."""
    h = hashlib.sha256()
    files = [source, Path(__file__), Path(m.__file__)]
    files += sorted(p for p in (source.parent / "meshes").rglob("*") if p.is_file())
    for path in files:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    for library in LIBRARIES:
        try:
            h.update(f"{library} {version(library)}".encode())
        except PackageNotFoundError:
            h.update(f"{library} none".encode())
    return h.hexdigest()[:16]


def _complete(path: Path) -> bool:
    """The URDF is there and so is every mesh file it names."""
    if not path.is_file():
        return False
    names = re.findall(r'filename="([^"]+)"', path.read_text(encoding="utf-8"))
    return all(Path(name).is_file() for name in names)


def _write(path: Path, text: str) -> None:
    """Written beside and renamed, so another process never reads half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as out:
        out.write(text)
    os.replace(tmp, path)


def viewer_urdf() -> Path:
    """The drawn Panda's URDF (absolute mesh paths) in the mesh cache, made if it is not there
    yet: about a second the first time, nothing after that in the same process (a digest of
    the sources, some 20 ms, in a new one)."""
    folder = m.cache_dir().resolve()
    with _LOCK:
        known = _BUILT.get(folder)
        if known is not None and known.is_file():
            return known
        source = urdf_path()
        path = folder / f"{STEM}-{_digest(source)}.urdf"
        if not _complete(path):
            start = time.perf_counter()
            text, triangles = build_urdf(source)
            _write(path, text)
            log.info(
                "wrote %s (%d triangles) in %.2f s", path, triangles, time.perf_counter() - start
            )
        _BUILT[folder] = path
        return path


# --- forward kinematics -------------------------------------------------------------------------


@dataclass(frozen=True)
class Joint:
    """One joint of a URDF: its kind, the links it joins, its origin in the parent's frame, its
    axis, and the joint it mimics (name, multiplier, offset)."""

    name: str
    kind: str  # revolute, continuous, prismatic or fixed (anything else is treated as fixed)
    parent: str
    child: str
    xyz: Vec3
    rpy: Vec3
    axis: Vec3
    mimic: tuple[str, float, float] | None = None


def _vec3(raw: str | None, default: Vec3) -> Vec3:
    if not raw:
        return default
    x, y, z = (float(v) for v in raw.split())
    return (x, y, z)


def read_joints(path: Path) -> tuple[Joint, ...]:
    """The joints of the URDF at ``path``, in file order."""
    out = []
    for joint in ET.parse(path).getroot().findall("joint"):
        origin = joint.find("origin")
        axis = joint.find("axis")
        mimic = joint.find("mimic")
        parent, child = joint.find("parent"), joint.find("child")
        if parent is None or child is None:
            raise ValueError(f"{path}: joint {joint.get('name')} lacks a parent or a child")
        out.append(
            Joint(
                name=joint.get("name", ""),
                kind=joint.get("type", "fixed"),
                parent=parent.get("link", ""),
                child=child.get("link", ""),
                xyz=_vec3(origin.get("xyz") if origin is not None else None, (0.0, 0.0, 0.0)),
                rpy=_vec3(origin.get("rpy") if origin is not None else None, (0.0, 0.0, 0.0)),
                axis=_vec3(axis.get("xyz") if axis is not None else None, (1.0, 0.0, 0.0)),
                mimic=None
                if mimic is None
                else (
                    mimic.get("joint", ""),
                    float(mimic.get("multiplier", 1.0)),
                    float(mimic.get("offset", 0.0)),
                ),
            )
        )
    return tuple(out)


def _axis_angle(axis: Vec3, angle: float) -> Quat:
    norm = math.sqrt(sum(a * a for a in axis)) or 1.0
    s = math.sin(angle / 2) / norm
    return (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2))


class Kinematics:
    """Forward kinematics of a URDF's tree of links: where each link's frame is, in the root
    link's, for given joint values (a joint not given is at 0, or follows the joint it
    mimics)."""

    def __init__(self, joints: tuple[Joint, ...]) -> None:
        self._joints = {j.name: j for j in joints}
        self._parent_joint = {j.child: j for j in joints}
        roots = {j.parent for j in joints} - set(self._parent_joint)
        if len(roots) != 1:
            raise ValueError(f"a URDF tree has one root link, got {sorted(roots)}")
        self.root = roots.pop()
        self.links = (self.root, *(j.child for j in joints))
        self._origins: dict[str, Pose] = {j.name: (j.xyz, quat_from_euler(*j.rpy)) for j in joints}

    @classmethod
    def from_urdf(cls, path: Path) -> Kinematics:
        return cls(read_joints(path))

    def _value(self, joint: Joint, values: Mapping[str, float]) -> float:
        if joint.name in values:
            return float(values[joint.name])
        if joint.mimic is not None:
            name, multiplier, offset = joint.mimic
            return multiplier * float(values.get(name, 0.0)) + offset
        return 0.0

    def _motion(self, joint: Joint, values: Mapping[str, float]) -> Pose:
        """The child's frame in the joint's origin frame, the joint at its value."""
        q = self._value(joint, values)
        if joint.kind in ("revolute", "continuous"):
            return ((0.0, 0.0, 0.0), _axis_angle(joint.axis, q))
        if joint.kind == "prismatic":
            x, y, z = joint.axis
            return ((x * q, y * q, z * q), (0.0, 0.0, 0.0, 1.0))
        return IDENTITY

    def link_pose(self, link: str, values: Mapping[str, float]) -> Pose:
        """The link's frame in the root link's."""
        out = IDENTITY
        while link != self.root:
            joint = self._parent_joint.get(link)
            if joint is None:
                raise KeyError(f"no link {link!r} (links: {', '.join(self.links)})")
            out = multiply(multiply(self._origins[joint.name], self._motion(joint, values)), out)
            link = joint.parent
        return out


@functools.cache
def panda_kinematics() -> Kinematics:
    """The Panda's forward kinematics, from pybullet_data's URDF (the viewer URDF's joints)."""
    return Kinematics.from_urdf(urdf_path())

"""The PR2 as drawn (planner/robots/pr2/visuals.py, its meshes/): its collision model is the
one every recorded trial ran with, its meshes sit where the simulated links are (the viewer's
forward kinematics, yourdfpy's, against pybullet's), within 2 cm of each link's collision
shapes, in the URDF's colours, and few enough triangles to draw quickly. (That the committed
files are what the generator makes is checked in test_pr2_model.py.)"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as p
import pytest
import trimesh
import yourdfpy

from planner.robots.pr2 import model as m
from planner.robots.pr2 import visuals as v

GOLDEN = Path(__file__).parent / "golden" / "pr2-physics-15f517c.txt"
ENVELOPE_TOL = 0.02  # m: each face of a link's drawn box within this of its collision box
POSITION_TOL = 1e-5  # m
ANGLE_TOL = 1e-5  # rad
MAX_TRIANGLES = 7000  # the whole robot (today's boxes and primitives: 5,660)


def _physics_lines(path: Path) -> list[str]:
    """What pybullet simulates of a URDF, one line per link (mass, inertia), collision shape
    and joint: everything but what is drawn."""
    root = ET.parse(path).getroot()
    out = []
    for link in root.findall("link"):
        inertial = link.find("inertial")
        assert inertial is not None
        mass, inertia = inertial.find("mass"), inertial.find("inertia")
        assert mass is not None and inertia is not None
        out.append(f"link {link.get('name')} mass {mass.get('value')} inertia {inertia.attrib}")
        for c in link.findall("collision"):
            origin, geometry = c.find("origin"), c.find("geometry")
            assert origin is not None and geometry is not None
            shape = geometry[0]
            out.append(
                f"  collision xyz={origin.get('xyz')} rpy={origin.get('rpy')} {shape.tag} "
                f"{dict(sorted(shape.attrib.items()))}"
            )
    for j in root.findall("joint"):
        parent, child, origin = j.find("parent"), j.find("child"), j.find("origin")
        assert parent is not None and child is not None and origin is not None
        parts = [
            f"joint {j.get('name')} {j.get('type')} {parent.get('link')} -> {child.get('link')}"
        ]
        parts.append(f"xyz={origin.get('xyz')} rpy={origin.get('rpy')}")
        axis, limit = j.find("axis"), j.find("limit")
        if axis is not None:
            parts.append(f"axis={axis.get('xyz')}")
        if limit is not None:
            parts.append(f"limit={dict(sorted(limit.attrib.items()))}")
        out.append(" ".join(parts))
    return out


def test_the_simulated_robot_is_the_one_every_recorded_trial_used() -> None:
    """Collision shapes, masses and joints are exactly those of 15f517c (before the meshes)."""
    assert _physics_lines(m.URDF_PATH) == GOLDEN.read_text(encoding="utf-8").splitlines()


@dataclass(frozen=True)
class Both:
    """The URDF loaded the simulator's way (pybullet) and the viewer's (yourdfpy)."""

    client: int
    body: int
    links: dict[str, int]  # link name -> pybullet index (base_footprint -1)
    joints: dict[str, int]
    urdf: Any

    def set(self, values: dict[str, float]) -> None:
        for name, value in values.items():
            p.resetJointState(self.body, self.joints[name], value, physicsClientId=self.client)
        self.urdf.update_cfg(np.array([values[j] for j in self.urdf.actuated_joint_names]))

    def sim_pose(self, link: str) -> np.ndarray:
        """The link's frame in pybullet, as a 4x4 transform from base_footprint."""
        if self.links[link] < 0:
            return np.eye(4)
        state = p.getLinkState(
            self.body, self.links[link], computeForwardKinematics=True, physicsClientId=self.client
        )
        return _matrix(state[4], state[5])


Drawn = dict[str, list[tuple[tuple[float, ...], np.ndarray]]]  # link -> (rgba, placement)


def _matrix(position: Any, quat: Any) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)
    t[:3, 3] = position
    return t


@pytest.fixture(scope="module")
def both() -> Iterator[Both]:
    client = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(str(m.URDF_PATH), useFixedBase=True, physicsClientId=client)
        links, joints = {m.ROOT_LINK: -1}, {}
        for index in range(p.getNumJoints(body, physicsClientId=client)):
            info = p.getJointInfo(body, index, physicsClientId=client)
            joints[info[1].decode()] = index
            links[info[12].decode()] = index
        yield Both(client, body, links, joints, yourdfpy.URDF.load(str(m.URDF_PATH)))
    finally:
        p.disconnect(physicsClientId=client)


def _random_conf(rng: np.random.Generator, names: list[str]) -> dict[str, float]:
    return {
        name: float(rng.uniform(*m.JOINT_LIMITS.get(name, (-math.pi, math.pi)))) for name in names
    }


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    cos = (np.trace(a[:3, :3].T @ b[:3, :3]) - 1.0) / 2.0
    return math.acos(min(1.0, max(-1.0, float(cos))))


@pytest.mark.slow
def test_every_drawn_link_is_where_the_simulated_one_is(both: Both) -> None:
    rng = np.random.default_rng(5)
    names = list(both.urdf.actuated_joint_names)
    assert set(names) == set(m.JOINT_LIMITS)  # every joint that moves, continuous ones too
    worst = (0.0, 0.0)
    for _ in range(30):
        both.set(_random_conf(rng, names))
        for link in both.links:
            ours = np.asarray(both.urdf.get_transform(link, both.urdf.base_link))
            sim = both.sim_pose(link)
            worst = (
                max(worst[0], float(np.linalg.norm(ours[:3, 3] - sim[:3, 3]))),
                max(worst[1], _angle(ours, sim)),
            )
    assert worst[0] < POSITION_TOL and worst[1] < ANGLE_TOL, worst


@pytest.mark.slow
def test_pybullet_and_the_viewer_place_the_same_meshes_in_the_same_colours(both: Both) -> None:
    rng = np.random.default_rng(9)
    both.set(_random_conf(rng, list(both.urdf.actuated_joint_names)))
    by_index = {i: name for name, i in both.links.items()}
    sim: Drawn = {}
    sim_files: dict[str, list[str]] = {}
    for row in p.getVisualShapeData(both.body, physicsClientId=both.client):
        _, index, kind, _, filename, position, quat, rgba = row
        assert kind == p.GEOM_MESH
        link = by_index[index]
        placed = both.sim_pose(link) @ _matrix(position, quat)
        sim.setdefault(link, []).append((tuple(round(c, 2) for c in rgba), placed))
        sim_files.setdefault(link, []).append(Path(filename.decode()).name)
    scene = both.urdf.scene
    ours: Drawn = {}
    for name, mesh in scene.geometry.items():
        link = scene.graph.transforms.parents[name]
        placed = np.asarray(both.urdf.get_transform(name, both.urdf.base_link))
        rgba = tuple(round(c / 255, 2) for c in mesh.visual.face_colors[0])
        ours.setdefault(link, []).append((rgba, placed))
    assert sorted(sim) == sorted(ours)
    assert sum(len(x) for x in sim.values()) >= 40
    for link, drawn in sim.items():
        files = [Path(x.geometry.mesh.filename).name for x in both.urdf.link_map[link].visuals]
        assert sorted(sim_files[link]) == sorted(files), link
        for (rgba, placed), (our_rgba, our_placed) in zip(
            sorted(drawn, key=lambda d: d[0]), sorted(ours[link], key=lambda d: d[0]), strict=True
        ):
            assert rgba == pytest.approx(our_rgba, abs=0.01), link
            assert np.allclose(placed, our_placed, atol=POSITION_TOL), link
        known = {tuple(round(c, 2) for c in rgba) for rgba in m.MATERIALS.values()}
        assert {rgba for rgba, _ in drawn} <= known, link


def _collision_box(link: m.Link) -> tuple[np.ndarray, np.ndarray] | None:
    shapes = []
    for shape in link.shapes:
        transform = trimesh.transformations.euler_matrix(*shape.rpy, axes="sxyz")  # type: ignore[no-untyped-call]
        transform[:3, 3] = shape.xyz
        if shape.kind == "box":
            shapes.append(trimesh.creation.box(extents=shape.size, transform=transform))
        elif shape.kind == "cylinder":
            radius, length = shape.size
            shapes.append(trimesh.creation.cylinder(radius, length, transform=transform))
        else:
            sphere = trimesh.creation.icosphere(radius=shape.size[0])
            shapes.append(sphere.apply_transform(transform))
    if not shapes:
        return None
    bounds = trimesh.util.concatenate(shapes).bounds
    return bounds[0], bounds[1]


def test_each_link_is_drawn_over_its_collision_shapes() -> None:
    """What is seen is what collides: each link's meshes and its collision shapes have the same
    box in the link's frame, face by face, within 2 cm."""
    model = m.pr2_model()
    drawn = 0
    for link in model.links:
        expected = _collision_box(link)
        files = v.link_visuals(link.name)
        if expected is None:
            assert files == (), f"{link.name} has no collision shapes but is drawn"
            continue
        assert files, f"{link.name} collides but is not drawn"
        meshes = [trimesh.load(str(m.URDF_PATH.parent / f), force="mesh") for f, _ in files]
        lo, hi = trimesh.util.concatenate(meshes).bounds
        gap = np.max(np.abs(np.concatenate([lo - expected[0], hi - expected[1]])))
        assert gap < ENVELOPE_TOL, f"{link.name}: drawn {lo}..{hi}, collides {expected}"
        drawn += 1
    assert drawn == 24  # base, torso, head pan and tilt, 2 x (7 arm links, palm, 2 fingers)


def test_the_meshes_are_simple() -> None:
    urdf = yourdfpy.URDF.load(str(m.URDF_PATH))
    triangles = sum(len(g.faces) for g in urdf.scene.geometry.values())
    assert 3000 < triangles < MAX_TRIANGLES
    for name in v.mesh_texts():
        assert (v.MESH_DIR / name).is_file()

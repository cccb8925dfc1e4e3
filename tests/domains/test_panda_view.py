"""The Panda in the 3D view: the drawn arm is pybullet's (its links where pybullet puts them, its
shape within millimetres of pybullet_data's meshes, light enough to draw), the scene shows the
robot, the table, the tray and every block, ghosts land in their layers where the values put the
hand, and a plan carries the block in the hand."""

from __future__ import annotations

import math
import random
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pybullet as p
import pytest
import trimesh
import yourdfpy  # type: ignore[import-untyped]
from scipy.spatial import cKDTree  # type: ignore[import-untyped]

from planner.abstract.skeleton import GroundAction
from planner.domains import problem_for_scene
from planner.domains.manipulation.problem import block_pose_to_pose, initial_pose_name
from planner.domains.panda.problem import ROBOT, START_CONF, geometry_of
from planner.domains.panda.samplers import PandaSamplers
from planner.domains.panda.values import BlockPose, Conf, Grasp, Trajectory
from planner.domains.panda.view import (
    GHOST_PAD,
    PandaTimeline,
    PandaView,
    robot_joints,
    tool_pose,
)
from planner.pddl.structs import Problem
from planner.robots.panda import visuals
from planner.robots.panda.model import (
    FINGER_OPEN,
    LOWER,
    READY,
    TOOL_LINK,
    UPPER,
    duration,
    finger_joint,
    urdf_path,
)
from planner.robots.panda.visuals import panda_kinematics, viewer_urdf
from planner.sim.render import render_scene
from planner.sim.transforms import Pose, angle_between, multiply
from planner.view import Box, QueryView, Urdf

SCENE = "panda-6"
VIEW = PandaView()


@pytest.fixture(scope="module", autouse=True)
def mesh_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A mesh cache of this module's own, so the viewer URDF is built here once."""
    folder = tmp_path_factory.mktemp("mesh-cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TAMP_MESH_CACHE", str(folder))
        yield folder


@pytest.fixture(scope="module")
def problem() -> Problem:
    return problem_for_scene(SCENE, seed=0)[1]


@pytest.fixture(scope="module")
def drawn() -> yourdfpy.URDF:
    return yourdfpy.URDF.load(str(viewer_urdf()))


@pytest.fixture(scope="module")
def bullet() -> Iterator[tuple[int, int]]:
    """pybullet_data's Panda in a client of its own: (client, robot)."""
    client = p.connect(p.DIRECT)
    robot = p.loadURDF(str(urdf_path()), useFixedBase=True, physicsClientId=client)
    yield client, robot
    p.disconnect(client)


def _bullet_links(client: int, robot: int, joints: dict[str, float]) -> dict[str, Pose]:
    """Each link's frame (not its centre of mass) where pybullet puts it for ``joints``."""
    out: dict[str, Pose] = {"panda_link0": ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))}
    for i in range(p.getNumJoints(robot, physicsClientId=client)):
        info = p.getJointInfo(robot, i, physicsClientId=client)
        p.resetJointState(robot, i, joints.get(info[1].decode(), 0.0), physicsClientId=client)
    for i in range(p.getNumJoints(robot, physicsClientId=client)):
        link = p.getJointInfo(robot, i, physicsClientId=client)[12].decode()
        state = p.getLinkState(robot, i, computeForwardKinematics=True, physicsClientId=client)
        (x, y, z), (qx, qy, qz, qw) = state[4], state[5]
        out[link] = ((x, y, z), (qx, qy, qz, qw))
    return out


def _angle(a: np.ndarray, quat: tuple[float, float, float, float]) -> float:
    """The angle between rotation matrix ``a`` and the rotation of ``quat`` (xyzw)."""
    b = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)
    return float(np.arccos(np.clip((np.trace(a.T @ b) - 1) / 2, -1.0, 1.0)))


def _start(problem: Problem, block: str) -> BlockPose:
    pose = problem.values[initial_pose_name(block)]
    assert isinstance(pose, BlockPose)
    return pose


def _random_joints(rng: random.Random) -> dict[str, float]:
    arm = [rng.uniform(lo, hi) for lo, hi in zip(LOWER, UPPER, strict=True)]
    return robot_joints(arm, rng.uniform(0.0, 0.04))


# --- the drawn arm ---------------------------------------------------------------------------


def test_the_drawn_panda_has_exactly_pybullets_links_and_joints() -> None:
    source = ET.parse(urdf_path()).getroot()
    made = ET.parse(viewer_urdf()).getroot()
    assert [link.get("name") for link in made.iter("link")] == [
        link.get("name") for link in source.iter("link")
    ]

    def joint(e: ET.Element) -> list[str]:  # its XML, whatever the indentation
        return ET.tostring(e, encoding="unicode").split()

    assert [joint(j) for j in made.findall("joint")] == [joint(j) for j in source.findall("joint")]


def test_each_drawn_link_is_where_pybullet_puts_it(
    drawn: yourdfpy.URDF, bullet: tuple[int, int]
) -> None:
    """For random configurations, yourdfpy's frames on the viewer URDF (what the 3D view
    draws) and the view's own kinematics (its ghosts and plan) are pybullet's."""
    client, robot = bullet
    rng = random.Random(7)
    for _ in range(20):
        joints = _random_joints(rng)
        want = _bullet_links(client, robot, joints)
        drawn.update_cfg(np.array([joints[j] for j in drawn.actuated_joint_names]))
        assert set(want) == set(drawn.link_map)
        for link, (position, quat) in want.items():
            frame = np.asarray(drawn.get_transform(link, drawn.base_link), dtype=np.float64)
            assert math.dist(frame[:3, 3], position) < 1e-4, link
            assert _angle(frame[:3, :3], quat) < 1e-3, link
            ours = panda_kinematics().link_pose(link, joints)
            assert math.dist(ours[0], position) < 1e-4, link
            assert angle_between(ours[1], quat) < 1e-3, link


def test_the_drawn_arm_is_light_white_and_dark(drawn: yourdfpy.URDF) -> None:
    triangles = sum(len(g.faces) for g in drawn.scene.geometry.values())
    assert 8_000 <= triangles <= 20_000
    colours = {
        tuple(int(c) for c in g.visual.face_colors[0][:3]) for g in drawn.scene.geometry.values()
    }
    assert any(min(c) >= 220 for c in colours), "white shells"
    assert any(max(c) <= 70 for c in colours), "dark joint covers"


def _mesh(path: str) -> trimesh.Trimesh:
    mesh = trimesh.load(path, force="mesh")
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh


def test_each_drawn_link_keeps_its_shape() -> None:
    """Every vertex drawn lies within 6 mm of the link's mesh in pybullet_data (the most cut
    part, a wrist cover of 746 triangles drawn with 150, is 5 mm off), and the drawn link spans
    what that mesh spans within 3 mm."""
    source = ET.parse(urdf_path()).getroot()
    made = ET.parse(viewer_urdf()).getroot()
    folder = urdf_path().parent
    for link in source.findall("link"):
        mesh = link.find("visual/geometry/mesh")
        if mesh is None:
            continue
        name = mesh.get("filename", "").removeprefix("package://")
        full = _mesh(str(folder / name))
        samples, _ = trimesh.sample.sample_surface(full, 100_000, seed=1)
        tree = cKDTree(np.vstack([samples, full.vertices]))
        files = made.findall(f"link[@name='{link.get('name')}']/visual/geometry/mesh")
        vertices = np.vstack([m.vertices for m in (_mesh(f.get("filename", "")) for f in files)])
        distance, _ = tree.query(vertices)
        assert distance.max() < 0.006, link.get("name")
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        assert np.abs(lo - full.bounds[0]).max() < 0.003, link.get("name")
        assert np.abs(hi - full.bounds[1]).max() < 0.003, link.get("name")


def test_the_viewer_urdf_is_made_once(mesh_cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    first = viewer_urdf()
    stamp = first.stat().st_mtime_ns
    # Remembered in this process: not rebuilt, not even the sources' digest taken again (a
    # check of the work done, not of the seconds, which a busy machine stretches).
    digests: list[Path] = []
    monkeypatch.setattr(visuals, "_digest", lambda source: digests.append(source) or "")
    assert viewer_urdf() == first
    assert digests == []
    assert first.parent == mesh_cache.resolve() and first.stat().st_mtime_ns == stamp


# --- the scene -------------------------------------------------------------------------------


def test_the_scene_shows_the_robot_table_tray_and_every_block(problem: Problem) -> None:
    view = VIEW.scene(problem)
    geometry = geometry_of(problem)
    names = {b.name for b in view.bodies}
    assert {"panda", "table", "region-table", "region-tray"} <= names
    robot = view.body("panda")
    assert isinstance(robot.shape, Urdf) and robot.shape.path == viewer_urdf()
    assert robot.shape.joints == robot_joints(READY, FINGER_OPEN)
    for block in geometry.blocks:
        body = view.body(block.name)
        pose = _start(problem, block.name)
        assert isinstance(body.shape, Box) and body.shape.size == block.size
        assert body.position == pytest.approx((pose.x, pose.y, pose.z))
    assert view.floor is not None and view.floor_z == -geometry.table.height
    assert view.camera is not None


def test_the_rendered_scene_shows_the_arm_table_tray_and_blocks(
    problem: Problem, tmp_path: Path
) -> None:
    """Clearly visible: the arm, the table, the regions, every obstacle and every block but
    those an obstacle stands next to (it may hide them from the renderer's camera)."""
    info = render_scene(VIEW.scene(problem), out=tmp_path / "panda.png", width=480, height=360)
    behind = {b.blocks for b in geometry_of(problem).blocks if b.blocks is not None}
    assert set(info.hidden(30)) <= behind, info.pixels
    assert info.pixels["panda"] > 2_000 and info.pixels["region-tray"] > 500


# --- ghosts ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def sampled(problem: Problem) -> tuple[str, Grasp, Conf, BlockPose, Conf]:
    """A block, its grasp and a configuration holding it at its start pose, a pose in the tray
    and a configuration putting it there, from the domain's samplers."""
    samplers = PandaSamplers(geometry_of(problem), random.Random(0))
    try:
        for block in ("b3", "b4", "b5", "b6"):
            start = _start(problem, block)
            (grasp,) = samplers.sample_grasp(block)
            pick = samplers.inverse_kinematics(block, start, grasp)
            placed = samplers.sample_placement(block, "tray")
            if not isinstance(pick, tuple) or not isinstance(placed, tuple):
                continue
            place = samplers.inverse_kinematics(block, placed[0], grasp)
            if isinstance(place, tuple):
                return block, grasp, pick[0], placed[0], place[0]
    finally:
        samplers.close()
    raise AssertionError("no block of panda-6 could be picked and placed")


def _near(a: Pose, b: Pose) -> bool:
    return math.dist(a[0], b[0]) < 2e-3


def test_each_streams_outputs_are_drawn_in_their_layer(
    problem: Problem, sampled: tuple[str, Grasp, Conf, BlockPose, Conf]
) -> None:
    block, grasp, pick, placed, _ = sampled
    start = _start(problem, block)
    (grasp_marker,) = VIEW.markers(QueryView("sample-grasp", (block,), (grasp,)), problem)
    assert (grasp_marker.layer, grasp_marker.kind) == ("grasps", "boxes")
    hand = multiply(block_pose_to_pose(start), grasp.tool_in_block())
    assert _near((grasp_marker.position, grasp_marker.quat), hand)
    (pose_marker,) = VIEW.markers(
        QueryView("sample-placement", (block, "tray"), (placed,)), problem
    )
    assert (pose_marker.layer, pose_marker.kind, pose_marker.translucent) == (
        "placements",
        "box",
        True,
    )
    assert pose_marker.position == pytest.approx((placed.x, placed.y, placed.z))
    # The IK ghost is the hand at the block (the tool point on the grasp point).
    (conf_marker,) = VIEW.markers(
        QueryView("inverse-kinematics", (block, start, grasp), (pick,)), problem
    )
    assert (conf_marker.layer, conf_marker.kind) == ("confs", "boxes")
    assert math.dist(conf_marker.position, hand[0]) < 2e-3
    path = (READY, pick.raised, pick.arm)
    traj = Trajectory(path, duration(path), None)
    (motion,) = VIEW.markers(QueryView("plan-motion", (Conf(READY, READY), pick), (traj,)), problem)
    assert (motion.layer, motion.kind) == ("motions", "path")
    assert math.dist(motion.points[0], tool_pose(READY)[0]) < 1e-9
    assert math.dist(motion.points[-1], hand[0]) < 2e-3
    assert len(motion.points) > len(path)  # the hand's curve between waypoints


def test_grasp_ghosts_are_sized_to_their_block(
    problem: Problem, sampled: tuple[str, Grasp, Conf, BlockPose, Conf]
) -> None:
    """A grasp's ghost is the hand's slim outline with its pads on the block's faces: as far
    apart as the block is wide between the fingers, and no part of it big enough to hide the
    block (the whole hand's ghost, 20 cm across, buried the 4 cm blocks)."""
    block, grasp, _, _, _ = sampled
    size = geometry_of(problem).block(block).size
    (marker,) = VIEW.markers(QueryView("sample-grasp", (block,), (grasp,)), problem)
    pads = [(c, s) for c, s in marker.parts if s == GHOST_PAD]
    assert len(pads) == 2
    across = abs(pads[0][0][1] - pads[1][0][1]) - GHOST_PAD[1]  # inner face to inner face
    between = size[1] if round(grasp.yaw / (math.pi / 2)) % 2 == 0 else size[0]
    assert across == pytest.approx(between)
    volume = size[0] * size[1] * size[2]
    assert all(s[0] * s[1] * s[2] < volume / 4 for _, s in marker.parts)
    assert max(abs(c[1]) + s[1] / 2 for c, s in marker.parts) < between / 2 + 0.01


def test_failures_and_focus(
    problem: Problem, sampled: tuple[str, Grasp, Conf, BlockPose, Conf]
) -> None:
    block, grasp, pick, placed, _ = sampled
    where = VIEW.failure_at(QueryView("inverse-kinematics", (block, placed, grasp)), problem)
    assert where is not None and where[:2] == pytest.approx((placed.x, placed.y))
    assert where[2] > placed.z
    tray = geometry_of(problem).region("tray")
    where = VIEW.failure_at(QueryView("sample-placement", (block, "tray")), problem)
    assert where is not None and where[:2] == pytest.approx(tray.center)
    branch = [
        QueryView("sample-grasp", (block,), (grasp,)),
        QueryView("inverse-kinematics", (block, placed, grasp), (pick,)),
    ]
    focus = VIEW.focus(branch, problem)
    assert focus.bodies[ROBOT].joints == robot_joints(pick.arm)
    assert VIEW.focus(branch[:1], problem).bodies == {}


# --- the plan ----------------------------------------------------------------------------------


def test_a_plan_carries_the_block_in_the_hand(
    problem: Problem, sampled: tuple[str, Grasp, Conf, BlockPose, Conf]
) -> None:
    block, grasp, pick, placed, place = sampled
    start = _start(problem, block)
    q0 = problem.values[START_CONF]
    assert isinstance(q0, Conf)
    to_pick = (q0.arm, pick.raised, pick.arm)
    to_place = (pick.arm, pick.raised, place.raised, place.arm)
    t1 = Trajectory(to_pick, duration(to_pick), None)
    t2 = Trajectory(to_place, duration(to_place), block)
    values = {
        "t1": t1,
        "t2": t2,
        "q1": pick,
        "q2": place,
        "p1": placed,
        "g": grasp,
    }
    pose0 = initial_pose_name(block)
    actions = [
        GroundAction("move", (START_CONF, "q1", "t1")),
        GroundAction("pick", (block, pose0, "table", "g", "q1")),
        GroundAction("move", ("q1", "q2", "t2")),
        GroundAction("place", (block, "p1", "tray", "g", "q2")),
    ]
    timeline = VIEW.animate(actions, values, problem)
    assert isinstance(timeline, PandaTimeline)
    first = t1.seconds
    assert timeline.duration == pytest.approx(first + t2.seconds)

    def block_at(t: float) -> Pose:
        state = timeline.at(t)
        robot, held = state[ROBOT], state[block]
        if held.attached is None:
            return (held.position, held.quat)
        body, link, position, quat = held.attached
        assert (body, link) == (ROBOT, TOOL_LINK)
        assert robot.joints is not None
        tool = panda_kinematics().link_pose(link, robot.joints)
        return multiply(tool, (position, quat))

    assert timeline.at(0.0)[ROBOT].joints == robot_joints(q0.arm)
    assert _near(block_at(0.0), block_pose_to_pose(start))
    assert timeline.at(0.0)[block].attached is None
    # Picked up: it leaves with the hand, which closes on it.
    assert _near(block_at(first + 1e-6), block_pose_to_pose(start))
    carrying = timeline.at(first + t2.seconds / 2)
    assert carrying[block].attached is not None
    fingers = carrying[ROBOT].joints
    assert fingers is not None and fingers["panda_finger_joint1"] == finger_joint(0.04)
    lifted = block_at(first + t2.seconds / 2)
    assert lifted[0][2] > start.z + 0.05
    # Put down in the tray, the hand open again.
    end = timeline.at(timeline.duration)
    assert end[block].attached is None
    assert end[block].position == pytest.approx((placed.x, placed.y, placed.z))
    assert math.dist(block_at(timeline.duration - 1e-6)[0], (placed.x, placed.y, placed.z)) < 3e-3
    assert end[ROBOT].joints == robot_joints(place.arm)

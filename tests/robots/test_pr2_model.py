"""The generated PR2 model: file up to date, loads in pybullet, arm kinematics match IKFast."""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p
import pytest
from pr2_ikfast import ikLeft, ikRight

from planner.robots.pr2 import model as m
from planner.robots.pr2.ik import arm_fk, arm_ik

logger = logging.getLogger(__name__)

IKFAST = {"left": ikLeft, "right": ikRight}
TORSO_HEIGHTS = (0.0, 0.11, 0.22, 0.33)
POSITION_TOL = 1e-3  # m
ANGLE_TOL = 1e-3  # rad


@dataclass(frozen=True)
class LoadedRobot:
    client: int
    body: int
    joints: dict[str, int]  # joint name -> index
    links: dict[str, int]  # link name -> index (base_footprint is -1)

    def set_arm(self, arm: str, joints: Sequence[float], torso: float) -> None:
        p.resetJointState(self.body, self.joints[m.TORSO_JOINT], torso, physicsClientId=self.client)
        for name, value in zip(m.ARM_JOINTS[arm], joints, strict=True):
            p.resetJointState(self.body, self.joints[name], value, physicsClientId=self.client)

    def tool_pose(self, arm: str) -> tuple[np.ndarray, np.ndarray]:
        """Tool frame position and rotation matrix in base_footprint (the body sits at origin)."""
        state = p.getLinkState(
            self.body,
            self.links[m.TOOL_LINK[arm]],
            computeForwardKinematics=True,
            physicsClientId=self.client,
        )
        rotation = np.array(p.getMatrixFromQuaternion(state[5], physicsClientId=self.client))
        return np.array(state[4]), rotation.reshape(3, 3)


@pytest.fixture(scope="module")
def robot() -> Iterator[LoadedRobot]:
    client = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(str(m.URDF_PATH), useFixedBase=True, physicsClientId=client)
        joints, links = {}, {}
        for index in range(p.getNumJoints(body, physicsClientId=client)):
            info = p.getJointInfo(body, index, physicsClientId=client)
            joints[info[1].decode()] = index
            links[info[12].decode()] = index
        yield LoadedRobot(client, body, joints, links)
    finally:
        p.disconnect(physicsClientId=client)


def _angle_between(a: np.ndarray, b: np.ndarray) -> float:
    cos = (np.trace(a.T @ b) - 1.0) / 2.0
    return math.acos(min(1.0, max(-1.0, float(cos))))


def _random_arm_conf(rng: np.random.Generator, arm: str) -> tuple[float, ...]:
    return tuple(float(rng.uniform(*m.JOINT_LIMITS[name])) for name in m.ARM_JOINTS[arm])


# --- the file ---------------------------------------------------------------------------------


def test_committed_urdf_and_meshes_match_generator() -> None:
    assert m.URDF_PATH.read_text(encoding="utf-8") == m.generate_pr2_urdf(), (
        f"{m.URDF_PATH} is stale: regenerate it with `python -m planner.robots.pr2.model --write`"
    )
    assert m.stale_files() == [], "regenerate with `python -m planner.robots.pr2.model --write`"
    assert m.generated_files() == m.generated_files()  # the same bytes every time


def test_check_cli_reports_up_to_date_files() -> None:
    assert m.main(["--check"]) == 0


def test_check_cli_names_a_stale_mesh(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    files = m.generated_files()
    mesh = next(path for path in files if path.suffix == ".obj")
    monkeypatch.setattr(m, "generated_files", lambda: {**files, mesh: files[mesh] + "# edited"})
    assert m.main(["--check"]) == 1
    assert f"{mesh.name} is stale" in capsys.readouterr().err


def test_constants_describe_two_seven_dof_arms() -> None:
    for arm in m.ARMS:
        assert len(m.ARM_JOINTS[arm]) == 7
        assert len(m.REST_ARM_CONF[arm]) == 7
        for name, value in zip(m.ARM_JOINTS[arm], m.REST_ARM_CONF[arm], strict=True):
            lo, hi = m.JOINT_LIMITS[name]
            assert lo <= value <= hi, f"REST_ARM_CONF[{arm}] {name}={value} outside limits"
    rolls = {f"{s}_{j}" for s in "lr" for j in ("forearm_roll_joint", "wrist_roll_joint")}
    assert rolls == m.CONTINUOUS_JOINTS


# --- pybullet ---------------------------------------------------------------------------------


@pytest.mark.slow
def test_urdf_loads_with_pr2_joint_names_and_limits(robot: LoadedRobot) -> None:
    movable = {m.TORSO_JOINT, *m.HEAD_JOINTS}
    for arm in m.ARMS:
        movable |= {*m.ARM_JOINTS[arm], *m.GRIPPER_JOINTS[arm]}
        assert m.TOOL_LINK[arm] in robot.links
    assert "base_link" in robot.links
    assert movable <= set(robot.joints)
    for name in movable:
        info = p.getJointInfo(robot.body, robot.joints[name], physicsClientId=robot.client)
        assert info[11] == pytest.approx(m.VELOCITY_LIMITS[name]), name
        if name in m.CONTINUOUS_JOINTS:
            assert info[8] > info[9], f"{name} should load as an unlimited joint"
        else:
            assert (info[8], info[9]) == pytest.approx(m.JOINT_LIMITS[name]), name
    prismatic = {m.TORSO_JOINT, *m.GRIPPER_JOINTS["left"], *m.GRIPPER_JOINTS["right"]}
    for name in movable:
        info = p.getJointInfo(robot.body, robot.joints[name], physicsClientId=robot.client)
        expected = p.JOINT_PRISMATIC if name in prismatic else p.JOINT_REVOLUTE
        assert info[2] == expected, name


@pytest.mark.slow
@pytest.mark.parametrize("arm", m.ARMS)
def test_pybullet_fk_matches_ikfast(robot: LoadedRobot, arm: str) -> None:
    rng = np.random.default_rng(7)
    worst_position = worst_angle = 0.0
    for i in range(50):
        torso = TORSO_HEIGHTS[i % len(TORSO_HEIGHTS)]
        conf = _random_arm_conf(rng, arm)
        robot.set_arm(arm, conf, torso)
        position, rotation = robot.tool_pose(arm)
        ik_position, ik_rotation = IKFAST[arm].get_fk([torso, *conf])  # in base_link
        expected = np.array(ik_position) + np.array((0.0, 0.0, m.BASE_LINK_HEIGHT))
        worst_position = max(worst_position, float(np.linalg.norm(position - expected)))
        worst_angle = max(worst_angle, _angle_between(rotation, np.array(ik_rotation)))
    logger.info("%s arm FK: max %.2e m, %.2e rad", arm, worst_position, worst_angle)
    assert worst_position < POSITION_TOL
    assert worst_angle < ANGLE_TOL


@pytest.mark.slow
@pytest.mark.parametrize("arm", m.ARMS)
def test_every_ik_solution_reaches_the_target_in_pybullet(robot: LoadedRobot, arm: str) -> None:
    rng = np.random.default_rng(11)
    solved = checked = 0
    for i in range(15):
        torso = TORSO_HEIGHTS[i % len(TORSO_HEIGHTS)]
        position, quat = arm_fk(arm, _random_arm_conf(rng, arm), torso=torso)
        target_rotation = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)
        solutions = arm_ik(arm, position, quat, torso=torso)
        solved += bool(solutions)
        for conf in solutions:
            for name, value in zip(m.ARM_JOINTS[arm], conf, strict=True):
                lo, hi = m.JOINT_LIMITS[name]
                assert lo <= value <= hi, f"{name}={value} outside [{lo}, {hi}]"
            robot.set_arm(arm, conf, torso)
            got_position, got_rotation = robot.tool_pose(arm)
            assert np.linalg.norm(got_position - np.array(position)) < POSITION_TOL
            assert _angle_between(got_rotation, target_rotation) < ANGLE_TOL
            checked += 1
    assert solved >= 13, f"only {solved}/15 reachable targets got an IK solution"
    assert checked >= 3 * solved, "expected several solutions per target (8 branches x rolls)"


@pytest.mark.slow
def test_rest_arm_conf_keeps_arms_clear_of_base_and_torso(robot: LoadedRobot) -> None:
    half_width = m.BASE_SIZE[0] / 2
    body_links = ("base_link", "torso_lift_link", "head_pan_link", "head_tilt_link")
    for torso in (0.0, m.JOINT_LIMITS[m.TORSO_JOINT][1]):
        for arm in m.ARMS:
            robot.set_arm(arm, m.REST_ARM_CONF[arm], torso)
        for arm in m.ARMS:
            other = "right" if arm == "left" else "left"
            for link in m.ARM_LINKS[arm][1:]:  # the shoulder pan link is mounted in the torso
                for obstacle in (*body_links, *m.ARM_LINKS[other]):
                    contacts = p.getClosestPoints(
                        robot.body,
                        robot.body,
                        0.0,
                        robot.links[link],
                        robot.links[obstacle],
                        physicsClientId=robot.client,
                    )
                    assert not contacts, f"torso {torso}: {link} touches {obstacle}"
                lo, hi = p.getAABB(robot.body, robot.links[link], physicsClientId=robot.client)
                assert max(abs(v) for v in (*lo[:2], *hi[:2])) <= half_width, (
                    f"torso {torso}: {link} sticks out of the base footprint"
                )


# --- IK without the simulator -----------------------------------------------------------------


def test_tool_frame_at_zero_is_where_the_pr2_reaches() -> None:
    position, quat = arm_fk("left", [0.0] * 7, torso=0.0)
    # shoulder 0.188 m left of centre; 0.951 m forward; base_link 0.051 + torso 0.739675 up
    assert position == pytest.approx((0.951, 0.188, 0.790675))
    assert quat == pytest.approx((0.0, 0.0, 0.0, 1.0))
    assert arm_fk("right", [0.0] * 7, torso=0.1)[0] == pytest.approx((0.951, -0.188, 0.890675))


@pytest.mark.parametrize("arm", m.ARMS)
def test_ik_with_fixed_roll_recovers_the_configuration(arm: str) -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        torso = float(rng.uniform(*m.JOINT_LIMITS[m.TORSO_JOINT]))
        conf = _random_arm_conf(rng, arm)
        position, quat = arm_fk(arm, conf, torso=torso)
        solutions = arm_ik(
            arm, position, quat, torso=torso, upper_arm_roll=conf[2], nearest_to=conf
        )
        assert solutions, f"no IK solution for a pose made from {conf}"
        assert solutions[0] == pytest.approx(conf, abs=1e-6)
        assert all(s[2] == pytest.approx(conf[2]) for s in solutions)


def test_ik_is_deterministic_and_empty_when_out_of_reach() -> None:
    position, quat = arm_fk("left", (0.3, 0.2, 1.0, -1.0, 0.5, -0.8, 0.2), torso=0.15)
    first = arm_ik("left", position, quat, torso=0.15)
    assert first == arm_ik("left", position, quat, torso=0.15)
    assert first == sorted(first)
    assert arm_ik("left", (3.0, 0.0, 0.8), (0.0, 0.0, 0.0, 1.0), torso=0.1) == []


def test_ik_rejects_unknown_arm_and_bad_inputs() -> None:
    with pytest.raises(ValueError, match="known arms: left, right"):
        arm_ik("middle", (0.7, 0.2, 0.8), (0.0, 0.0, 0.0, 1.0), torso=0.1)
    with pytest.raises(ValueError, match="torso_lift_joint"):
        arm_ik("left", (0.7, 0.2, 0.8), (0.0, 0.0, 0.0, 1.0), torso=0.5)
    with pytest.raises(ValueError, match="zero length"):
        arm_ik("left", (0.7, 0.2, 0.8), (0.0, 0.0, 0.0, 0.0), torso=0.1)
    with pytest.raises(ValueError, match="known arms"):
        arm_fk("up", [0.0] * 7, torso=0.0)

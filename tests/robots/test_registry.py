"""The robots' registry (planner/robots): robots by name, an unknown name lists the known ones,
another package's robot joins it, and every robot's files are where an installed wheel has them:
loadable by pybullet from inside the package, and covered by the package data."""

from __future__ import annotations

import re
import tomllib
from collections.abc import Iterator
from pathlib import Path, PurePosixPath

import pybullet as p
import pytest

import planner
from planner import robots
from planner.robots import Robot, UnknownRobotError, get_robot, known_robots, register_robot
from planner.robots.base import path_seconds, step_seconds

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = Path(planner.__file__).resolve().parent


def _package_data() -> list[str]:
    data = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    patterns: list[str] = data["tool"]["setuptools"]["package-data"]["planner"]
    return patterns


def _shipped(path: Path) -> bool:
    """The file is inside the package and a package-data pattern takes it into the wheel."""
    if not path.resolve().is_relative_to(PACKAGE):
        return False
    relative = PurePosixPath(path.resolve().relative_to(PACKAGE).as_posix())
    return any(
        relative.match(pattern) and len(relative.parts) == len(PurePosixPath(pattern).parts)
        for pattern in _package_data()
    )


@pytest.fixture
def registered() -> Iterator[None]:
    yield
    robots._REGISTERED.pop("toy-arm", None)


def test_the_project_s_robots_are_known_by_name() -> None:
    assert known_robots() == ("panda", "pr2")
    for name in known_robots():
        robot = get_robot(name)
        assert robot.name == name and robot.description
        assert get_robot(name) is robot  # one object per name


def test_an_unknown_robot_lists_the_known_ones() -> None:
    with pytest.raises(
        UnknownRobotError, match=r"unknown robot 'ur5' \(known robots: panda, pr2\)"
    ):
        get_robot("ur5")


def test_another_package_s_robot_joins_the_registry(registered: None, tmp_path: Path) -> None:
    urdf = tmp_path / "toy.urdf"
    toy = Robot("toy-arm", "a test arm", urdf=lambda: urdf, view_urdf=lambda: urdf)
    register_robot(toy)
    register_robot(toy)  # the same robot again is no change
    assert get_robot("toy-arm") is toy and "toy-arm" in known_robots()
    with pytest.raises(ValueError, match="already taken"):
        register_robot(Robot("toy-arm", "another", urdf=lambda: urdf, view_urdf=lambda: urdf))
    with pytest.raises(ValueError, match="already taken"):
        register_robot(Robot("pr2", "not the PR2", urdf=lambda: urdf, view_urdf=lambda: urdf))


def test_a_robot_with_impossible_limits_is_refused(tmp_path: Path) -> None:
    urdf = tmp_path / "toy.urdf"
    with pytest.raises(ValueError, match="joint j1 has limits"):
        Robot("toy", "", urdf=lambda: urdf, view_urdf=lambda: urdf, joint_limits={"j1": (1, 0)})
    with pytest.raises(ValueError, match="joint j1 has velocity limit 0"):
        Robot("toy", "", urdf=lambda: urdf, view_urdf=lambda: urdf, velocity_limits={"j1": 0})


@pytest.mark.parametrize("name", ["pr2", "panda"])
def test_every_moving_joint_has_its_limits(name: str) -> None:
    robot = get_robot(name)
    client = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(
            str(robot.urdf()),
            useFixedBase=True,
            flags=p.URDF_IGNORE_VISUAL_SHAPES,
            physicsClientId=client,
        )
        moving = {
            info[1].decode()
            for info in (
                p.getJointInfo(body, j, physicsClientId=client)
                for j in range(p.getNumJoints(body, physicsClientId=client))
            )
            if info[2] != p.JOINT_FIXED
        }
    finally:
        p.disconnect(physicsClientId=client)
    assert moving and moving <= set(robot.velocity_limits)
    assert moving <= set(robot.joint_limits)


def test_a_path_takes_as_long_as_its_slowest_joint_needs() -> None:
    assert step_seconds((0.0, 0.0), (1.0, -0.5), (2.0, 0.25)) == pytest.approx(2.0)
    assert path_seconds([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)], (2.0, 0.5)) == pytest.approx(2.5)
    pr2 = get_robot("pr2")
    joints = ("torso_lift_joint", "head_pan_joint")
    assert pr2.velocities(joints) == (0.013, 6.0)


def test_the_pr2_s_files_ship_inside_the_package() -> None:
    """What an installed wheel holds is what the PR2 reads: its URDF and every mesh the URDF
    names, inside planner/robots/pr2 and taken by a package-data pattern (nothing from the
    repository's root)."""
    for name in ("pr2", "panda"):
        for urdf in {get_robot(name).urdf(), get_robot(name).view_urdf()}:
            assert urdf.is_file()
    urdf = get_robot("pr2").urdf()
    assert urdf.resolve().is_relative_to(PACKAGE / "robots" / "pr2")
    assert get_robot("pr2").view_urdf() == urdf
    meshes = re.findall(r'filename="([^"]+)"', urdf.read_text(encoding="utf-8"))
    assert len(meshes) > 20
    for path in [urdf, *(urdf.parent / mesh for mesh in meshes)]:
        assert path.is_file(), path
        assert _shipped(path), f"{path} is not package data (pyproject.toml)"
    assert not _shipped(ROOT / "scenes" / "kitchen-1.json")  # the check can fail


def test_every_file_the_package_holds_ships_in_the_wheel() -> None:
    """Each domain's and each robot's own files (PDDL, scenes, shipped models, URDFs, meshes)
    are package data: what the wheel installs is what the source tree runs with."""
    files = [
        path
        for path in PACKAGE.rglob("*")
        if path.is_file() and "__pycache__" not in path.parts and path.suffix not in (".py", ".pyc")
    ]
    kinds = {path.suffix for path in files}
    assert {".pddl", ".json", ".pt", ".urdf", ".obj"} <= kinds  # the walk found the assets
    missing = sorted(str(path.relative_to(PACKAGE)) for path in files if not _shipped(path))
    assert not missing, f"not package data (pyproject.toml): {missing}"

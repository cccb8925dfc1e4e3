"""The broad-phase collision checker answers as every exact query would: for the kitchen's PR2 on
its mobile base and for a fixed-base Panda, with and without a held block, with and without
clearance; its pair filter only drops link pairs that no joint values bring that close; and a
seeded kitchen motion is the same path with it as with every exact query."""

from __future__ import annotations

import math
import multiprocessing
import random
from collections.abc import Iterable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pybullet as p
import pybullet_data
import pytest

from planner.domains.kitchen.geometry import KitchenGeometry, geometry_from_scene
from planner.domains.kitchen.samplers import KitchenSamplers, SamplerConfig, _grasps
from planner.domains.kitchen.values import Conf
from planner.domains.kitchen.world import KitchenWorld
from planner.domains.manipulation.world import PENETRATION
from planner.pddl import Atom
from planner.robots.pr2.model import ARM_JOINTS, JOINT_LIMITS, REST_ARM_CONF
from planner.scene import load_scene
from planner.sim import bodies
from planner.sim.collision import Attached, CollisionConfig, Obstacles, RobotCollision
from planner.sim.transforms import multiply, quat_from_euler
from planner.streams import StreamContext

pytestmark = pytest.mark.slow

EXACT = CollisionConfig(broad_phase=False, pair_filter=False)  # every exact query there is
PANDA = Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"


def _closer(client: int, a: int, b: int, margin: float, **links: int) -> bool:
    return bool(p.getClosestPoints(a, b, margin, physicsClientId=client, **links))


def _kitchen_exact(world: KitchenWorld, *, ignore: Iterable[str] = (), clearance: float) -> bool:
    """The kitchen's question asked with every exact query, as robot_collides did before it
    had a broad phase: the whole robot against each fixture and placed block, each arm link
    against each base link, the held block against all of those and the base."""
    c, robot = world.client, world.robot
    margin = clearance if clearance > 0 else PENETRATION
    held = world.held[0] if world.held else None
    skip = set(ignore)
    obstacles = list(world.fixtures.values()) + [
        world.blocks[n] for n in world.placed if n not in skip and n != held
    ]
    if any(_closer(c, robot, o, margin) for o in obstacles):
        return True
    if any(
        _closer(c, robot, robot, margin, linkIndexA=a, linkIndexB=b)
        for a in world.arm_links
        for b in world.base_links
    ):
        return True
    if held is None:
        return False
    body = world.blocks[held]
    return any(_closer(c, body, o, margin) for o in obstacles) or any(
        _closer(c, robot, body, margin, linkIndexA=b) for b in world.base_links
    )


@pytest.fixture(scope="module")
def kitchen() -> KitchenGeometry:
    return geometry_from_scene(load_scene("kitchen-4"))


def test_the_kitchen_gets_the_exact_answer_everywhere(kitchen: KitchenGeometry) -> None:
    """Random configurations round the fixtures, the arm anywhere or folded, a block in the hand
    or not, the block to grasp ignored or not: the same answers as every exact query. Between
    block arrangements the robot moves as a search moves it: the base alone, or the arm."""
    rng = random.Random(0)
    lower = [JOINT_LIMITS[j][0] for j in ARM_JOINTS["right"]]
    upper = [JOINT_LIMITS[j][1] for j in ARM_JOINTS["right"]]
    grasps = _grasps(0.07, 0.1)
    poses = kitchen.initial_poses(0)
    answers: list[bool] = []
    with KitchenWorld(kitchen, "right") as world:
        for _ in range(150):
            held = rng.choice([None, *sorted(poses)])
            world.hold(None)
            world.set_blocks({b: pose for b, pose in poses.items() if b != held})
            if held is not None:
                world.hold(held, rng.choice(grasps))
            cx, cy = rng.choice(kitchen.platforms).center
            torso = rng.uniform(0.0, 0.33)
            base = (cx + rng.uniform(-1, 1), cy + rng.uniform(-1, 1), rng.uniform(-4, 4))
            arm = REST_ARM_CONF["right"]
            for _ in range(10):
                if rng.random() < 0.5:
                    x, y, _ = base
                    base = (x + rng.uniform(-0.3, 0.3), y + rng.uniform(-0.3, 0.3), base[2] + 1)
                else:
                    arm = tuple(rng.uniform(lo, hi) for lo, hi in zip(lower, upper, strict=True))
                world.set_conf(Conf(base, torso, arm))
                ignore = [rng.choice(sorted(poses))] if rng.random() < 0.3 else []
                clearance = rng.choice([0.0, SamplerConfig().clearance, 0.05])
                got = world.robot_collides(ignore=ignore, clearance=clearance)
                assert got == _kitchen_exact(world, ignore=ignore, clearance=clearance)
                answers.append(got)
    assert 0.2 < sum(answers) / len(answers) < 0.8  # both answers, many times


def test_a_block_let_go_of_is_an_obstacle_where_the_hand_left_it(
    kitchen: KitchenGeometry,
) -> None:
    poses = kitchen.initial_poses(0)
    start = Conf(kitchen.robot.base, kitchen.robot.torso, REST_ARM_CONF["right"])
    with KitchenWorld(kitchen, "right") as world:
        world.set_blocks(poses)
        world.set_conf(start)
        assert not world.robot_collides(clearance=0.015)
        world.hold("b1", _grasps(0.07, 0.1)[0])
        world.set_conf(start)  # the block comes to the hand
        world.hold(None)
        assert world.robot_collides(clearance=0.015)  # the fingers are round it
        assert _kitchen_exact(world, clearance=0.015)


def _panda_world() -> tuple[int, int, list[int], list[int]]:
    """A Panda on a table with a shelf and four blocks in reach and one to hold: client, robot,
    the obstacles, the blocks."""
    c = bodies.connect()
    robot = int(
        p.loadURDF(
            str(PANDA), useFixedBase=True, flags=p.URDF_IGNORE_VISUAL_SHAPES, physicsClientId=c
        )
    )
    table = bodies.add_box(c, (0.6, 0.8, 0.02), ((0.3, 0.0, -0.02), (0, 0, 0, 1)), (1, 1, 1, 1))
    shelf = bodies.add_box(c, (0.1, 0.4, 0.02), ((0.5, 0.0, 0.5), (0, 0, 0, 1)), (1, 1, 1, 1))
    blocks = [
        bodies.add_box(c, (0.02, 0.02, 0.02), ((x, y, 0.02), (0, 0, 0, 1)), (1, 0, 0, 1))
        for x, y in ((0.5, 0.0), (0.4, 0.3), (0.3, -0.35), (0.6, 0.2), (0.0, 0.0))
    ]
    return c, robot, [table, shelf, *blocks[:4]], blocks


def test_a_fixed_base_arm_with_a_held_block_gets_the_exact_answer() -> None:
    """The whole arm against the shelf and the blocks, the links that move against the table its
    base stands on, wrist and hand against base and shoulder, and half the time a block in the
    hand against all that and the links up to the elbow."""
    c, robot, obstacles, blocks = _panda_world()
    table, held = obstacles[0], blocks[4]
    moving = list(range(0, 11))  # link1 .. the fingers
    hand, tool = 8, 11
    self_pairs = [(a, b) for a in (5, 6, hand, 9, 10) for b in (-1, 0, 1)]
    held_against = (-1, 0, 1, 2, 3)
    checkers = {
        name: RobotCollision(c, robot, self_pairs=self_pairs, config=config)
        for name, config in (("broad", CollisionConfig()), ("exact", EXACT))
    }
    joints = list(range(7))
    limits = [p.getJointInfo(robot, j, physicsClientId=c)[8:10] for j in joints]
    rng = random.Random(1)
    answers: list[bool] = []
    try:
        for _ in range(150):
            bodies.set_pose(c, blocks[0], ((rng.uniform(0.2, 0.7), 0.0, 0.02), (0, 0, 0, 1)))
            scene = Obstacles(c, obstacles, links={table: moving})
            for _ in range(10):
                q = [rng.uniform(lo, hi) for lo, hi in limits]
                p.resetJointStatesMultiDof(robot, joints, [[v] for v in q], physicsClientId=c)
                attached = None
                if rng.random() < 0.5:
                    tool_pose = bodies.link_pose(c, robot, tool)
                    grip = (
                        (0.0, 0.0, rng.uniform(-0.01, 0.01)),
                        quat_from_euler(0, 0, rng.random()),
                    )
                    bodies.set_pose(c, held, multiply(tool_pose, grip))
                    attached = Attached(held, held_against)
                else:
                    bodies.set_pose(c, held, ((0.0, 0.0, -5.0), (0, 0, 0, 1)))
                margin = rng.choice([PENETRATION, 0.01, 0.03])
                got = {
                    name: check.collides(scene, margin=margin, attached=attached)
                    for name, check in checkers.items()
                }
                exact = (
                    any(_closer(c, robot, table, margin, linkIndexA=k) for k in moving)
                    or any(_closer(c, robot, o, margin) for o in obstacles[1:])
                    or any(
                        _closer(c, robot, robot, margin, linkIndexA=a, linkIndexB=b)
                        for a, b in self_pairs
                    )
                    or (
                        attached is not None
                        and (
                            any(_closer(c, held, o, margin) for o in obstacles)
                            or any(
                                _closer(c, robot, held, margin, linkIndexA=k) for k in held_against
                            )
                        )
                    )
                )
                assert got == {"broad": exact, "exact": exact}
                answers.append(exact)
    finally:
        bodies.disconnect(c)
    assert 0.2 < sum(answers) / len(answers) < 0.8


def _min_distances(
    client: int, robot: int, samples: int, seed: int
) -> dict[tuple[int, int], float]:
    """The least distance seen between every two links with collision shapes, over random
    values of every moving joint within its limits (continuous joints: a full turn)."""
    n = p.getNumJoints(robot, physicsClientId=client)
    moving = []
    for j in range(n):
        info = p.getJointInfo(robot, j, physicsClientId=client)
        if info[2] != p.JOINT_FIXED:
            lo, hi = info[8], info[9]
            moving.append((j, (lo, hi) if lo <= hi else (-math.pi, math.pi)))
    shaped = [k for k in range(-1, n) if p.getCollisionShapeData(robot, k, physicsClientId=client)]
    pairs = [(a, b) for i, a in enumerate(shaped) for b in shaped[i + 1 :]]
    least = {pair: math.inf for pair in pairs}
    rng = random.Random(seed)
    for _ in range(samples):
        for j, (lo, hi) in moving:
            p.resetJointState(robot, j, rng.uniform(lo, hi), physicsClientId=client)
        for a, b in pairs:
            pts = p.getClosestPoints(
                robot, robot, 5.0, linkIndexA=a, linkIndexB=b, physicsClientId=client
            )
            if pts:
                least[a, b] = min(least[a, b], min(pt[8] for pt in pts))
    return least


@pytest.mark.parametrize("robot_name", ["pr2", "panda"])
def test_the_pair_filter_only_drops_pairs_that_never_come_close(
    robot_name: str, kitchen: KitchenGeometry
) -> None:
    """Every two links' bound is below the least distance they reach at random joint values,
    so a pair dropped at a margin never comes within it."""
    if robot_name == "pr2":
        world = KitchenWorld(kitchen, "right")
        c, robot = world.client, world.robot
    else:
        c, robot, _, _ = _panda_world()
    try:
        check = RobotCollision(c, robot)
        least = _min_distances(c, robot, 150, seed=2)
        for (a, b), seen in least.items():
            assert check.pair_bound(a, b) <= seen + 1e-9, (a, b)
    finally:
        bodies.disconnect(c)


def test_the_kitchen_checks_fewer_self_pairs(kitchen: KitchenGeometry) -> None:
    """Of the arm's 11 links against the 2 base links, the shapeless ones (the root, the tool
    frame) and those that cannot reach down to the base (the shoulder) are not checked."""
    with KitchenWorld(kitchen, "right") as world:
        kept = world.collision.kept_pairs(SamplerConfig().clearance)
        assert len(world.collision.self_pairs) == 22
        assert len(kept) == 8
        assert all(b == world.base_links[1] for _, b in kept)


def _kitchen_motions(exact: bool) -> list[object]:
    """In a fresh process (OMPL takes one seed per process): kitchen-4 seed 2, the motion to
    pick b1 and, holding it, to the stove, with every exact query or with the broad phase."""
    geometry = geometry_from_scene(load_scene("kitchen-4"))
    samplers = KitchenSamplers(geometry, random.Random(2))
    if exact:
        samplers.world.close()
        samplers.world = KitchenWorld(geometry, samplers.arm, collision=EXACT)
    poses = geometry.initial_poses(2)
    values: dict[str, object] = {f"p_{b}": pose for b, pose in poses.items()}
    values["q0"] = q0 = Conf(geometry.robot.base, geometry.robot.torso, REST_ARM_CONF["right"])
    state = {Atom("at-pose", (b, f"p_{b}")) for b in poses} | {Atom("at-conf", ("q0",))}
    context = StreamContext(frozenset(state), values)
    (grasp,) = samplers.sample_grasp("b1")
    (pick,) = samplers.inverse_kinematics("b1", poses["b1"], grasp, context=context)  # type: ignore[misc]
    to_pick = samplers.plan_motion(q0, pick, context=context)
    values.update(g=grasp, q1=pick)
    state = {Atom("at-pose", (b, f"p_{b}")) for b in poses if b != "b1"}
    state |= {Atom("holding", ("b1", "g")), Atom("at-conf", ("q1",))}
    context = StreamContext(frozenset(state), values)
    (place,) = samplers.sample_placement("b1", "stove", context=context)  # type: ignore[misc]
    (cook,) = samplers.inverse_kinematics("b1", place, grasp, context=context)  # type: ignore[misc]
    to_stove = samplers.plan_motion(pick, cook, context=context)
    samplers.close()
    return [pick, to_pick, place, cook, to_stove]


def test_a_seeded_kitchen_motion_is_the_same_path_as_with_every_exact_query() -> None:
    spawn = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(2, mp_context=spawn, max_tasks_per_child=1) as pool:
        exact, broad = pool.submit(_kitchen_motions, True), pool.submit(_kitchen_motions, False)
        got, want = broad.result(), exact.result()
    assert got == want
    (to_pick,), (to_stove,) = got[1], got[4]  # type: ignore[misc]
    # Both moves went round something: the base's and an arm's RRT grew trees (more than the
    # straight line's two waypoints), one of them with the block in the hand.
    assert any(len(s.base) > 2 for s in to_pick.segments)
    assert any(len(s.base) > 2 for s in to_stove.segments) and to_stove.holding == "b1"

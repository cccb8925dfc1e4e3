"""The Panda tabletop: its scenes, samplers and validator (planner/domains/panda)."""

from __future__ import annotations

import json
import math
import random
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from planner.abstract.skeleton import GroundAction
from planner.domains import load_domain
from planner.domains.manipulation.problem import initial_pose_name
from planner.domains.panda.geometry import geometry_from_scene
from planner.domains.panda.problem import START_CONF, geometry_of
from planner.domains.panda.samplers import PandaSamplers, grasp_height, tool_target
from planner.domains.panda.values import BlockPose, Conf, Grasp, Trajectory
from planner.domains.panda.world import PandaWorld
from planner.pddl.structs import Atom, Problem
from planner.robots.panda.model import LOWER, UPPER
from planner.scene import Scene, SceneError, load_scene
from planner.sim.transforms import angle_between
from planner.streams.adapters import StreamContext

SCENES = Path(__file__).resolve().parents[2] / "planner" / "domains" / "panda" / "scenes"


def _scene(n: int) -> Scene:
    return load_scene(str(SCENES / f"panda-{n}.json"))


def _problem(n: int, seed: int) -> Problem:
    return load_domain("panda").problem_from_scene(_scene(n), seed=seed)


def _context(problem: Problem, **changes: Any) -> StreamContext:
    """The start state, with ``moved`` blocks taken off their start poses and ``holding`` (a
    block, a grasp) in the hand."""
    moved = set(changes.get("moved", ()))
    state = {a for a in problem.init if not (a.predicate == "at-pose" and a.args[0] in moved)}
    values = dict(problem.values)
    if "holding" in changes:
        block, grasp = changes["holding"]
        state = {a for a in state if not (a.predicate == "at-pose" and a.args[0] == block)}
        state.add(Atom("holding", (block, "g")))
        values["g"] = grasp
    return StreamContext(frozenset(state), values)


def test_every_scene_loads_and_its_obstacles_stand_against_their_blocks() -> None:
    for n in (2, 4, 6, 8, 10, 12):
        geometry = geometry_from_scene(_scene(n))
        targets = [b for b in geometry.blocks if not b.obstacle]
        assert len(targets) == n
        for seed in (1000, 1001, 1002):
            poses = geometry.initial_poses(seed)
            for block in geometry.blocks:
                pose = poses[block.name]
                assert geometry.region(block.start).contains(pose, block.size)
                if block.blocks is not None:  # a face 5 mm from its target's
                    target = poses[block.blocks]
                    assert math.hypot(pose.x - target.x, pose.y - target.y) == pytest.approx(
                        0.045, abs=1e-6
                    )


@pytest.mark.parametrize(
    ("change", "says"),
    [
        (lambda d: d["regions"][1].update(kind="bowl"), "regions[1].kind: expected one of"),
        (lambda d: d["blocks"][0].update(size=[0.06, 0.06, 0.04]), "blocks[0].size"),
        (lambda d: d["obstacles"][0].update(blocks="b99"), "obstacles[0].blocks: no block"),
        (lambda d: d["regions"][1].update(center=[0.95, 0.3]), "regions[1]"),
        (lambda d: d["regions"].pop(1), "regions: expected a table region and a tray"),
    ],
)
def test_a_bad_scene_names_its_field(change: Any, says: str) -> None:
    data = json.loads((SCENES / "panda-4.json").read_text())
    change(data)
    with pytest.raises(SceneError, match=says.replace("[", r"\[").replace("]", r"\]")):
        geometry_from_scene(Scene("panda-4", "panda", data, "panda-4.json"))


def test_the_problem_says_which_blocks_are_obstructed_and_where_each_may_go() -> None:
    problem = _problem(4, 1000)
    assert Atom("obstructed", ("b1",)) in problem.init
    assert Atom("obstructs", ("o1", "b1")) in problem.init
    assert Atom("placeable", ("b1", "tray")) in problem.init
    assert Atom("placeable", ("o1", "table")) in problem.init
    assert Atom("placeable", ("b1", "table")) not in problem.init


@pytest.fixture(scope="module")
def panda4() -> Any:
    problem = _problem(4, 1000)
    samplers = PandaSamplers(geometry_of(problem), random.Random(0))
    yield problem, samplers
    samplers.close()


def test_ik_puts_the_hand_on_the_block_by_the_grasp(panda4: Any) -> None:
    problem, s = panda4
    pose = problem.values[initial_pose_name("b2")]
    grasp = Grasp(0.0, 0.0)
    out = s.inverse_kinematics("b2", pose, grasp, context=_context(problem))
    assert out, out
    (conf,) = out
    s.world.hold(None)
    s.world.set_arm(conf.arm)
    have = s.world.tool_pose()
    misses = [
        (math.dist(have[0], want[0]), angle_between(have[1], want[1]))
        for want in (tool_target(pose, grasp, flip=f) for f in (False, True))
    ]
    assert min(misses) < (1e-3, 1e-2)
    s.world.set_arm(conf.raised)
    assert s.world.tool_pose()[0][2] == pytest.approx(pose.z + 0.10, abs=1e-3)


def test_an_obstacle_blocks_every_grasp_until_it_is_moved(panda4: Any) -> None:
    problem, s = panda4
    pose = problem.values[initial_pose_name("b1")]  # o1 stands against b1
    for yaw in (0.0, math.pi / 2):
        out = s.inverse_kinematics("b1", pose, Grasp(yaw, 0.0), context=_context(problem))
        assert not out and "hand in collision" in out.reason and out.exhausted
    moved = _context(problem, moved=["o1"])
    assert any(
        s.inverse_kinematics("b1", pose, Grasp(yaw, 0.0), context=moved)
        for yaw in (0.0, math.pi / 2)
    )


def test_the_obstacle_itself_can_be_picked(panda4: Any) -> None:
    problem, s = panda4
    pose = problem.values[initial_pose_name("o1")]
    size = geometry_of(problem).block("o1").size
    grasps = [Grasp(yaw, grasp_height(size)) for yaw in (0.0, math.pi / 2)]
    assert any(s.inverse_kinematics("o1", pose, g, context=_context(problem)) for g in grasps)


def test_placements_in_the_tray_fit_and_leave_the_others_alone(panda4: Any) -> None:
    problem, s = panda4
    geometry = geometry_of(problem)
    tray = geometry.region("tray")
    placed: dict[str, BlockPose] = {}
    for block in ("b1", "b2", "b3", "b4"):
        state = {a for a in problem.init if a.predicate != "at-pose"}
        state |= {Atom("at-pose", (b, f"v-{b}")) for b in placed}
        values = {**problem.values, **{f"v-{b}": p for b, p in placed.items()}}
        out = s.sample_placement(block, "tray", context=StreamContext(frozenset(state), values))
        if not out:  # a tray of four has room for four only on its grid
            break
        (pose,) = out
        assert tray.contains(pose, geometry.block(block).size)
        for other in placed.values():
            assert math.hypot(pose.x - other.x, pose.y - other.y) > 0.04
        placed[block] = pose
    assert len(placed) >= 2


def test_a_motion_is_collision_free_and_ends_at_its_configurations(panda4: Any) -> None:
    problem, s = panda4
    context = _context(problem)
    start = problem.values[START_CONF]
    pose = problem.values[initial_pose_name("b3")]
    out = s.inverse_kinematics("b3", pose, Grasp(math.pi / 2, 0.0), context=context)
    assert out
    (goal,) = out
    motion = s.plan_motion(start, goal, context=context)
    assert motion
    (traj,) = motion
    assert traj.path[0] == start.arm and traj.path[-1] == goal.arm
    assert traj.seconds > 0 and traj.holding is None


def _solve(n: int, seed: int, planner: str) -> Any:
    from planner.api import RunConfig, solve

    return solve(
        RunConfig(scene=str(SCENES / f"panda-{n}.json"), seed=seed, planner=planner, budget_s=120)
    )


@pytest.mark.slow
def test_a_planned_trial_validates_and_a_tampered_one_does_not() -> None:
    result = _solve(2, 1000, "baseline")
    assert result.status == "solved"
    problem = _problem(2, 1000)
    from planner.domains.panda.validate import validate_plan

    check = validate_plan(result.actions, result.values, problem)
    assert check.ok, check.message
    assert check.execution_s == pytest.approx(result.execution_s)

    actions: list[GroundAction] = list(result.actions)
    places = [i for i, a in enumerate(actions) if a.name == "place" and a.args[2] == "tray"]
    # Both blocks put down on the same spot: the second overlaps the first.
    first, second = (actions[i] for i in places[:2])
    values = dict(result.values)
    values[second.args[1]] = replace(values[first.args[1]])
    bad = validate_plan(actions, values, problem)
    assert not bad.ok and f"step {places[1]}" in bad.message
    # A trajectory that skips to another configuration does not start where the arm is.
    move = next(i for i, a in enumerate(actions) if a.name == "move" and i > 0)
    traj = values[actions[move].args[2]]
    values = dict(result.values)
    values[actions[move].args[2]] = Trajectory(traj.path[1:] or traj.path, traj.seconds, None)
    assert not validate_plan(actions, values, problem).ok


def test_the_validator_sees_a_collision_along_a_trajectory() -> None:
    problem = _problem(2, 1000)
    geometry = geometry_of(problem)
    start: Conf = problem.values[START_CONF]
    # Leaning forward and down: the hand ends up under the table's top.
    with PandaWorld(geometry) as world:
        low = list(start.arm)
        low[1] += 1.7
        low[3] += 0.3
        world.set_arm(low)
        assert world.tool_pose()[0][2] < 0 and world.robot_collides()
    from planner.domains.panda.validate import validate_plan

    through = Conf(tuple(low), tuple(low))
    traj = Trajectory((start.arm, tuple(low)), 1.0, None)
    actions = [GroundAction("move", (START_CONF, "q1", "t1"))]
    check = validate_plan(actions, {"q1": through, "t1": traj}, problem)
    assert not check.ok and "collision" in check.message


def test_the_broad_phase_answers_as_every_exact_query_does() -> None:
    from planner.sim.collision import CollisionConfig

    problem = _problem(6, 1001)
    geometry = geometry_of(problem)
    poses = {b.name: problem.values[initial_pose_name(b.name)] for b in geometry.blocks}
    rng = random.Random(5)
    exact_config = CollisionConfig(broad_phase=False, pair_filter=False)
    with PandaWorld(geometry) as fast, PandaWorld(geometry, collision=exact_config) as exact:
        hits = 0
        for i in range(300):
            holding = i % 2 == 1
            arm = tuple(rng.uniform(lo, hi) for lo, hi in zip(LOWER, UPPER, strict=True))
            for world in (fast, exact):
                world.set_blocks({k: v for k, v in poses.items() if k != "b2" or not holding})
                world.hold("b2" if holding else None, Grasp(0.0, 0.0) if holding else None)
                world.set_arm(arm)
            for clearance in (0.0, 0.01, 0.05):
                answer = exact.robot_collides(clearance=clearance)
                assert fast.robot_collides(clearance=clearance) == answer
                assert fast.hand_collides(clearance=clearance) == exact.hand_collides(
                    clearance=clearance
                )
                hits += answer
        assert 0 < hits < 900  # both answers occur


@pytest.mark.slow
def test_blocks_go_onto_a_raised_shelf_as_into_the_tray() -> None:
    from planner.api import RunConfig, solve

    scene = str(SCENES / "panda-shelf-4.json")
    out = solve(RunConfig(scene=scene, seed=1001, planner="learned", budget_s=120))
    assert out.status == "solved" and out.check() == (True, "valid (replayed in pybullet)")
    places = [a for a in out.actions if a.name == "place" and a.args[2] == "shelf"]
    assert len(places) == 4
    for action in places:  # each block stands on the board, 20 cm up
        assert out.values[action.args[1]].z == pytest.approx(0.2 + 0.02)

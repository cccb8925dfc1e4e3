"""The two PDDLStream examples shipped under examples/ run as a user runs them from a fresh
clone: their files load only through PDDLStream's leniency (and --strict names what it refuses),
baseline and learned (with the shipped model) find plans the validators accept, and the
validators and scene readers refuse what is wrong with the step or field that is wrong."""

from __future__ import annotations

import dataclasses
import importlib
import json
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from planner.api import plan
from planner.domains import load_domain_folder
from planner.domains.registry import problem_for_scene
from planner.pddl import PDDLError, parse_domain
from planner.scene import SceneError

ROOT = Path(__file__).resolve().parents[2]
PICK_PLACE = ROOT / "examples" / "pick_place_2d"
BLOCKS = ROOT / "examples" / "blocks_streams"


def module(folder: Path, name: str) -> Any:
    loaded = load_domain_folder(folder)
    package = loaded.spec.problem_from_scene.__module__.rsplit(".", 1)[0]
    return importlib.import_module(f"{package}.{name}")


def validator(loaded: Any) -> Any:
    assert loaded.spec.validate is not None
    return loaded.spec.validate


@pytest.mark.parametrize("folder", [PICK_PLACE, BLOCKS], ids=["pick-place-2d", "blocks-streams"])
def test_examples_load_by_pddlstreams_leniency_and_ship_a_model(folder: Path) -> None:
    loaded = load_domain_folder(folder)
    inferred = {i.name for i in loaded.domain.inferred} | {i.name for i in loaded.streams.inferred}
    assert inferred  # written as PDDLStream's examples are: static facts declared by use
    assert loaded.spec.model is not None and loaded.spec.model.exists()
    with pytest.raises(
        PDDLError, match=r"domain\.pddl:\d+:\d+: .*(undeclared predicate|:predicates)"
    ):
        parse_domain((folder / "domain.pddl").read_text(), file="domain.pddl", strict=True)


@pytest.mark.parametrize("planner", ["baseline", "learned"])
def test_pick_place_2d_solves_with_a_valid_plan(planner: str) -> None:
    loaded = load_domain_folder(PICK_PLACE)
    result = plan(
        str(PICK_PLACE / "scenes" / "pickplace-2.json"),
        planner,
        domain=loaded,
        seed=1,
        budget_s=120,
    )
    assert result.status == "solved" and result.valid, result.message
    placed = [a for a in result.actions if a.name == "place"]
    assert {a.args[0] for a in placed} >= {"a", "b"}
    assert result.execution_s is not None and result.execution_s > 0


@pytest.mark.parametrize("planner", ["baseline", "learned"])
def test_a_block_in_the_way_is_moved_first(planner: str) -> None:
    """pickplace-blocked-3 (PDDLStream's blocked problem): B stands in the middle of the red
    region and leaves no room for A. The first skeleton places A beside B; its clearance test
    fails for every pose drawn, the search doubts it and asks for another skeleton, and the one
    it gets moves B out of the way first."""
    from planner.events import ListSink, SkeletonsAdded

    loaded = load_domain_folder(PICK_PLACE)
    sink = ListSink()
    result = plan(
        str(PICK_PLACE / "scenes" / "pickplace-blocked-3.json"),
        planner,
        domain=loaded,
        seed=1000,
        budget_s=300,
        sink=sink,
    )
    assert result.status == "solved" and result.valid, result.message
    picked = [a.args[0] for a in result.actions if a.name == "pick"]
    assert picked.index("b") < picked.index("a"), result.actions
    added = [e for e in sink.events if isinstance(e, SkeletonsAdded) and e.plans]
    assert added and any("cfree a" in line and "doubted" in line for line in added[0].learned)


def test_a_known_failure_is_not_asked_again_and_learned_goes_on_to_the_next_grasp() -> None:
    """pickplace-2 seed 1012: B's first two grasps never reach its start pose (the IK, a
    PDDLStream function, finds nothing and says it will not), and the list of grasps starts
    again at them under every new node. The search asks no failed function twice
    (TreeSearch.memo_exhausted: the failure comes back as a reused answer), and the learned
    search, predicting those known failures as failures (LearnedConfig.known_failures), goes on
    to the third grasp: with the part off it resampled A's placement and the same two grasps
    until its budget ran out (3,735 IK failures in 60 s)."""
    from planner.events import ListSink, StreamQueried

    loaded = load_domain_folder(PICK_PLACE)
    sink = ListSink()
    result = plan(
        str(PICK_PLACE / "scenes" / "pickplace-2.json"),
        "learned",
        domain=loaded,
        seed=1012,
        budget_s=300,
        sink=sink,
    )
    assert result.status == "solved" and result.valid, result.message
    asked = [e for e in sink.events if isinstance(e, StreamQueried)]
    failed = Counter(
        (e.stream, json.dumps(e.inputs)) for e in asked if not e.success and e.reused_from is None
    )
    ik = {k: n for k, n in failed.items() if k[0] == "inverse-kinematics"}
    assert ik and max(ik.values()) == 1, ik  # each failed once, then known
    known = [e for e in asked if not e.success and e.reused_from is not None]
    assert any(e.stream == "inverse-kinematics" for e in known)
    assert len(asked) < 1000  # 12,676 with known_failures off, to the budget


@pytest.mark.parametrize("planner", ["baseline", "learned"])
def test_blocks_streams_builds_the_tower(planner: str) -> None:
    loaded = load_domain_folder(BLOCKS)
    result = plan(
        str(BLOCKS / "scenes" / "tower-3.json"), planner, domain=loaded, seed=3, budget_s=120
    )
    assert result.status == "solved" and result.valid, result.message
    assert len(result.actions) >= 3  # the scene's min_moves


def test_pick_place_2d_validator_names_the_step_that_breaks() -> None:
    loaded = load_domain_folder(PICK_PLACE)
    result = plan(
        str(PICK_PLACE / "scenes" / "pickplace-2.json"),
        "baseline",
        domain=loaded,
        seed=1,
        budget_s=120,
    )
    assert result.valid
    actions = list(result.actions)
    i = next(i for i, a in enumerate(actions) if a.name == "move")
    dropped = actions[:i] + actions[i + 1 :]  # the gripper never gets where it picks
    check = validator(loaded)(dropped, result.values, result.problem)
    assert not check.ok and f"step {i + 1}" in check.message
    short = [a for a in actions if a.name != "place" or a is not actions[-1]][:-1]
    assert not validator(loaded)(short, result.values, result.problem).ok


def test_blocks_validator_and_streams_refuse_what_the_arm_cannot_do() -> None:
    loaded = load_domain_folder(BLOCKS)
    prims = module(BLOCKS, "primitives")
    result = plan(str(BLOCKS / "scenes" / "tower-4.json"), "baseline", domain=loaded, seed=1)
    assert result.valid, result.message
    world = module(BLOCKS, "scene").world_of(result.problem)
    actions, values = list(result.actions), result.values
    # a step out of order: its block is not where the step takes it from, or not clear
    check = validator(loaded)(actions[1:], values, result.problem)
    assert not check.ok and check.message.startswith("step ")
    # a carry that ends a little off the destination's top
    first = values[actions[0].args[3]]
    shifted = dataclasses.replace(first, end=(first.end[0] + 0.5, first.end[1]))
    check = validator(loaded)(actions, {**values, actions[0].args[3]: shifted}, result.problem)
    assert not check.ok and "step 1" in check.message and "does not go" in check.message
    # the streams' rules: nothing on the fragile block, nothing wider on a narrower one, and an
    # arm too weak for the farthest slot does not carry there
    stackable = prims.get_stackable_test(world)
    assert world.blocks["D"].fragile and not stackable("E", "D") and stackable("E", "C")
    assert not stackable("A", "E")
    weak = dataclasses.replace(world, moment=1.0)
    far = "s4"  # 5 from the base
    carry = prims.get_carry_fn(world)
    assert carry("A", "s9", far, [("on", "A", "s1")]) is None  # A is not on s9
    assert carry("A", "s1", far, [("on", "A", "s1")]) is not None
    assert prims.get_carry_fn(weak)("A", "s1", far, [("on", "A", "s1")]) is None


def test_blocks_starts_are_drawn_solvable_within_the_scene_bounds() -> None:
    loaded = load_domain_folder(BLOCKS)
    prims = module(BLOCKS, "primitives")
    scene = module(BLOCKS, "scene")
    for seed in range(5):
        _, problem = problem_for_scene(
            str(BLOCKS / "scenes" / "tower-6.json"), seed=seed, domain=loaded
        )
        world = scene.world_of(problem)
        on = {
            problem.values.get(a.args[0], a.args[0]): problem.values.get(a.args[1], a.args[1])
            for a in problem.init
            if a.predicate == "on"
        }
        goal = [
            (problem.values.get(g.atom.args[0]), problem.values.get(g.atom.args[1], g.atom.args[1]))
            for g in problem.goal
        ]
        assert 4 <= prims.fewest_moves(world, on, goal) <= 5


def test_scene_errors_name_the_file_and_the_field(tmp_path: Path) -> None:
    loaded = load_domain_folder(BLOCKS)
    data = json.loads((BLOCKS / "scenes" / "tower-3.json").read_text())
    data["domain"] = str(BLOCKS)
    cases: list[tuple[dict[str, Any], str]] = [
        ({**data, "min_moves": 9, "max_moves": 3}, "max_moves"),
        ({**data, "min_moves": 12, "max_moves": 12}, "blocks"),
        ({**data, "goal": [["On", "A", "nowhere"]]}, "goal[0]"),
        ({**data, "blocks": [{**data["blocks"][0], "fragile": "yes"}]}, "blocks[0].fragile"),
        ({**data, "arm": {**data["arm"], "moment": -1}}, "arm.moment"),
    ]
    for i, (bad, field) in enumerate(cases):
        path = tmp_path / f"bad{i}.json"
        path.write_text(json.dumps(bad))
        with pytest.raises(
            SceneError, match=rf"bad{i}\.json: {field.replace('[', '.').replace(']', '.')}"
        ):
            plan(str(path), "baseline", domain=loaded, seed=0, budget_s=10)
    pick = json.loads((PICK_PLACE / "scenes" / "pickplace-2.json").read_text())
    pick["domain"] = str(PICK_PLACE)
    pick["blocks"][0]["region"] = "blue"
    path = tmp_path / "pick.json"
    path.write_text(json.dumps(pick))
    with pytest.raises(SceneError, match=r"pick\.json: blocks.0..region: unknown region 'blue'"):
        plan(str(path), "baseline", domain=load_domain_folder(PICK_PLACE), seed=0, budget_s=10)

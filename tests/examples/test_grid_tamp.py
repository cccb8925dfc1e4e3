"""The third PDDLStream example, the grid TAMP (examples/grid_tamp), as a PDDLStream user's folder
runs from a fresh clone with no validator of its own: its language (a rule, a stream with no
inputs, a constant, an ``or`` goal built in Python, a stream-map helper the stream file never
declares) loads and plans with both planners; its cells are numpy arrays and its paths plain
lists, and a plan file gives them back as such, so a validator that reuses the primitives runs
on it; the execution seconds come from the domain's ``execution_s``, and without it the plan
says why they are 0."""

from __future__ import annotations

import dataclasses
import importlib
import itertools
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planner.api import plan
from planner.cli import main
from planner.domains import LoadedDomain, PlanCheck, load_domain_folder
from planner.plans import EXECUTION_UNKNOWN, read_plan, validate
from planner.scene import SceneError

ROOT = Path(__file__).resolve().parents[2]
GRID = ROOT / "examples" / "grid_tamp"


@pytest.fixture(scope="module")
def grid() -> LoadedDomain:
    return load_domain_folder(GRID)


def primitives(loaded: LoadedDomain) -> Any:
    package = loaded.spec.problem_from_scene.__module__.rsplit(".", 1)[0]
    return importlib.import_module(f"{package}.primitives")


def test_the_language_loads_as_pddlstream_writes_it(grid: LoadedDomain) -> None:
    kinds = {s.name: s.kind for s in grid.streams.streams}
    assert "rule" in kinds.values()
    sample = grid.streams.stream("sample-pose")
    assert sample.inputs == () and len(sample.outputs) == 1  # a stream with no inputs
    assert [c.name for c in grid.domain.constants] == ["home"]
    problem = grid.problem_from_scene(_scene("grid-2"), seed=0)
    assert isinstance(problem.values["home"], np.ndarray)  # the constant's value, as given
    assert problem.goal_conditions  # the or goal, read from Python
    runtime = grid.runtime(problem, seed=0)
    assert "collision" not in runtime.names  # PDDLStream's helper, left out (with a warning)


def _scene(name: str) -> Any:
    from planner.scene import load_scene

    return load_scene(str(GRID / "scenes" / f"{name}.json"))


@pytest.mark.parametrize("planner", ["baseline", "learned"])
def test_both_planners_plan_it_and_the_replay_validates_it(
    grid: LoadedDomain, planner: str
) -> None:
    result = plan(str(GRID / "scenes" / "grid-3.json"), planner, domain=grid, seed=2, budget_s=60)
    assert result.status == "solved" and result.valid, result.message
    assert "replayed fact by fact" in result.message and "tests asked again" in result.message
    values = {**result.problem.values, **result.values}
    places = [a for a in result.actions if a.name == "place"]
    assert all(isinstance(values[a.args[1]], np.ndarray) for a in places)
    a_at = [values[a.args[1]].tolist() for a in places if a.args[0] == "a"][-1]
    assert a_at == [4, 2]  # t1: t2, the or's other side, is out of the arm's reach
    paths = [values[a.args[1]] for a in result.actions if a.name == "move"]
    assert paths and all(isinstance(p, list) for p in paths)
    world = grid.spec.problem_from_scene.__globals__["world_of"](result.problem)
    expected = sum((len(p) - 1) * world.seconds_per_cell for p in paths)
    assert result.execution_s == pytest.approx(expected) and expected > 0


def test_a_plan_file_gives_back_numpy_cells_and_list_paths(
    grid: LoadedDomain, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "plan.json"
    scene = str(GRID / "scenes" / "grid-2.json")
    args = ["plan", "--scene", scene, "--planner", "baseline", "--seed", "1", "--no-record"]
    assert main([*args, "--out", str(out)]) == 0, capsys.readouterr().out
    assert main(["validate", str(out)]) == 0
    said = capsys.readouterr().out
    assert "valid (replayed fact by fact" in said and " s)" in said  # with its seconds
    file = read_plan(out)
    values = file.decoded_values(grid)
    cells = [values[a.args[1]] for a in file.actions if a.name in ("pick", "place")]
    assert cells and all(isinstance(c, np.ndarray) and c.dtype.kind == "i" for c in cells)
    paths = [values[a.args[1]] for a in file.actions if a.name == "move"]
    assert all(isinstance(p, list) and isinstance(p[0], np.ndarray) for p in paths)
    # A validator of the user's, reusing the primitives: numpy arithmetic on the values.
    prims = primitives(grid)
    world_of = grid.spec.problem_from_scene.__globals__["world_of"]

    def reusing(actions: Any, bound: Any, problem: Any) -> PlanCheck:
        world = world_of(problem)
        every = {**problem.values, **bound}
        for act in actions:
            if act.name == "move":
                path = every[act.args[1]]
                steps = [prims.distance_fn(a, b) for a, b in itertools.pairwise(path)]
                if any(s != 1 for s in steps):
                    return PlanCheck(False, f"{act}: a path jumps")
            elif prims.get_ik_fn(world)(every[act.args[1]]) is None:
                return PlanCheck(False, f"{act}: out of reach")
        return PlanCheck(True, "valid (the user's)")

    mine = dataclasses.replace(grid, spec=dataclasses.replace(grid.spec, validate=reusing))
    problem = mine.problem_from_scene(_scene("grid-2"), seed=file.seed)
    every = {**{o.name: o.name for o in problem.objects}, **problem.values, **values}
    check = validate(mine, problem, file.actions, every, streams=file.streams)
    assert check.ok, check.message


def test_without_execution_seconds_the_plan_says_why_they_are_zero(grid: LoadedDomain) -> None:
    untimed = dataclasses.replace(grid, spec=dataclasses.replace(grid.spec, execution_s=None))
    result = plan(
        str(GRID / "scenes" / "grid-2.json"), "baseline", domain=untimed, seed=1, budget_s=60
    )
    assert result.valid and result.execution_s == 0.0
    assert result.message.endswith(EXECUTION_UNKNOWN)
    assert "DomainSpec.execution_s" in result.message
    timed = plan(str(GRID / "scenes" / "grid-2.json"), "baseline", domain=grid, seed=1)
    assert timed.execution_s is not None and timed.execution_s > 0
    assert EXECUTION_UNKNOWN not in timed.message


def test_learned_with_priors_only_searches_as_the_baseline(grid: LoadedDomain) -> None:
    """On a domain it has never seen (no model, no recorded queries) no estimate is trusted
    (LearnedConfig.trust), so the learned search makes the baseline's queries; with the rule
    off it trusts averages and searches otherwise (the rule is what makes them the same)."""

    def queries(planner: str, **kw: Any) -> list[tuple[str, bool]]:
        result = plan(
            str(GRID / "scenes" / "grid-4.json"), planner, domain=grid, seed=3, budget_s=60, **kw
        )
        assert result.status == "solved", result.message
        return [(q.stream, q.success) for q in result.result.queries]

    baseline = queries("baseline")
    assert queries("learned", model="priors") == baseline
    assert queries("learned:trust=off", model="priors") != baseline


def test_scene_errors_name_the_file_and_the_field(grid: LoadedDomain, tmp_path: Path) -> None:
    data = json.loads((GRID / "scenes" / "grid-2.json").read_text())
    data["domain"] = str(GRID)
    cases: list[tuple[dict[str, Any], str]] = [
        ({**data, "targets": {**data["targets"], "t1": [40, 2]}}, r"targets\.t1: cell \[40, 2\]"),
        ({**data, "goal": ["and", ["AtPose", "A", "t9"]]}, r"goal\[1\]\[2\]: unknown name 't9'"),
        ({**data, "arm": {**data["arm"], "reach": 0}}, r"arm\.reach: expected a positive"),
        ({**data, "blocks": [{"name": "A", "at": "t7"}]}, r"blocks\[0\]\.at: unknown target"),
    ]
    for i, (bad, says) in enumerate(cases):
        path = tmp_path / f"bad{i}.json"
        path.write_text(json.dumps(bad))
        with pytest.raises(SceneError, match=rf"bad{i}\.json: {says}"):
            plan(str(path), "baseline", domain=grid, seed=0, budget_s=10)

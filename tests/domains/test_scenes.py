"""Scenes load into problems; a malformed scene names the field that is wrong."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from planner.domains import LoadedDomain, problem_for_scene
from planner.pddl import Atom
from planner.scene import SceneError, known_scenes, load_scene

KITCHEN_BLOCKS = (1, 2, 3, 4, 5, 6, 7, 8, 10, 12, 16, 20, 24)  # the shipped kitchens' block counts


def test_all_kitchens_ship_with_their_blocks() -> None:
    names = known_scenes()
    assert [n for n in names if n.startswith("kitchen")] == [f"kitchen-{i}" for i in KITCHEN_BLOCKS]
    for n in KITCHEN_BLOCKS:
        _, problem = problem_for_scene(f"kitchen-{n}")
        blocks = sorted(a.args[0] for a in problem.init if a.predicate == "block")
        assert len(blocks) == n
        assert {lit.atom for lit in problem.goal} == {Atom("cooked", (b,)) for b in blocks}
        assert Atom("on", ("b1", "table")) in problem.init


def test_unknown_scene_lists_the_known_ones() -> None:
    with pytest.raises(SceneError, match=r"unknown scene 'kitchen-99'.*kitchen-1, kitchen-2"):
        load_scene("kitchen-99")


def write(tmp_path: Path, data: object) -> str:
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    return str(path)


def base() -> dict[str, object]:
    return json.loads(Path(load_scene("kitchen-2").source).read_text())


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.pop("blocks"), "blocks: missing field"),
        (lambda d: d.update(blocks=[]), "blocks: expected at least one block"),
        (lambda d: d["platforms"][1].update(kind="oven"), r"platforms\[1\].kind: expected one of"),
        (lambda d: d["platforms"].pop(2), "needs a platform of kind 'stove'"),
        (lambda d: d["blocks"][1].update(name="b1"), r"blocks\[1\].name: name 'b1'"),
        (lambda d: d["blocks"][0].update(name="opt-b"), "reserved prefix"),
        (lambda d: d["blocks"][0].update(on="shelf"), "unknown platform 'shelf'"),
        (lambda d: d["goal"].append(["cooked", "b9"]), r"goal\[2\]: unknown object 'b9'"),
        (lambda d: d["goal"].append(["fried", "b1"]), "unknown predicate 'fried'"),
        (lambda d: d.update(name=3), "name: expected a string"),
    ],
)
def test_malformed_kitchen_scene_names_the_field(
    tmp_path: Path, kitchen: LoadedDomain, edit: object, message: str
) -> None:
    data = base()
    edit(data)  # type: ignore[operator]
    with pytest.raises(SceneError, match=message):
        scene = load_scene(write(tmp_path, data))
        kitchen.problem_from_scene(scene)


def test_invalid_json_gives_line_and_column(tmp_path: Path) -> None:
    path = tmp_path / "broken.json"
    path.write_text('{"name": "x",\n  "domain": }')
    with pytest.raises(SceneError, match=r"broken.json:2:\d+: invalid JSON"):
        load_scene(str(path))


def test_line_scene_checks_geometry(tmp_path: Path, line: LoadedDomain) -> None:
    data = json.loads(Path(load_scene("line-2").source).read_text())
    data["blocks"][0]["x"] = 0.0  # between the regions
    with pytest.raises(SceneError, match=r"blocks\[0\].x: block does not lie inside start"):
        line.problem_from_scene(load_scene(write(tmp_path, data)))


def test_scene_for_unknown_domain_names_the_field(tmp_path: Path) -> None:
    data = base()
    data["domain"] = "blocksworld"
    with pytest.raises(SceneError, match=r"domain: unknown domain 'blocksworld' .known: kitchen"):
        problem_for_scene(write(tmp_path, data))

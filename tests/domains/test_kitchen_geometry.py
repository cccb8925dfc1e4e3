"""Kitchen scene geometry: impossible scenes are refused by field; seeds give fixed poses."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from planner.domains.kitchen.geometry import geometry_from_scene
from planner.domains.kitchen.samplers import SamplerConfig, _slots
from planner.scene import SceneError, load_scene


def scene_with(tmp_path: Path, edit: object) -> object:
    data = json.loads(Path(load_scene("kitchen-4").source).read_text())
    edit(data)  # type: ignore[operator]
    path = tmp_path / "k.json"
    path.write_text(json.dumps(data))
    return load_scene(str(path))


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d["blocks"][2].update(size=0.9), r"blocks\[2\].size: a 0.9 m block fits on no"),
        (
            lambda d: d["platforms"][2].update(center=[1.0, 0.3]),
            r"platforms\[2\].center: stove overlaps table",
        ),
        (lambda d: d["platforms"][1].update(size=[0.3, -1, 0.7]), r"platforms\[1\].size"),
        (lambda d: d["platforms"][0].update(color=[2, 0, 0, 1]), r"platforms\[0\].color"),
        (lambda d: d["robot"].update(base=[1.1, 0.0, 0.0]), "robot.base: the robot starts inside"),
        (lambda d: d["robot"].update(torso=0.9), r"robot.torso: torso lift must lie in"),
        (lambda d: d["spawn"].update(min_gap=0.5), "blocks: no room for block"),
    ],
)
def test_impossible_scenes_name_the_field(tmp_path: Path, edit: object, message: str) -> None:
    scene = scene_with(tmp_path, edit)
    with pytest.raises(SceneError, match=message):
        geometry_from_scene(scene)  # type: ignore[arg-type]


def test_seeded_initial_poses_lie_on_the_table_apart() -> None:
    geometry = geometry_from_scene(load_scene("kitchen-8"))
    table = geometry.platform("table")
    xmin, xmax, ymin, ymax = table.footprint()
    poses = geometry.initial_poses(seed=3)
    assert poses == geometry.initial_poses(seed=3)
    assert poses != geometry.initial_poses(seed=4)
    for name, pose in poses.items():
        assert xmin < pose.x < xmax and ymin < pose.y < ymax
        assert pose.z == pytest.approx(table.top + geometry.block(name).size / 2)
    items = list(poses.values())
    for i, a in enumerate(items):
        for b in items[i + 1 :]:
            assert math.hypot(a.x - b.x, a.y - b.y) > 0.07  # no two blocks overlap


def test_stove_is_crowded_by_four_blocks() -> None:
    geometry = geometry_from_scene(load_scene("kitchen-4"))
    stove = geometry.platform("stove")
    block = geometry.blocks[0].size
    # The paper's Fig. 1C: four 7 cm blocks only just fit on a ~22 cm stove.
    assert stove.size[0] * stove.size[1] < 12 * block * block


PACKED_YAW = 0.1  # radians a packed placement turns off square (samplers.sample_placement)


@pytest.mark.parametrize(
    ("scene", "blocks"),
    [
        ("kitchen-10", 10),
        ("kitchen-12", 12),
        ("kitchen-16", 16),
        ("kitchen-20", 20),
        ("kitchen-24", 24),
    ],
)
def test_long_kitchens_fit_their_blocks_on_the_stove_and_the_table(scene: str, blocks: int) -> None:
    """kitchen-10 to -24 have the other kitchens' sink (and up to -12 their table; from -16 a
    longer one, as crowded as kitchen-12's) and a stove with a grid slot for every block: the
    placement sampler's packed tries (square to the stove, at most ``PACKED_YAW`` off, 1 cm
    gap, 1 cm jitter) have as many slots as there are blocks, however they turn. Their blocks'
    seeded start poses draw apart on the table."""
    geometry = geometry_from_scene(load_scene(scene))
    kitchen8 = geometry_from_scene(load_scene("kitchen-8"))
    assert len(geometry.blocks) == blocks
    assert len({b.color for b in geometry.blocks}) == blocks
    assert geometry.platform("sink") == kitchen8.platform("sink")
    if blocks <= 12:
        assert geometry.platform("table") == kitchen8.platform("table")
    assert geometry.robot == kitchen8.robot and geometry.spawn == kitchen8.spawn
    xmin, xmax, ymin, ymax = geometry.platform("stove").footprint()
    config = SamplerConfig()
    size = geometry.blocks[0].size
    for yaw in (0.0, PACKED_YAW):
        half = size / 2 * (math.cos(yaw) + math.sin(yaw))
        pitch = 2 * half + config.placement_gap + 2 * config.corner_jitter
        slots = len(_slots(xmin + half, xmax - half, pitch)) * len(
            _slots(ymin + half, ymax - half, pitch)
        )
        assert slots >= blocks, f"{scene}: {slots} stove slots at yaw {yaw}"
    table = geometry.platform("table")
    txmin, txmax, tymin, tymax = table.footprint()
    for seed in range(1000, 1010):
        poses = list(geometry.initial_poses(seed).values())
        assert len(poses) == blocks
        assert all(txmin < p.x < txmax and tymin < p.y < tymax for p in poses)
        for i, a in enumerate(poses):
            for b in poses[i + 1 :]:
                assert math.hypot(a.x - b.x, a.y - b.y) > size * math.sqrt(2)

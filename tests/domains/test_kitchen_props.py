"""The kitchen as drawn (planner/domains/kitchen/props.py): every fixture over exactly the box
the planner checks, its front towards the robot, the stove's burners by its size, the blocks
as their cubes in their colours, a floor under everything, and the same mesh files each time."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest
import trimesh

from planner.domains import problem_for_scene
from planner.domains.kitchen.geometry import KitchenGeometry
from planner.domains.kitchen.problem import GEOMETRY_KEY
from planner.sim.meshes import CACHE_ENV
from planner.view import Body, Mesh, Meshes, SceneView

TOP_TOL = 0.0025  # m: burners, basin and drain lie flat on the top, at most this proud of it


def _scene(name: str, seed: int = 0) -> tuple[SceneView, KitchenGeometry]:
    loaded, problem = problem_for_scene(name, seed=seed)
    assert loaded.spec.view is not None
    geometry = problem.values[GEOMETRY_KEY]
    assert isinstance(geometry, KitchenGeometry)
    return loaded.spec.view.scene(problem), geometry


def _parts(body: Body) -> tuple[Mesh, ...]:
    assert isinstance(body.shape, Meshes | Mesh)
    return body.shape.parts if isinstance(body.shape, Meshes) else (body.shape,)


def _placed(body: Body, part: Mesh) -> trimesh.Trimesh:
    mesh = trimesh.load(str(part.path), force="mesh")
    x, y, z, w = body.quat
    transform = trimesh.transformations.quaternion_matrix((w, x, y, z))  # type: ignore[no-untyped-call]
    transform[:3, 3] = body.position
    return mesh.apply_transform(transform)


@pytest.mark.parametrize("scene", ["kitchen-1", "kitchen-5", "kitchen-8"])
def test_each_fixture_is_drawn_over_exactly_its_box(scene: str) -> None:
    view, geometry = _scene(scene)
    for plat in geometry.platforms:
        body = view.body(f"platform-{plat.name}")
        assert body.label == plat.name
        bounds = trimesh.util.concatenate([_placed(body, p) for p in _parts(body)]).bounds
        xmin, xmax, ymin, ymax = plat.footprint()
        assert bounds[0][:2] == pytest.approx((xmin, ymin), abs=1e-4), plat.name
        assert bounds[1][:2] == pytest.approx((xmax, ymax), abs=1e-4), plat.name
        assert bounds[0][2] == pytest.approx(0.0, abs=1e-4)
        assert plat.top <= bounds[1][2] <= plat.top + TOP_TOL, plat.name


def test_the_fronts_face_the_robot_and_the_stove_has_a_burner_per_15_cm() -> None:
    for scene, burners in (("kitchen-1", 1), ("kitchen-5", 2), ("kitchen-8", 4)):
        view, geometry = _scene(scene)
        robot = np.array(geometry.robot.base[:2])
        for plat in geometry.platforms:
            body = view.body(f"platform-{plat.name}")
            parts = {"-".join(p.path.name.split("-")[1:3]): p for p in _parts(body)}
            centre = np.array(plat.center)
            if plat.kind == "table":
                continue
            # The door (the sink) or the knobs and handle (the stove) are on the robot's side.
            front = parts["sink-door"] if plat.kind == "sink" else parts["stove-steel"]
            offset = _placed(body, front).centroid[:2] - centre
            toward = robot - centre
            assert offset @ toward / (np.linalg.norm(offset) * np.linalg.norm(toward)) > 0.9
            if plat.kind == "stove":
                coils = _placed(body, parts["stove-burners"])
                coils.merge_vertices(merge_norm=True)  # rejoin what sharp edges split
                coils = coils.split(only_watertight=False)
                assert len(coils) == 2 * burners, scene  # a ring and a centre each


def test_blocks_are_their_cubes_in_their_colours() -> None:
    view, geometry = _scene("kitchen-8", seed=3)
    files = set()
    for block in geometry.blocks:
        body = view.body(block.name)
        assert isinstance(body.shape, Mesh)
        rgb = tuple(int(c * 255) for c in block.color[:3])
        assert body.shape.color == rgb
        mesh = trimesh.load(str(body.shape.path), force="mesh")
        assert mesh.extents == pytest.approx((block.size,) * 3, abs=1e-5)
        assert mesh.volume == pytest.approx(block.size**3, rel=0.05)  # edges rounded, a little
        files.add(body.shape.path)
    assert len(files) == 1  # one file for every block of a size


def test_the_floor_is_tiled_under_the_fixtures_and_the_robot() -> None:
    view, geometry = _scene("kitchen-8")
    assert view.floor is not None
    assert view.floor.name not in {b.name for b in view.bodies}  # not a body of the scene
    light, dark = (trimesh.load(str(p.path), force="mesh") for p in _parts(view.floor))
    both = trimesh.util.concatenate([light, dark])
    assert np.all(both.vertices[:, 2] == 0.0)
    assert len(light.faces) == len(dark.faces) == pytest.approx(len(both.faces) / 2, abs=2)
    assert both.area == pytest.approx(np.prod(both.extents[:2]))  # no gaps, no overlaps
    for plat in geometry.platforms:
        xmin, xmax, ymin, ymax = plat.footprint()
        assert both.bounds[0][0] <= xmin - 1.5 and both.bounds[1][0] >= xmax + 1.5
        assert both.bounds[0][1] <= ymin - 1.5 and both.bounds[1][1] >= ymax + 1.5
    assert all(math.isclose(v / 0.5, round(v / 0.5)) for v in both.bounds.ravel()[:2])


def test_the_same_scene_is_drawn_from_the_same_files() -> None:
    first, _ = _scene("kitchen-4", seed=1)
    files = sorted({p.path for b in (*first.bodies, first.floor) if b for p in _bodies(b)})
    cache = Path(os.environ[CACHE_ENV])
    assert all(f.parent == cache for f in files)
    stamps = {f: f.stat().st_mtime_ns for f in files}
    again, _ = _scene("kitchen-4", seed=2)  # other block poses, the same fixtures
    assert sorted({p.path for b in (*again.bodies, again.floor) if b for p in _bodies(b)}) == files
    assert {f: f.stat().st_mtime_ns for f in files} == stamps  # none written twice


def _bodies(body: Body) -> tuple[Mesh, ...]:
    return _parts(body) if isinstance(body.shape, Mesh | Meshes) else ()

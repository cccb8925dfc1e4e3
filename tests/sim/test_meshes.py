"""Mesh shapes and files (planner/sim/meshes.py): closed shapes of the asked size, OBJ text that
reads back the same in trimesh and pybullet, shaded smooth where smooth and sharp where sharp,
the same bytes every time, and a cache that writes each mesh once."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet as p
import pytest
import trimesh

from planner.sim import meshes as m

SHAPES = {
    "rounded box": (m.rounded_box((0.4, 0.3, 0.2), 0.03, at=(1.0, 0.0, 0.1)), (0.8, 1.2, 0.0)),
    "box": (m.rounded_box((0.4, 0.3, 0.2), 0.0), (-0.2, 0.2, -0.1)),
    "cylinder": (m.cylinder(0.05, 0.2, axis="x", bevel=0.01), (-0.1, 0.1, -0.05)),
    "capsule": (m.capsule(0.09, 0.3, at=(0.0, 0.0, -0.08)), (-0.09, 0.09, -0.23)),
    "lathe": (
        m.lathe([(0.0, 0.0), (0.05, 0.0), (0.04, 0.3), (0.0, 0.3)], axis="x"),
        (0, 0.3, -0.05),
    ),
    "ring": (m.ring(0.02, 0.05, 0.004, at=(0.0, 0.0, 0.7)), (-0.05, 0.05, 0.698)),
    "prism": (m.prism(m.rounded_rectangle((0.6, 0.4), 0.05), 0.1, 0.3), (-0.3, 0.3, 0.1)),
}


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_shapes_are_closed_and_where_they_were_asked(name: str) -> None:
    mesh, (lo_x, hi_x, lo_z) = SHAPES[name]
    assert mesh.is_watertight and mesh.is_winding_consistent, name
    assert mesh.volume > 0, f"{name} faces inwards"
    assert mesh.bounds[0][0] == pytest.approx(lo_x, abs=1e-6)
    assert mesh.bounds[1][0] == pytest.approx(hi_x, abs=1e-6)
    assert mesh.bounds[0][2] == pytest.approx(lo_z, abs=1e-6)


def test_a_rounded_box_keeps_its_size_and_loses_its_corners() -> None:
    sharp = m.rounded_box((0.4, 0.3, 0.2), 0.0)
    round_ = m.rounded_box((0.4, 0.3, 0.2), 0.03)
    assert np.allclose(round_.bounds, sharp.bounds)
    # A rounded corner is cut away: (r - r/sqrt 2)^2 * 4 edges' worth of volume, roughly.
    assert 0.9 * sharp.volume < round_.volume < 0.99 * sharp.volume
    corner = np.array([0.2, 0.15, 0.1])
    assert np.min(np.linalg.norm(round_.vertices - corner, axis=1)) > 0.01


def test_bad_sizes_are_refused() -> None:
    with pytest.raises(ValueError, match="positive"):
        m.rounded_box((0.4, -0.3, 0.2), 0.03)
    with pytest.raises(ValueError, match="positive"):
        m.ring(0.05, 0.02, 0.01)
    with pytest.raises(ValueError, match="radius 0"):
        m.lathe([(0.05, 0.0), (0.05, 0.3)])


def _write(tmp_path: Path, mesh: trimesh.Trimesh, name: str = "x.obj") -> Path:
    path = tmp_path / name
    path.write_text(m.obj_text(mesh, comment="a test"), encoding="utf-8")
    return path


def test_obj_text_reads_back_in_trimesh_and_pybullet(tmp_path: Path) -> None:
    mesh = m.combine([SHAPES["rounded box"][0], SHAPES["cylinder"][0]])
    path = _write(tmp_path, mesh)
    back = trimesh.load(str(path), force="mesh")
    assert len(back.faces) == len(mesh.faces)
    assert np.allclose(back.bounds, mesh.bounds, atol=1e-5)
    assert back.volume == pytest.approx(mesh.volume, rel=1e-3)
    client = p.connect(p.DIRECT)
    try:
        assert p.createVisualShape(p.GEOM_MESH, fileName=str(path), physicsClientId=client) >= 0
    finally:
        p.disconnect(physicsClientId=client)


def test_sharp_edges_get_a_normal_per_side_and_smooth_ones_share_one(tmp_path: Path) -> None:
    cube = trimesh.load(str(_write(tmp_path, m.rounded_box((1.0, 1.0, 1.0), 0.0))), force="mesh")
    assert len(cube.vertices) == 24  # each corner once per face that meets there
    face_normal = {tuple(np.round(n, 6)) for n in cube.vertex_normals}
    assert len(face_normal) == 6  # every vertex's normal is its face's
    cylinder = m.cylinder(0.5, 1.0, sections=16)
    back = trimesh.load(str(_write(tmp_path, cylinder, "c.obj")), force="mesh")
    side = back.vertices[:, 2] > -0.49
    side &= back.vertices[:, 2] < 0.49
    # The side's normals point straight out (smooth round the side); the caps' along the axis.
    rim = np.abs(back.vertex_normals[:, 2]) < 1e-3
    caps = np.abs(np.abs(back.vertex_normals[:, 2]) - 1) < 1e-3
    assert np.all(rim | caps)
    assert rim.sum() == 32 and caps.sum() >= 32  # 16 round each rim, the rims' own cap copies


def test_obj_text_is_the_same_bytes_every_time() -> None:
    a = m.obj_text(m.rounded_box((0.4, 0.3, 0.2), 0.03), comment="x")
    b = m.obj_text(m.rounded_box((0.4, 0.3, 0.2), 0.03), comment="x")
    assert a == b
    numbers = [w for line in a.splitlines() if line[:2] in ("v ", "vn") for w in line.split()[1:]]
    assert all(len(w.split(".")[1]) in (4, 5) for w in numbers)  # fixed decimals
    assert "-0.00000" not in a and "-0.0000 " not in a


def test_cached_obj_writes_a_mesh_once_under_its_content(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(m.CACHE_ENV, str(tmp_path / "cache"))
    box = m.rounded_box((0.4, 0.3, 0.2), 0.03)
    first = m.cached_obj(box, "thing")
    assert first.parent == tmp_path / "cache" and first.name.startswith("thing-")
    stamp = first.stat().st_mtime_ns
    assert m.cached_obj(m.rounded_box((0.4, 0.3, 0.2), 0.03), "thing") == first
    assert first.stat().st_mtime_ns == stamp  # not written again
    other = m.cached_obj(m.rounded_box((0.4, 0.3, 0.25), 0.03), "thing")
    assert other != first
    assert sorted(x.name for x in (tmp_path / "cache").iterdir()) == sorted(
        [first.name, other.name]
    )
    assert m.triangles(first) == len(box.faces)

"""Rendering a domain's scene description to a PNG (the kitchen's): a valid image of the asked
size that shows every body."""

from __future__ import annotations

import struct
import zlib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from planner.cli import main
from planner.domains import problem_for_scene
from planner.scene import SceneError
from planner.sim.render import BACKGROUND, RenderInfo
from planner.sim.render import render_scene as render_view


def render_scene(
    scene: str, *, seed: int, out: Path, width: int = 960, height: int = 720
) -> RenderInfo:
    loaded, problem = problem_for_scene(scene, seed=seed)
    assert loaded.spec.view is not None
    return render_view(loaded.spec.view.scene(problem), out=out, width=width, height=height)


WIDTH, HEIGHT = 480, 360
MIN_PIXELS = 30  # "clearly visible" for a 7 cm block at this size (it covers ~190 pixels)


def read_png(path: Path) -> tuple[int, int, bytes]:
    """Width, height and raw scanlines of an 8-bit RGB PNG; checks signature and every CRC."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG signature"
    pos, chunks = 8, []
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind, body = data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length : pos + 12 + length])
        assert crc == zlib.crc32(kind + body) & 0xFFFFFFFF, f"bad CRC in {kind!r}"
        chunks.append((kind, body))
        pos += 12 + length
    assert chunks[0][0] == b"IHDR" and chunks[-1][0] == b"IEND"
    width, height, depth, color_type, _, _, _ = struct.unpack(">IIBBBBB", chunks[0][1])
    assert (depth, color_type) == (8, 2), "expected 8-bit RGB"
    raw = zlib.decompress(b"".join(body for kind, body in chunks if kind == b"IDAT"))
    assert len(raw) == height * (1 + 3 * width)
    return width, height, raw


@pytest.fixture(scope="module")
def seed3(tmp_path_factory: pytest.TempPathFactory) -> RenderInfo:
    out = tmp_path_factory.mktemp("render") / "kitchen-4-seed3.png"
    return render_scene("kitchen-4", seed=3, out=out, width=WIDTH, height=HEIGHT)


@pytest.mark.slow
def test_render_writes_a_png_of_the_asked_size(seed3: RenderInfo) -> None:
    width, height, _ = read_png(seed3.path)
    assert (width, height) == (WIDTH, HEIGHT) == (seed3.width, seed3.height)


@pytest.mark.slow
def test_robot_fixtures_and_every_block_are_visible(seed3: RenderInfo) -> None:
    expected = {"pr2", "platform-table", "platform-sink", "platform-stove", "b1", "b2", "b3", "b4"}
    assert set(seed3.pixels) == expected
    small = {name: n for name, n in seed3.pixels.items() if n < MIN_PIXELS}
    assert not small, f"barely visible: {small}"
    assert seed3.hidden(MIN_PIXELS) == ()


@pytest.mark.slow
def test_the_kitchen_stands_on_its_tiled_floor(seed3: RenderInfo, tmp_path: Path) -> None:
    """The scene's floor is drawn instead of the renderer's plain grey plane: the front of the
    picture shows its two tones of tile (the plane would be one), and the light background
    only beyond its edges."""
    loaded, problem = problem_for_scene("kitchen-4", seed=3)
    assert loaded.spec.view is not None
    view = loaded.spec.view.scene(problem)
    plain = render_view(
        replace(view, floor=None), out=tmp_path / "plain.png", width=WIDTH, height=HEIGHT
    )
    for info, tones in ((seed3, 2), (plain, 1)):
        width, height, raw = read_png(info.path)
        image = np.frombuffer(raw, dtype=np.uint8).reshape(height, 1 + 3 * width)[:, 1:]
        image = image.reshape(height, width, 3)
        assert len(np.unique(image[-20:].reshape(-1, 3) // 8, axis=0)) == tones
        background = np.all(image == BACKGROUND, axis=2).mean()
        assert background < 0.25 if tones == 2 else background == 0.0


@pytest.mark.slow
def test_different_seeds_give_different_images(seed3: RenderInfo, tmp_path: Path) -> None:
    other = render_scene(
        "kitchen-4", seed=4, out=tmp_path / "seed4.png", width=WIDTH, height=HEIGHT
    )
    again = render_scene(
        "kitchen-4", seed=3, out=tmp_path / "again.png", width=WIDTH, height=HEIGHT
    )
    assert read_png(other.path)[2] != read_png(seed3.path)[2]
    assert read_png(again.path)[2] == read_png(seed3.path)[2]


def test_unknown_scene_raises_scene_error(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="unknown scene 'kitchen-99'"):
        render_scene("kitchen-99", seed=0, out=tmp_path / "x.png")


def test_missing_output_directory_is_named(tmp_path: Path) -> None:
    missing = tmp_path / "nowhere"
    with pytest.raises(ValueError, match=f"directory {missing} does not exist"):
        render_scene("kitchen-4", seed=0, out=missing / "x.png")
    assert not missing.exists()


def test_a_domain_without_a_view_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["render", "--scene", "line-2", "--out", str(tmp_path / "x.png")]) == 2
    assert "domain 'line' has no scene description" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()

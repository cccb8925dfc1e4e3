"""What a user can launch: scenes and model files, by name only (names never become paths)."""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from planner.runs import DEFAULT_MODEL
from planner.scene import SceneError, known_scenes, load_scene

log = logging.getLogger(__name__)

NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,99}$")  # a scene or model name; no / or ..


class UnknownNameError(LookupError):
    """A scene or model name that is not offered; the message lists what is."""


@dataclass(frozen=True)
class SceneInfo:
    name: str
    domain: str
    description: str
    blocks: int


@dataclass(frozen=True)
class ModelInfo:
    name: str
    domain: str
    default: bool
    streams: list[str]
    bytes: int


def safe_name(name: str) -> bool:
    return bool(NAME.match(name)) and ".." not in name


def scenes() -> list[SceneInfo]:
    out = []
    for name in known_scenes():
        if not safe_name(name):
            continue
        try:
            scene = load_scene(name)
        except SceneError as exc:
            log.warning("scene %s is not offered: %s", name, exc)
            continue
        blocks = scene.data.get("blocks", [])
        out.append(
            SceneInfo(
                name=name,
                domain=scene.domain,
                description=str(scene.data.get("description", "")),
                blocks=len(blocks) if isinstance(blocks, list | dict) else 0,
            )
        )
    return out


def scene(name: str) -> SceneInfo:
    known = scenes()
    for info in known:
        if info.name == name and safe_name(name):
            return info
    raise UnknownNameError(
        f"unknown scene {name!r} (known: {', '.join(s.name for s in known) or 'none'})"
    )


class Models:
    """Model files ``*.pt`` in one directory; the shipped default is always offered."""

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self._cache: dict[tuple[str, float], ModelInfo | None] = {}

    def files(self) -> dict[str, Path]:
        found = {DEFAULT_MODEL.stem: DEFAULT_MODEL}
        if self.directory.is_dir():
            for path in sorted(self.directory.glob("*.pt")):
                if safe_name(path.stem):
                    found.setdefault(path.stem, path)
        return found

    def list(self) -> list[ModelInfo]:
        out = []
        for name, path in self.files().items():
            info = self._info(name, path)
            if info is not None:
                out.append(info)
        return out

    def path(self, name: str) -> Path:
        """The file of model ``name``; :class:`UnknownNameError` lists the known names."""
        files = self.files()
        if safe_name(name) and name in files:
            return files[name]
        raise UnknownNameError(f"unknown model {name!r} (known: {', '.join(files) or 'none'})")

    def _info(self, name: str, path: Path) -> ModelInfo | None:
        key = (str(path), path.stat().st_mtime)
        if key not in self._cache:
            self._cache[key] = self._read(name, path)
        return self._cache[key]

    @staticmethod
    def _read(name: str, path: Path) -> ModelInfo | None:
        import torch

        try:
            data: Any = torch.load(path, map_location="cpu", weights_only=True)
            return ModelInfo(
                name=name,
                domain=str(data["domain"]),
                default=path.resolve() == DEFAULT_MODEL.resolve(),
                streams=sorted(data["networks"]),
                bytes=path.stat().st_size,
            )
        except Exception as exc:  # a broken file is not offered, and says why in the log
            log.warning("model file %s is not offered: %s", path, exc)
            return None

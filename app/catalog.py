"""What a user can launch: domains, their scenes and model files, by name only (names never
become paths).

Scenes come from the project's ``scenes/`` folder and from the ``scenes/`` folder of every domain
found (installed ones, and the folders given to ``tamp serve --domain``); a domain that does not
load is reported (``GET /api/domains``) and its scenes are not offered. Models are the files
``*.pt`` of the model folder and each domain's shipped model, offered under the domain's name.
"""

from __future__ import annotations

import logging
import re
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from planner.domains import (
    DomainInfo,
    LoadedDomain,
    add_domain_folder,
    domain_infos,
    load_domain,
    scene_domain,
    scene_refs,
)
from planner.scene import SceneError, load_scene

log = logging.getLogger(__name__)

NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,99}$")  # a scene or model name; no / or ..


class UnknownNameError(LookupError):
    """A scene or model name that is not offered; the message lists what is."""


@dataclass(frozen=True)
class SceneInfo:
    name: str
    domain: str  # the domain's name
    description: str
    blocks: int
    path: str  # the scene file (not shown to clients)
    domain_ref: str | None  # what a run records of the domain: its folder, or None (by name)
    view: bool  # whether the domain has a 3D view


@dataclass(frozen=True)
class ModelInfo:
    name: str
    domain: str
    default: bool  # the shipped model of its domain
    streams: list[str]
    bytes: int
    trained_at: str | None = None  # when it was trained (ISO 8601), if the file says
    runs: int | None = None  # runs it was trained and validated on
    queries: int | None = None  # stream queries it saw
    validated: bool = False  # the file holds its validation figures
    source: str = "file"  # "shipped" (a domain's), "dashboard" (trained here), "file"
    metadata: dict[str, Any] | None = None  # everything the file says about its training


def safe_name(name: str) -> bool:
    return bool(NAME.match(name)) and ".." not in name


class Domains:
    """The domains the dashboard offers: installed ones and folders added at start-up. Loading a
    folder that fails is reported in :meth:`infos`, never raised."""

    def __init__(self, folders: Sequence[Path] = ()) -> None:
        self._lock = threading.Lock()
        self._added: list[LoadedDomain] = []
        self._failed: list[DomainInfo] = []
        for folder in folders:
            try:
                self._added.append(add_domain_folder(folder))
            except Exception as exc:  # a broken domain folder must not stop the server
                log.warning("domain folder %s is skipped: %s", folder, exc)
                self._failed.append(
                    DomainInfo(Path(folder).name, f"folder {folder}", None, str(exc))
                )
        self._scenes: list[SceneInfo] | None = None

    def infos(self) -> list[DomainInfo]:
        seen = {i.name for i in self._failed}
        return [i for i in domain_infos() if i.name not in seen or i.error is None] + list(
            self._failed
        )

    def scenes(self) -> list[SceneInfo]:
        with self._lock:
            if self._scenes is None:
                self._scenes = self._find_scenes()
            return list(self._scenes)

    def _find_scenes(self) -> list[SceneInfo]:
        out = []
        for ref in scene_refs(self._added):
            if not safe_name(ref.name):
                continue
            try:
                scene = load_scene(str(ref.path))
                loaded = scene_domain(ref)
            except (SceneError, ValueError) as exc:
                log.warning("scene %s is not offered: %s", ref.path, exc)
                continue
            blocks = scene.data.get("blocks", [])
            out.append(
                SceneInfo(
                    name=ref.name,
                    domain=loaded.name,
                    description=str(scene.data.get("description", "")),
                    blocks=len(blocks) if isinstance(blocks, list | dict) else 0,
                    path=str(ref.path),
                    domain_ref=loaded.reference,
                    view=loaded.spec.view is not None,
                )
            )
        return out

    def scene(self, name: str) -> SceneInfo:
        known = self.scenes()
        for info in known:
            if info.name == name and safe_name(name):
                return info
        raise UnknownNameError(
            f"unknown scene {name!r} (known: {', '.join(s.name for s in known) or 'none'})"
        )

    def loaded(self) -> list[LoadedDomain]:
        """Every domain that loads."""
        out = {d.name: d for d in self._added}
        for info in domain_infos():
            if info.error is None and info.name not in out:
                try:
                    out[info.name] = load_domain(info.name)
                except Exception as exc:  # reported by infos()
                    log.debug("domain %s: %s", info.name, exc)
        return list(out.values())

    def shipped_models(self) -> dict[str, Path]:
        """Domain name -> its shipped model file, for every domain that loads and has one."""
        return {
            d.name: d.spec.model
            for d in self.loaded()
            if d.spec.model is not None and d.spec.model.is_file()
        }


class Models:
    """Model files ``*.pt`` in one directory, and each domain's shipped model under its domain's
    name."""

    def __init__(self, directory: Path, domains: Domains) -> None:
        self.directory = directory
        self.domains = domains
        self._cache: dict[tuple[str, float], ModelInfo | None] = {}

    def files(self) -> dict[str, Path]:
        found = dict(self.domains.shipped_models())
        if self.directory.is_dir():
            for path in sorted(self.directory.glob("*.pt")):
                if safe_name(path.stem):
                    found.setdefault(path.stem, path)
        return found

    def list(self) -> list[ModelInfo]:
        out = []
        shipped = {p.resolve() for p in self.domains.shipped_models().values()}
        for name, path in self.files().items():
            info = self._info(name, path, path.resolve() in shipped)
            if info is not None:
                out.append(info)
        return out

    def path(self, name: str) -> Path:
        """The file of model ``name``; :class:`UnknownNameError` lists the known names."""
        files = self.files()
        if safe_name(name) and name in files:
            return files[name]
        raise UnknownNameError(f"unknown model {name!r} (known: {', '.join(files) or 'none'})")

    def info(self, name: str) -> ModelInfo:
        """Model ``name`` with what its file says; :class:`UnknownNameError` lists the known
        names."""
        for info in self.list():
            if info.name == name:
                return info
        known = ", ".join(m.name for m in self.list()) or "none"
        raise UnknownNameError(f"unknown model {name!r} (known: {known})")

    def domain_of(self, name: str) -> str:
        return self.info(name).domain

    def exists(self, name: str) -> bool:
        """Whether a model file of this name is offered, or would be shadowed by one."""
        return name in self.files() or (self.directory / f"{name}.pt").exists()

    def default_for(self, domain: str) -> str | None:
        """The name of a domain's shipped model, if it has one."""
        return domain if domain in self.domains.shipped_models() else None

    def _info(self, name: str, path: Path, default: bool) -> ModelInfo | None:
        key = (str(path), path.stat().st_mtime)
        if key not in self._cache:
            self._cache[key] = self._read(name, path, default)
        return self._cache[key]

    @staticmethod
    def _read(name: str, path: Path, default: bool) -> ModelInfo | None:
        import torch

        try:
            data: Any = torch.load(path, map_location="cpu", weights_only=True)
            meta = data.get("metadata") or {}
            provenance = meta.get("provenance")
            source = "shipped" if default else "file"
            if isinstance(provenance, dict) and provenance.get("trained_by") == "dashboard":
                source = "dashboard"
            return ModelInfo(
                name=name,
                domain=str(data["domain"]),
                default=default,
                streams=sorted(data["networks"]),
                bytes=path.stat().st_size,
                trained_at=_text(meta.get("trained_at")),
                runs=_count(meta.get("runs")),
                queries=_count(meta.get("queries")),
                validated=isinstance(meta.get("validation"), dict),
                source=source,
                metadata=meta if isinstance(meta, dict) else None,
            )
        except Exception as exc:  # a broken file is not offered, and says why in the log
            log.warning("model file %s is not offered: %s", path, exc)
            return None


def _text(value: Any) -> str | None:
    return value if isinstance(value, str) else None


def _count(value: Any) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) else None

"""Scene files: ``scenes/NAME.json`` describes one problem instance of a domain.

The generic part (``name``, ``domain``) is checked here; each domain checks its own fields when it
builds a problem from the scene. Every error names the file and the field.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

SCENES_DIR = Path(
    os.environ.get("TAMP_SCENES_DIR", Path(__file__).resolve().parent.parent / "scenes")
)


class SceneError(Exception):
    """A scene file is missing, malformed or describes an impossible problem."""


@dataclass(frozen=True)
class Scene:
    name: str
    domain: str
    data: Mapping[str, Any] = field(repr=False)  # the whole file, for the domain to read
    source: str = "<dict>"

    def field_error(self, path: str, message: str) -> SceneError:
        return SceneError(f"{self.source}: {path}: {message}")

    def get(self, path: str, kind: type | tuple[type, ...]) -> Any:
        """A top-level field of the given JSON type, or a :class:`SceneError` naming it."""
        if path not in self.data:
            raise self.field_error(path, "missing field")
        value = self.data[path]
        if not isinstance(value, kind) or (isinstance(value, bool) and kind is not bool):
            raise self.field_error(path, f"expected {_kind_name(kind)}, got {value!r}")
        return value


def _kind_name(kind: type | tuple[type, ...]) -> str:
    names = {list: "a list", dict: "an object", str: "a string", int: "an integer"}
    kinds = kind if isinstance(kind, tuple) else (kind,)
    return " or ".join(names.get(k, k.__name__) for k in kinds)


def known_scenes(directory: Path = SCENES_DIR) -> tuple[str, ...]:
    """Names of the scene files in ``directory``, in natural order (kitchen-2 before -10)."""

    def natural(name: str) -> tuple[str, int]:
        stem, _, num = name.rpartition("-")
        return (stem, int(num)) if num.isdigit() else (name, -1)

    return tuple(sorted((p.stem for p in directory.glob("*.json")), key=natural))


def load_scene(name_or_path: str, directory: Path = SCENES_DIR) -> Scene:
    """Load a scene by name (``kitchen-4``) or by path to a JSON file."""
    path = Path(name_or_path)
    if path.suffix != ".json":
        path = directory / f"{name_or_path}.json"
    if not path.is_file():
        known = ", ".join(known_scenes(directory)) or "none"
        raise SceneError(f"unknown scene {name_or_path!r} (known scenes: {known})")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise SceneError(f"{path}:{exc.lineno}:{exc.colno}: invalid JSON: {exc.msg}") from exc
    if not isinstance(data, dict):
        raise SceneError(f"{path}: expected a JSON object at the top level")
    scene = Scene(name="", domain="", data=data, source=str(path))
    name = scene.get("name", str)
    domain = scene.get("domain", str)
    return Scene(name=name, domain=domain, data=data, source=str(path))


def check_name(scene: Scene, path: str, value: Any) -> str:
    """A PDDL-safe object name (letters, digits, ``-``, ``_``; starting with a letter)."""
    if not isinstance(value, str) or not value:
        raise scene.field_error(path, f"expected a non-empty string, got {value!r}")
    name = value.lower()
    if not name[0].isalpha() or not all(c.isalnum() or c in "-_" for c in name):
        raise scene.field_error(
            path, f"{value!r} is not a valid object name (letters, digits, '-', '_')"
        )
    if name.startswith("opt-"):
        raise scene.field_error(path, f"{value!r} uses the reserved prefix 'opt-'")
    return name


def goal_atoms(scene: Scene, domain_predicates: Mapping[str, int], objects: set[str]) -> list[Any]:
    """``goal``: a list of facts such as ``["cooked", "b1"]``, checked against the domain."""
    goal = scene.get("goal", list)
    if not goal:
        raise scene.field_error("goal", "expected at least one fact")
    atoms = []
    for i, fact in enumerate(goal):
        path = f"goal[{i}]"
        if not isinstance(fact, list) or not fact or not all(isinstance(t, str) for t in fact):
            raise scene.field_error(path, f"expected a fact such as ['cooked', 'b1'], got {fact!r}")
        pred, *args = (t.lower() for t in fact)
        if pred not in domain_predicates:
            raise scene.field_error(path, f"unknown predicate {pred!r}")
        if domain_predicates[pred] != len(args):
            raise scene.field_error(
                path, f"{pred} takes {domain_predicates[pred]} arguments, got {len(args)}"
            )
        for arg in args:
            if arg not in objects:
                raise scene.field_error(path, f"unknown object {arg!r}")
        atoms.append((pred, tuple(args)))
    return atoms

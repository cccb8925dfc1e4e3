"""Bound kitchen plans as JSON (``tamp plan --out``, ``tamp validate``): actions and values."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from planner.abstract.skeleton import GroundAction
from planner.domains.kitchen.geometry import BlockPose
from planner.domains.kitchen.values import Conf, Grasp, Segment, Trajectory

FORMAT = "guided-tamp/kitchen-plan-v1"


class PlanFileError(Exception):
    """A plan file is missing, malformed or for something else; the message names the field."""


@dataclass(frozen=True)
class PlanFile:
    scene: str
    seed: int
    actions: tuple[GroundAction, ...]
    values: Mapping[str, Any]  # optimistic objects -> kitchen values


def _conf(c: Conf) -> dict[str, Any]:
    return {
        "type": "conf",
        "base": list(c.base),
        "torso": c.torso,
        "arm": list(c.arm),
        "approach_arm": None if c.approach_arm is None else list(c.approach_arm),
    }


def encode(value: Any) -> Any:
    """A kitchen value as JSON-able data (strings stay strings)."""
    if isinstance(value, str):
        return value
    if isinstance(value, BlockPose):
        return {"type": "pose", "x": value.x, "y": value.y, "z": value.z, "yaw": value.yaw}
    if isinstance(value, Grasp):
        (pos, quat) = value.tool_in_block
        return {
            "type": "grasp",
            "kind": value.kind,
            "position": list(pos),
            "quat_xyzw": list(quat),
            "approach": value.approach,
        }
    if isinstance(value, Conf):
        return _conf(value)
    if isinstance(value, Trajectory):
        return {
            "type": "trajectory",
            "start": _conf(value.start),
            "end": _conf(value.end),
            "holding": value.holding,
            "segments": [
                {
                    "kind": s.kind,
                    "base": [list(b) for b in s.base],
                    "arm": [list(a) for a in s.arm],
                    "seconds": s.seconds,
                }
                for s in value.segments
            ],
        }
    raise TypeError(f"cannot encode a {type(value).__name__} in a kitchen plan")


def _floats(data: Any, n: int | None, path: str) -> tuple[float, ...]:
    if not isinstance(data, list) or (n is not None and len(data) != n):
        raise PlanFileError(f"{path}: expected a list of {n or 'some'} numbers")
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in data):
        raise PlanFileError(f"{path}: expected numbers")
    return tuple(float(v) for v in data)


def _decode_conf(d: Any, path: str) -> Conf:
    if not isinstance(d, dict) or d.get("type") != "conf":
        raise PlanFileError(f"{path}: expected a conf")
    b = _floats(d.get("base"), 3, f"{path}.base")
    approach = d.get("approach_arm")
    return Conf(
        (b[0], b[1], b[2]),
        float(d.get("torso", 0.0)),
        _floats(d.get("arm"), 7, f"{path}.arm"),
        None if approach is None else _floats(approach, 7, f"{path}.approach_arm"),
    )


def decode(data: Any, path: str) -> Any:
    if isinstance(data, str):
        return data
    if not isinstance(data, dict) or "type" not in data:
        raise PlanFileError(f"{path}: expected a string or an object with a 'type'")
    kind = data["type"]
    try:
        if kind == "pose":
            return BlockPose(
                float(data["x"]), float(data["y"]), float(data["z"]), float(data["yaw"])
            )
        if kind == "grasp":
            pos = _floats(data["position"], 3, f"{path}.position")
            q = _floats(data["quat_xyzw"], 4, f"{path}.quat_xyzw")
            if data["kind"] not in ("top", "side"):
                raise PlanFileError(f"{path}.kind: expected 'top' or 'side'")
            return Grasp(
                data["kind"],
                ((pos[0], pos[1], pos[2]), (q[0], q[1], q[2], q[3])),
                float(data["approach"]),
            )
        if kind == "conf":
            return _decode_conf(data, path)
        if kind == "trajectory":
            segments = []
            for i, s in enumerate(data["segments"]):
                sp = f"{path}.segments[{i}]"
                if s.get("kind") not in ("arm", "base"):
                    raise PlanFileError(f"{sp}.kind: expected 'arm' or 'base'")
                base = tuple(_floats(b, 3, f"{sp}.base") for b in s["base"])
                arm = tuple(_floats(a, 7, f"{sp}.arm") for a in s["arm"])
                segments.append(
                    Segment(s["kind"], base, arm, float(s["seconds"]))  # type: ignore[arg-type]
                )
            return Trajectory(
                _decode_conf(data["start"], f"{path}.start"),
                _decode_conf(data["end"], f"{path}.end"),
                tuple(segments),
                data.get("holding"),
            )
    except (KeyError, TypeError, ValueError) as exc:
        raise PlanFileError(f"{path}: malformed {kind}: {exc}") from exc
    raise PlanFileError(f"{path}.type: unknown value type {kind!r}")


def plan_to_dict(
    *, scene: str, seed: int, actions: tuple[GroundAction, ...], values: Mapping[str, Any]
) -> dict[str, Any]:
    """The plan file's contents: the actions, and the values of the objects they use."""
    used = {a for act in actions for a in act.args}
    return {
        "format": FORMAT,
        "domain": "kitchen",
        "scene": scene,
        "seed": seed,
        "actions": [str(a) for a in actions],
        "values": {
            n: encode(values[n])
            for n in sorted(used)
            if n in values and not isinstance(values[n], str)
        },
    }


def write_plan(
    path: Path,
    *,
    scene: str,
    seed: int,
    actions: tuple[GroundAction, ...],
    values: Mapping[str, Any],
) -> None:
    data = plan_to_dict(scene=scene, seed=seed, actions=actions, values=values)
    path.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")


def read_plan(path: Path) -> PlanFile:
    if not path.is_file():
        raise PlanFileError(f"{path}: no such plan file")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise PlanFileError(f"{path}:{exc.lineno}:{exc.colno}: invalid JSON: {exc.msg}") from exc
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise PlanFileError(f"{path}: format: expected {FORMAT!r}")
    scene, seed = data.get("scene"), data.get("seed")
    if not isinstance(scene, str):
        raise PlanFileError(f"{path}: scene: expected a scene name")
    if not isinstance(seed, int) or isinstance(seed, bool):
        raise PlanFileError(f"{path}: seed: expected an integer")
    raw_actions = data.get("actions")
    if not isinstance(raw_actions, list) or not all(isinstance(a, str) for a in raw_actions):
        raise PlanFileError(f"{path}: actions: expected a list of strings such as '(move ...)'")
    raw_values = data.get("values", {})
    if not isinstance(raw_values, dict):
        raise PlanFileError(f"{path}: values: expected an object")
    values = {k: decode(v, f"values.{k}") for k, v in raw_values.items()}
    return PlanFile(scene, seed, tuple(GroundAction.parse(a) for a in raw_actions), values)

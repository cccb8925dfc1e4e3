"""The kitchen's value types: block poses, grasps, configurations and trajectories as JSON and as
model features (``DomainSpec.value_types``).

JSON: ``{"type": "pose", "x", "y", "z", "yaw"}``, ``{"type": "grasp", "kind", "position",
"quat_xyzw", "approach"}``, ``{"type": "conf", "base", "torso", "arm", "approach_arm"}`` and
``{"type": "trajectory", "start", "end", "holding", "segments"}``. Features: a pose is
``[x, y, z, cos yaw, sin yaw]``; a grasp ``[is_top, position(3), quat_xyzw(4)]``; a conf
``[x, y, cos yaw, sin yaw, torso, arm(6)]`` (the wrist roll goes where the shipped model saw it:
see ``conf_spill`` in features.py); a trajectory ``[seconds, start x, start y, end x,
end y]``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from planner.domains.kitchen.geometry import BlockPose
from planner.domains.kitchen.values import Conf, Grasp, Segment, Trajectory
from planner.values import JSON, ValueDecodeError, ValueType, numbers


def _conf_fields(c: Conf) -> dict[str, JSON]:
    return {
        "base": list(c.base),
        "torso": c.torso,
        "arm": list(c.arm),
        "approach_arm": None if c.approach_arm is None else list(c.approach_arm),
    }


def _conf_json(c: Conf) -> dict[str, JSON]:
    return {"type": "conf", **_conf_fields(c)}


def _decode_conf(d: Any, where: str) -> Conf:
    if not isinstance(d, Mapping) or d.get("type") != "conf":
        raise ValueDecodeError(f"{where}: expected a conf")
    b = numbers(d.get("base"), 3, f"{where}.base")
    approach = d.get("approach_arm")
    return Conf(
        (b[0], b[1], b[2]),
        float(d.get("torso", 0.0)),
        tuple(numbers(d.get("arm"), 7, f"{where}.arm")),
        None if approach is None else tuple(numbers(approach, 7, f"{where}.approach_arm")),
    )


def _pose_fields(p: BlockPose) -> dict[str, JSON]:
    return {"x": p.x, "y": p.y, "z": p.z, "yaw": p.yaw}


def _decode_pose(d: Mapping[str, JSON]) -> BlockPose:
    return BlockPose(float(d["x"]), float(d["y"]), float(d["z"]), float(d["yaw"]))


def _pose_features(d: Mapping[str, JSON]) -> list[float]:
    x, y, z, yaw = (float(d[k]) for k in ("x", "y", "z", "yaw"))
    return [x, y, z, math.cos(yaw), math.sin(yaw)]


def _grasp_fields(g: Grasp) -> dict[str, JSON]:
    (pos, quat) = g.tool_in_block
    return {"kind": g.kind, "position": list(pos), "quat_xyzw": list(quat), "approach": g.approach}


def _decode_grasp(d: Mapping[str, JSON]) -> Grasp:
    pos = numbers(d["position"], 3, "position")
    q = numbers(d["quat_xyzw"], 4, "quat_xyzw")
    if d["kind"] not in ("top", "side"):
        raise ValueDecodeError("kind: expected 'top' or 'side'")
    return Grasp(
        "top" if d["kind"] == "top" else "side",
        ((pos[0], pos[1], pos[2]), (q[0], q[1], q[2], q[3])),
        float(d["approach"]),
    )


def _grasp_features(d: Mapping[str, JSON]) -> list[float]:
    position = numbers(d.get("position"), 3, "position")
    quat = numbers(d.get("quat_xyzw"), 4, "quat_xyzw")
    return [1.0 if d.get("kind") == "top" else 0.0, *position, *quat]


def _conf_features(d: Mapping[str, JSON]) -> list[float]:
    x, y, yaw = numbers(d.get("base"), 3, "base")
    torso = float(d.get("torso", 0.0))
    arm = numbers(d.get("arm"), 7, "arm")
    return [x, y, math.cos(yaw), math.sin(yaw), torso, *arm[:6]]  # wrist roll: see features.py


def _trajectory_fields(t: Trajectory) -> dict[str, JSON]:
    return {
        "start": _conf_json(t.start),
        "end": _conf_json(t.end),
        "holding": t.holding,
        "segments": [
            {
                "kind": s.kind,
                "base": [list(b) for b in s.base],
                "arm": [list(a) for a in s.arm],
                "seconds": s.seconds,
            }
            for s in t.segments
        ],
    }


def _decode_trajectory(d: Mapping[str, JSON]) -> Trajectory:
    segments = []
    raw = d["segments"]
    if not isinstance(raw, list):
        raise ValueDecodeError("segments: expected a list")
    for i, s in enumerate(raw):
        sp = f"segments[{i}]"
        if not isinstance(s, Mapping) or s.get("kind") not in ("arm", "base"):
            raise ValueDecodeError(f"{sp}.kind: expected 'arm' or 'base'")
        base = tuple((b[0], b[1], b[2]) for b in (numbers(b, 3, f"{sp}.base") for b in s["base"]))
        arm = tuple(tuple(numbers(a, 7, f"{sp}.arm")) for a in s["arm"])
        seconds = float(s["seconds"])
        if s["kind"] == "arm":
            segments.append(Segment("arm", base, arm, seconds))
        else:
            segments.append(Segment("base", base, arm, seconds))
    holding = d.get("holding")
    return Trajectory(
        _decode_conf(d["start"], "start"),
        _decode_conf(d["end"], "end"),
        tuple(segments),
        holding if isinstance(holding, str) else None,
    )


def _trajectory_features(d: Mapping[str, JSON]) -> list[float]:
    segments = d.get("segments", [])
    seconds = sum(float(s["seconds"]) for s in segments)
    start = numbers(d["start"]["base"], 3, "start.base")
    end = numbers(d["end"]["base"], 3, "end.base")
    return [seconds, start[0], start[1], end[0], end[1]]


def _pose_label(d: Mapping[str, JSON]) -> str:
    return f"pose x {float(d['x']):.3f} y {float(d['y']):.3f} yaw {float(d['yaw']):.2f}"


def _conf_label(d: Mapping[str, JSON]) -> str:
    x, y, yaw = numbers(d.get("base"), 3, "base")
    return f"conf base ({x:.2f}, {y:.2f}, {yaw:.2f})"


def _trajectory_label(d: Mapping[str, JSON]) -> str:
    return f"trajectory {_trajectory_features(d)[0]:.1f} s"


POSE = ValueType(
    "pose", BlockPose, _pose_fields, _decode_pose, _pose_features, 5, label=_pose_label
)
GRASP = ValueType(
    "grasp",
    Grasp,
    _grasp_fields,
    _decode_grasp,
    _grasp_features,
    8,
    label=lambda d: f"{d.get('kind')} grasp",
)
CONF = ValueType(
    "conf",
    Conf,
    _conf_fields,
    lambda d: _decode_conf(d, "conf"),
    _conf_features,
    11,
    label=_conf_label,
)
TRAJECTORY = ValueType(
    "trajectory",
    Trajectory,
    _trajectory_fields,
    _decode_trajectory,
    _trajectory_features,
    5,
    label=_trajectory_label,
)
VALUE_TYPES = (POSE, GRASP, CONF, TRAJECTORY)

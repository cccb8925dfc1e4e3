"""The Panda's own feature hook (``DomainSpec.features``): what stands around a grasp, and the room
left in a region, besides the generic input slots.

State part (the same for every stream): how many blocks stand in a table region, how many in the
other regions (trays, shelves), whether the hand holds a block, and how many blocks are still
obstructed.

Stream parts, after the input slots, each led by ``unknown`` (1 when an input it needs is not
bound yet, the rest then 0):

- ``sample-placement`` (block, region): the packing grid's free slots (a slot is taken when a
  block there comes closer than a finger's room to it), the room left (how far, in decimetres,
  the block's centre can stay from every block already there, over a 9 x 9 grid of the centres
  where it fits) and the blocks already in the region. Where the last blocks go into a tray with
  little room, the free slots tell a placement that fits from one that cannot.
- ``inverse-kinematics`` (block, pose, grasp): along the axis the fingers close on, the free
  room beside the block's faces (to the nearest block in the fingers' way, in decimetres, capped
  at 1) and to a tray's rim; across it, the room to the nearest tall block (the palm's way); and
  whether a tall block stands within 8 cm. These say whether the hand fits down around the block
  before any IK is solved.

Everything is computed from the query's context: the ``at-pose`` facts and their values, and the
scene's regions and block sizes that every query carries (``static_context`` in problem.py).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.domains.manipulation.features import FloatArray, Inputs, Slots, feature_numbers
from planner.domains.panda.geometry import grid_slots
from planner.domains.spec import QueryLike
from planner.values import JSON, FeatureError, ValueCodec

KIND = "panda"  # the name model files give these features

FINGER_HALF_WIDTH = 0.011  # metres: half a finger's width across the axis it closes on
FINGER_ROOM = 0.025  # metres a closed finger needs beside a block's face
PALM_HALF_LENGTH = 0.105  # metres: half the hand's length along the fingers' axis
TALL_ABOVE = 0.03  # a block this much taller than the one grasped reaches the palm
NEAR = 0.08  # metres: a tall block this close to the centre counts as near
CAP = 0.1  # metres: more room than this is plenty
ROOM_GRID = 9  # candidate centres per side of a region, for the room left
SLOT_CAP = 12.0  # free slots counted up to this many

STREAMS: Mapping[str, tuple[str, ...]] = {
    "sample-placement": ("unknown", "free_slots", "room_dm", "blocks_in_region"),
    "inverse-kinematics": (
        "unknown",
        "finger_room_dm",
        "rim_room_dm",
        "palm_room_dm",
        "tall_near",
    ),
}
SCENE = ("n_on_table", "n_in_goal_regions", "holding", "n_obstructed")


def _pose(value: Any) -> tuple[float, float, float, float] | None:
    """x, y, z, yaw of an encoded block pose (None if it is not one)."""
    if not isinstance(value, Mapping) or value.get("type") != "panda_pose":
        return None
    try:
        return (float(value["x"]), float(value["y"]), float(value["z"]), float(value["yaw"]))
    except (KeyError, TypeError, ValueError) as exc:
        raise FeatureError(f"malformed pose {value!r}") from exc


def _half(size: Sequence[float], yaw: float) -> tuple[float, float]:
    """Half the x and y extent of a footprint turned by ``yaw`` (in the frame it is read in)."""
    c, s = abs(math.cos(yaw)), abs(math.sin(yaw))
    return (size[0] / 2 * c + size[1] / 2 * s, size[0] / 2 * s + size[1] / 2 * c)


@dataclass(frozen=True)
class _Scene:
    """What a query's context says of the scene: the regions (box, kind, rim), the block sizes
    and where each block stands."""

    regions: Mapping[str, tuple[tuple[float, float, float, float], str, float]]
    sizes: Mapping[str, tuple[float, float, float]]
    poses: Mapping[str, tuple[float, float, float, float]]  # block -> x, y, z, yaw
    on: Mapping[str, str]  # block -> region


def _scene(context: Mapping[str, Any]) -> _Scene | None:
    geometry = context.get("geometry")
    if not isinstance(geometry, Mapping):
        return None
    regions_raw, sizes_raw = geometry.get("regions"), geometry.get("blocks")
    if not isinstance(regions_raw, Mapping) or not isinstance(sizes_raw, Mapping):
        raise FeatureError("context geometry: expected {'regions': {...}, 'blocks': {...}}")
    regions = {}
    for name, r in regions_raw.items():
        if not isinstance(r, Mapping):
            raise FeatureError(f"context geometry region {name!r}: expected an object")
        box = feature_numbers(r.get("box"), 4, f"context geometry region {name!r}.box")
        rim = float(r.get("rim", 0.0))
        regions[str(name)] = ((box[0], box[1], box[2], box[3]), str(r.get("kind", "")), rim)
    sizes = {}
    for name, s in sizes_raw.items():
        n = feature_numbers(s, 3, f"context geometry block {name!r}")
        sizes[str(name)] = (n[0], n[1], n[2])
    facts = context.get("facts", [])
    values = context.get("values", {})
    if not isinstance(facts, list) or not isinstance(values, Mapping):
        raise FeatureError("context: expected {'facts': [...], 'values': {...}}")
    poses, on = {}, {}
    for fact in facts:
        if not isinstance(fact, list) or len(fact) != 3:
            continue
        if fact[0] == "at-pose":
            pose = _pose(values.get(fact[2]))
            if pose is not None:
                poses[str(fact[1])] = pose
        elif fact[0] == "on":
            on[str(fact[1])] = str(fact[2])
    return _Scene(regions, sizes, poses, on)


def placement_features(block: Any, region: Any, scene: _Scene | None) -> list[float]:
    """``[unknown, free slots, room (dm), blocks in region]`` for placing ``block`` in
    ``region`` (see the module docstring)."""
    if scene is None or not isinstance(block, str) or not isinstance(region, str):
        return [1.0, 0.0, 0.0, 0.0]
    if region not in scene.regions or block not in scene.sizes:
        return [1.0, 0.0, 0.0, 0.0]
    box, _, _ = scene.regions[region]
    size = scene.sizes[block]
    others = [
        (b, scene.poses[b])
        for b, r in scene.on.items()
        if r == region and b != block and b in scene.poses
    ]
    count = float(sum(1 for b, r in scene.on.items() if r == region and b != block))
    hx, hy = _half(size, 0.0)
    xs, ys = grid_slots(box, (hx, hy))
    free = 0
    for x in xs:
        for y in ys:
            if all(_apart(x, y, hx, hy, pose, scene.sizes.get(b)) for b, pose in others):
                free += 1
    xmin, xmax, ymin, ymax = box
    if xmax - xmin < 2 * hx or ymax - ymin < 2 * hy:
        return [0.0, 0.0, 0.0, count]
    if not others:
        room = CAP
    else:
        gx = np.linspace(xmin + hx, xmax - hx, ROOM_GRID)
        gy = np.linspace(ymin + hy, ymax - hy, ROOM_GRID)
        cx = np.array([p[0] for _, p in others])
        cy = np.array([p[1] for _, p in others])
        d2 = np.square(gx[:, None, None] - cx) + np.square(gy[None, :, None] - cy)
        room = min(float(np.sqrt(d2.min(axis=2).max())), CAP)
    return [0.0, min(float(free), SLOT_CAP) / 4, room * 10, count / 4]


def _apart(
    x: float,
    y: float,
    hx: float,
    hy: float,
    pose: tuple[float, float, float, float],
    size: tuple[float, float, float] | None,
) -> bool:
    """A slot at (x, y) keeps a finger's room from a block at ``pose``, on one axis at least."""
    if size is None:
        return True
    ox, oy = _half(size, pose[3])
    return (
        abs(pose[0] - x) >= hx + ox + FINGER_ROOM - 0.005
        or abs(pose[1] - y) >= hy + oy + FINGER_ROOM - 0.005
    )


def grasp_features(block: Any, pose: Any, grasp: Any, scene: _Scene | None) -> list[float]:
    """``[unknown, finger room, rim room, palm room (dm, capped at 1), tall block near]``
    around ``block`` standing at ``pose`` held by ``grasp`` (see the module docstring)."""
    p = _pose(pose)
    if (
        scene is None
        or p is None
        or not isinstance(block, str)
        or not isinstance(grasp, Mapping)
        or block not in scene.sizes
    ):
        return [1.0, 0.0, 0.0, 0.0, 0.0]
    x, y, _, yaw = p
    try:
        grasp_yaw = float(grasp["yaw"])
    except (KeyError, TypeError, ValueError) as exc:
        raise FeatureError(f"malformed grasp {grasp!r}") from exc
    size = scene.sizes[block]
    # u: the axis the fingers close along (the hand's y axis), v across it.
    axis = yaw + grasp_yaw + math.pi / 2
    ux, uy = math.cos(axis), math.sin(axis)
    half_u, half_v = _half(size, math.pi / 2 - grasp_yaw)  # the block's extent along u and v
    finger, palm, tall_near = CAP, CAP, 0.0
    for other, (ox, oy, _, oyaw) in scene.poses.items():
        if other == block or other not in scene.sizes:
            continue
        osize = scene.sizes[other]
        du = (ox - x) * ux + (oy - y) * uy
        dv = -(ox - x) * uy + (oy - y) * ux
        o_u, o_v = _half(osize, oyaw - axis)
        tall = osize[2] > size[2] + TALL_ABOVE
        if abs(dv) < half_v + o_v + FINGER_HALF_WIDTH:
            finger = min(finger, max(0.0, abs(du) - half_u - o_u))
        if tall and abs(du) < PALM_HALF_LENGTH + o_u:
            palm = min(palm, max(0.0, abs(dv) - half_v - o_v))
        if tall and math.hypot(ox - x, oy - y) < NEAR:
            tall_near = 1.0
    rim = CAP
    for box, _, height in scene.regions.values():
        xmin, xmax, ymin, ymax = box
        if height <= 0 or not (xmin <= x <= xmax and ymin <= y <= ymax):
            continue
        for sign in (1.0, -1.0):  # from the centre along +u and -u to the region's edge
            dx, dy = sign * ux, sign * uy
            exits = [
                (xmax - x) / dx if dx > 1e-9 else math.inf,
                (xmin - x) / dx if dx < -1e-9 else math.inf,
                (ymax - y) / dy if dy > 1e-9 else math.inf,
                (ymin - y) / dy if dy < -1e-9 else math.inf,
            ]
            rim = min(rim, max(0.0, min(exits) - half_u))
    return [0.0, min(finger, CAP) * 10, min(rim, CAP) * 10, min(palm, CAP) * 10, tall_near]


@dataclass(frozen=True)
class PandaEncoder:
    """The fitted Panda features (see the module docstring): nothing is learned from data."""

    def to_dict(self) -> dict[str, Any]:
        return {"kind": KIND}

    @property
    def scene_width(self) -> int:
        return len(SCENE)

    def stream_width(self, stream: str) -> int:
        return len(STREAMS.get(stream, ()))

    def stream_features(
        self, stream: str, inputs: Sequence[JSON | None], context: Mapping[str, Any]
    ) -> Sequence[float]:
        if stream == "sample-placement":
            if len(inputs) != 2:
                raise FeatureError(f"stream {stream!r}: expected 2 inputs, got {len(inputs)}")
            return placement_features(inputs[0], inputs[1], _scene(context))
        if stream == "inverse-kinematics":
            if len(inputs) != 3:
                raise FeatureError(f"stream {stream!r}: expected 3 inputs, got {len(inputs)}")
            return grasp_features(inputs[0], inputs[1], inputs[2], _scene(context))
        return ()

    def scene_features(self, context: Mapping[str, Any], out: FloatArray, offset: int) -> None:
        facts = context.get("facts", [])
        if not isinstance(facts, list):
            raise FeatureError("context: expected {'facts': [...], 'values': {...}}")
        geometry = context.get("geometry")
        kinds: dict[str, str] = {}
        if isinstance(geometry, Mapping) and isinstance(geometry.get("regions"), Mapping):
            for name, r in geometry["regions"].items():
                if isinstance(r, Mapping):
                    kinds[str(name)] = str(r.get("kind", ""))
        for fact in facts:
            if not isinstance(fact, list) or not fact:
                raise FeatureError(f"context: malformed fact {fact!r}")
            if fact[0] == "on" and len(fact) == 3:
                out[offset + (0 if kinds.get(fact[2]) == "table" else 1)] += 1.0
            elif fact[0] == "holding":
                out[offset + 2] = 1.0
            elif fact[0] == "obstructed":
                out[offset + 3] += 1.0

    def feature_names(self, stream: str) -> tuple[list[str], list[str]]:
        return list(STREAMS.get(stream, ())), list(SCENE)

    def finish_row(self, stream: str, inputs: Inputs, row: FloatArray, slots: Slots) -> None:
        return None


class PandaFeatures:
    """The Panda's :class:`~planner.learning.features.StateFeatures`: nothing to fit."""

    kind = KIND

    def fit(self, records: Sequence[QueryLike], codec: ValueCodec) -> PandaEncoder:
        return PandaEncoder()

    def load(self, data: Mapping[str, Any], codec: ValueCodec) -> PandaEncoder:
        if data.get("kind") != KIND:
            raise FeatureError(f"expected {KIND} features, got {data.get('kind')!r}")
        return PandaEncoder()

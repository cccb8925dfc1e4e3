"""The kitchen's own feature hook (``DomainSpec.features``): the blocks' state, and the room left
on a platform for a placement. Two layouts (``KitchenEncoder.layout``):

**relative** (what ``tamp train`` fits): nothing depends on how many blocks a scene has or what
they are called, so a model trained on short kitchens reads long ones as it read the short. The
state part counts the blocks on the table, in the sink, on the stove, held, cleaned and cooked.
Every stream's row also gets, after its input slots, its own block's ``[present, on table, on
sink, on stove, held, x, y, cos yaw, sin yaw]``: the block it is asked about (its first input
naming a block) or, for a stream about no block (motion), the block the hand holds.

**names** (the shipped model's): for each block ``b1..b<max_blocks>`` (8), ``[present, on
table, on sink, on stove, held, x, y, cos yaw, sin yaw]`` (zeros when the block is absent or its
pose is not known) and then the number of blocks on the stove and on the sink. Blocks past b8
have no features of their own; they are counted.

A placement also gets the room left on its platform, after its input slots:
``[unknown, room, blocks on it]``. ``room`` is how far the block's centre can stay from every
block already there: the largest distance to the nearest of their centres over a grid of the
centres where the block fits on the platform, in centimetres (the training noise, 0.3 on every
feature, would drown a difference of a few centimetres in metres), capped at
:data:`ROOM_CAP`. It reads the platform's footprint and the block's size from the context's
``geometry`` (see :func:`planner.domains.kitchen.problem.static_context`); without them
``unknown`` is 1. Where the last block goes onto a crowded stove, this one number tells success
from failure (when the feature came in, 1a9d360, on the validation trials of that model's
collection, the fourth block onto the stove: AUC 0.98 for the room alone, 0.96 for the model,
0.37 for the model before it, without the feature).

**The configuration spill** (``conf_spill``, on for the shipped model and for new fits): the
featurizer the shipped model was trained with gave a configuration slot room for 11 numbers but
wrote 12 (``[x, y, cos yaw, sin yaw, torso, arm(7)]``), so the last arm joint (the wrist roll)
landed in the next column: the next slot's mask bit (left alone when that slot is unbound, which
sets it) or the first state number (overwritten by 1 when block b1 is present). The conf value
type now gives 11 numbers (``arm(6)``: the wrist roll dropped) and this switch writes the wrist
roll where it used to land, so the shipped model sees exactly the rows it was trained on.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.domains.manipulation.features import FloatArray, Inputs, Slots, feature_numbers
from planner.domains.spec import QueryLike
from planner.values import JSON, FeatureError, ValueCodec

KIND = "kitchen"  # the name model files give these features
PLATFORMS = ("table", "sink", "stove")  # one "on <platform>" feature each, in this order
COUNTED = ("stove", "sink")  # "how many blocks are on it" features, in this order
MAX_BLOCKS = 8  # b1..b8: the largest kitchen scene when the names layout came in
LAYOUTS = ("relative", "names")
RELATIVE_COUNTS = ("table", "sink", "stove", "held", "cleaned", "cooked")  # relative state part
OWN_WIDTH = 9  # a block's own features: present, on table/sink/stove, held, x, y, cos, sin
_BLOCK_NAME = re.compile(r"b\d+")  # the kitchen's blocks are b1, b2, ...
ROOM: Mapping[str, int] = {"sample-placement": 1}  # streams with room features: platform input
ROOM_WIDTH = 3  # unknown, room (cm), blocks on the platform
ROOM_CAP = 30.0  # centimetres: more room than this is plenty
ROOM_GRID = 9  # candidate centres per side of the platform
FACTS_READ_MAX = 4096  # facts lists whose reading is kept (a search has one per state)

# What a facts list sets (KitchenEncoder._read_facts): the state part before the poses' values
# (present, on a platform, held, the counts), and per block with an at-pose fact, where its pose
# goes in the state part and the pose's name.
_FactsRead = tuple[FloatArray, list[tuple[int, str]]]
# What a facts list says of the blocks (KitchenEncoder._read_blocks): the blocks it names, the
# held one, each block's platform and the name of its pose.
_BlocksRead = tuple[frozenset[str], str | None, dict[str, str], dict[str, str]]


def _is_pose(value: Any) -> bool:
    return isinstance(value, Mapping) and value.get("type") == "pose"


@dataclass(frozen=True)
class KitchenEncoder:
    """The fitted kitchen features (see the module docstring)."""

    max_blocks: int = MAX_BLOCKS
    platforms: tuple[str, ...] = PLATFORMS
    counted: tuple[str, ...] = COUNTED
    room: Mapping[str, int] | None = None  # stream -> input naming the platform
    conf_spill: bool = True  # the last arm joint where the shipped model saw it (docstring)
    layout: str = "names"  # see the module docstring; tamp train fits "relative"
    _block_index: dict[str, int] = field(init=False, repr=False, compare=False)
    _platform_index: dict[str, int] = field(init=False, repr=False, compare=False)
    _facts_read: dict[int, tuple[list[Any], _FactsRead]] = field(
        init=False, repr=False, compare=False, default_factory=dict
    )
    _poses_read: dict[int, tuple[Any, FloatArray]] = field(
        init=False, repr=False, compare=False, default_factory=dict
    )
    _platforms_read: dict[
        tuple[int, str], tuple[Any, frozenset[Any], tuple[tuple[Any, Any], ...]]
    ] = field(init=False, repr=False, compare=False, default_factory=dict)
    _rooms: dict[tuple[Any, ...], tuple[Any, list[Any], list[float]]] = field(
        init=False, repr=False, compare=False, default_factory=dict
    )
    _blocks_read: dict[int, tuple[list[Any], _BlocksRead]] = field(
        init=False, repr=False, compare=False, default_factory=dict
    )
    _counts_read: dict[int, tuple[list[Any], FloatArray]] = field(
        init=False, repr=False, compare=False, default_factory=dict
    )

    def __post_init__(self) -> None:
        if self.max_blocks < 1:
            raise FeatureError(f"max_blocks must be >= 1, got {self.max_blocks}")
        if not set(self.counted) <= set(self.platforms):
            raise FeatureError(f"counted platforms {self.counted} are not all in {self.platforms}")
        if self.layout not in LAYOUTS:
            raise FeatureError(f"unknown layout {self.layout!r} (known: {', '.join(LAYOUTS)})")
        object.__setattr__(self, "room", dict(ROOM if self.room is None else self.room))
        object.__setattr__(
            self, "_block_index", {f"b{i}": i - 1 for i in range(1, self.max_blocks + 1)}
        )
        object.__setattr__(self, "_platform_index", {p: i for i, p in enumerate(self.platforms)})

    @property
    def blocks(self) -> tuple[str, ...]:
        return tuple(f"b{i}" for i in range(1, self.max_blocks + 1))

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": KIND,
            "max_blocks": self.max_blocks,
            "platforms": list(self.platforms),
            "counted": list(self.counted),
            "room": dict(self.room or {}),
            "conf_spill": self.conf_spill,
            "layout": self.layout,
        }

    @property
    def relative(self) -> bool:
        return self.layout == "relative"

    @property
    def scene_width(self) -> int:
        if self.relative:
            return len(RELATIVE_COUNTS)
        return self.max_blocks * (len(self.platforms) + 6) + len(self.counted)

    def stream_width(self, stream: str) -> int:
        room = ROOM_WIDTH if stream in (self.room or {}) else 0
        return room + (OWN_WIDTH if self.relative else 0)

    def stream_features(
        self, stream: str, inputs: Sequence[JSON | None], context: Mapping[str, Any]
    ) -> Sequence[float]:
        own = self._own_block(inputs, context) if self.relative else []
        if stream not in (self.room or {}):
            return own
        return [*self._room_features(stream, inputs, context), *own]

    def _own_block(self, inputs: Sequence[JSON | None], context: Mapping[str, Any]) -> list[float]:
        """``[present, on table, on sink, on stove, held, x, y, cos yaw, sin yaw]`` of the block
        the query is about: its first input naming a block in the state, else the held one."""
        facts = context.get("facts", [])
        if not isinstance(facts, list):
            raise FeatureError("context: expected {'facts': [...], 'values': {...}}")
        blocks, held, where, poses = self._read_blocks(facts)
        block = next((v for v in inputs if isinstance(v, str) and v in blocks), held)
        out = [0.0] * OWN_WIDTH
        if block is None:
            return out
        out[0] = 1.0
        platform = where.get(block)
        if platform is not None and platform in self._platform_index:
            out[1 + self._platform_index[platform]] = 1.0
        if block == held:
            out[1 + len(self.platforms)] = 1.0
        name = poses.get(block)
        values = context.get("values", {})
        pose = values.get(name) if name is not None and isinstance(values, Mapping) else None
        if isinstance(pose, Mapping) and _is_pose(pose):
            out[2 + len(self.platforms) : OWN_WIDTH] = self._pose_numbers(pose, str(name))
        return out

    def _read_blocks(self, facts: list[Any]) -> _BlocksRead:
        """The blocks a state names, the held one, each block's platform and pose name."""
        cached = self._blocks_read.get(id(facts))
        if cached is not None and cached[0] is facts:
            return cached[1]
        blocks: set[str] = set()
        held: str | None = None
        where: dict[str, str] = {}
        poses: dict[str, str] = {}
        for fact in facts:
            if not isinstance(fact, list) or len(fact) < 2:
                continue
            predicate, block = fact[0], fact[1]
            if predicate in ("on", "holding", "at-pose", "cleaned", "cooked"):
                blocks.add(block)
            if predicate == "on" and len(fact) == 3:
                where[block] = fact[2]
            elif predicate == "holding":
                held = block
            elif predicate == "at-pose" and len(fact) == 3:
                poses[block] = fact[2]
        read: _BlocksRead = (frozenset(blocks), held, where, poses)
        if len(self._blocks_read) >= FACTS_READ_MAX:
            self._blocks_read.clear()
        self._blocks_read[id(facts)] = (facts, read)  # the list is kept: its id is not reused
        return read

    def _room_features(
        self, stream: str, inputs: Sequence[JSON | None], context: Mapping[str, Any]
    ) -> list[float]:
        at = (self.room or {})[stream]
        if len(inputs) <= at:
            raise FeatureError(f"stream {stream!r}: room input {at} is not given")
        block, platform = inputs[0], inputs[at]
        geometry = context.get("geometry")
        if not isinstance(block, str) or not isinstance(geometry, Mapping):
            return room_left(block, platform, context)
        if not isinstance(platform, str):
            return [1.0, 0.0, 0.0]
        return self._room_left(block, platform, geometry, context)

    def _room_left(
        self, block: str, platform: str, geometry: Mapping[str, Any], context: Mapping[str, Any]
    ) -> list[float]:
        """:func:`room_left`, computed once per block, platform, geometry and the poses of the
        blocks on the platform (not per context: placing a block elsewhere leaves it)."""
        facts = context.get("facts", [])
        read = self._platforms_read.get((id(facts), platform))
        if read is None or read[0] is not facts:
            read = (facts, *_on_platform(facts, platform))
            if len(self._platforms_read) >= FACTS_READ_MAX:
                self._platforms_read.clear()
            self._platforms_read[(id(facts), platform)] = read
        _, on, placed = read
        values = context.get("values", {})
        poses = [values.get(n) for b, n in placed if b != block]
        key = (block, platform, id(geometry), on, *map(id, poses))
        hit = self._rooms.get(key)
        if hit is not None:
            return hit[2]
        room = _room(block, platform, geometry, on, poses)
        if len(self._rooms) >= FACTS_READ_MAX:
            self._rooms.clear()
        self._rooms[key] = (geometry, poses, room)  # kept, so their ids are not reused
        return room

    def finish_row(self, stream: str, inputs: Inputs, row: FloatArray, slots: Slots) -> None:
        if self.relative:
            # A block's name says nothing of it (b9 of kitchen-12 is a block like b2): its
            # one-hot is cleared, so that a model reads the block only through its own
            # features, in any scene, whatever its blocks are called.
            for i, (kind, offset, width) in enumerate(slots):
                value = inputs[i]
                if kind == "name" and isinstance(value, str) and _BLOCK_NAME.fullmatch(value):
                    row[offset + 1 : offset + width] = 0.0
            return
        if not self.conf_spill:
            return
        for i, (kind, offset, width) in enumerate(slots):
            value = inputs[i]
            if kind != "conf" or not isinstance(value, Mapping):
                continue
            wrist = feature_numbers(value.get("arm"), 7, f"stream {stream!r} input {i}.arm")[6]
            at = offset + width
            if i + 1 < len(slots):
                if inputs[i + 1] is not None:  # an unbound next slot set its mask bit over it
                    row[at] = wrist
            elif self.stream_width(stream) == 0 and row[at] != 1.0:  # b1 present wrote 1 over it
                row[at] = wrist

    def feature_names(self, stream: str) -> tuple[list[str], list[str]]:
        room = ["room.unknown", "room.cm", "room.blocks"] if stream in (self.room or {}) else []
        on = [f"on_{p}" for p in self.platforms]
        per_block = ["present", *on, "held", "x", "y", "cos_yaw", "sin_yaw"]
        if self.relative:
            return room + [f"own.{f}" for f in per_block], [f"n_{c}" for c in RELATIVE_COUNTS]
        scene = [f"{b}.{f}" for b in self.blocks for f in per_block]
        return room, scene + [f"n_on_{p}" for p in self.counted]

    def scene_features(self, context: Mapping[str, Any], out: FloatArray, offset: int) -> None:
        facts = context.get("facts", [])
        values = context.get("values", {})
        if not isinstance(facts, list) or not isinstance(values, Mapping):
            raise FeatureError("context: expected {'facts': [...], 'values': {...}}")
        if self.relative:
            out[offset : offset + len(RELATIVE_COUNTS)] = self._counts(facts)
            return
        part, poses = self._read_facts(facts)
        out[offset : offset + len(part)] = part
        for at, name in poses:
            pose = values.get(name)
            if isinstance(pose, Mapping) and _is_pose(pose):
                out[offset + at : offset + at + 4] = self._pose_numbers(pose, name)

    def _counts(self, facts: list[Any]) -> FloatArray:
        """The relative layout's state part: blocks on the table, sink and stove, held,
        cleaned, cooked (every block, whatever its name)."""
        cached = self._counts_read.get(id(facts))
        if cached is not None and cached[0] is facts:
            return cached[1]
        counts = dict.fromkeys(RELATIVE_COUNTS, 0.0)
        for fact in facts:
            if not isinstance(fact, list) or not fact or not all(isinstance(a, str) for a in fact):
                raise FeatureError(f"context: malformed fact {fact!r}")
            predicate = fact[0]
            if predicate == "on" and len(fact) == 3 and fact[2] in counts:
                counts[fact[2]] += 1.0
            elif predicate == "holding":
                counts["held"] += 1.0
            elif predicate in ("cleaned", "cooked"):
                counts[predicate] += 1.0
        part = np.array([counts[c] for c in RELATIVE_COUNTS], dtype=np.float32)
        part.flags.writeable = False
        if len(self._counts_read) >= FACTS_READ_MAX:
            self._counts_read.clear()
        self._counts_read[id(facts)] = (facts, part)
        return part

    def _pose_numbers(self, pose: Mapping[str, Any], name: str) -> FloatArray:
        """``[x, y, cos yaw, sin yaw]`` of an encoded pose, computed once per pose object (a
        search encodes each bound value once; the object is kept, so its id is not reused)."""
        hit = self._poses_read.get(id(pose))
        if hit is not None and hit[0] is pose:
            return hit[1]
        x, y, _z, cos_yaw, sin_yaw = _pose_features(pose, f"context value {name}")
        numbers = np.array([x, y, cos_yaw, sin_yaw], dtype=np.float32)
        if len(self._poses_read) >= FACTS_READ_MAX:
            self._poses_read.clear()
        self._poses_read[id(pose)] = (pose, numbers)
        return numbers

    def _read_facts(self, facts: list[Any]) -> _FactsRead:
        """What ``facts`` set, apart from the poses' values: the state part with the features
        they make 1 (present, on a platform, held) and the blocks on each counted platform,
        and per block with an ``at-pose`` fact, where its pose's numbers go and the pose's
        name. A search's contexts share one facts list per state (planner.search.queries), so
        each list is read once."""
        cached = self._facts_read.get(id(facts))
        if cached is not None and cached[0] is facts:
            return cached[1]
        block_index, platform_index = self._block_index, self._platform_index
        n_platforms = len(self.platforms)
        per_block = n_platforms + 6
        ones: set[int] = set()
        counts = dict.fromkeys(self.counted, 0)
        poses: list[tuple[int, str]] = []
        for fact in facts:
            if not isinstance(fact, list) or not fact or not all(isinstance(a, str) for a in fact):
                raise FeatureError(f"context: malformed fact {fact!r}")
            predicate, *args = fact
            for arg in args:
                if arg in block_index:
                    ones.add(block_index[arg] * per_block)  # present
            if predicate == "on" and len(args) == 2 and args[1] in counts:
                counts[args[1]] += 1  # every block counts, past the padded ones too
            if not args or args[0] not in block_index:
                continue
            base = block_index[args[0]] * per_block
            if predicate == "on" and len(args) == 2 and args[1] in platform_index:
                ones.add(base + 1 + platform_index[args[1]])
            elif predicate == "holding":
                ones.add(base + 1 + n_platforms)
            elif predicate == "at-pose" and len(args) == 2:
                poses.append((block_index[args[0]], args[1]))
        part = np.zeros(self.scene_width, dtype=np.float32)
        part[np.array(sorted(ones), dtype=np.intp)] = 1.0
        tail = self.max_blocks * per_block
        part[tail : tail + len(self.counted)] = [float(counts[p]) for p in self.counted]
        part.flags.writeable = False
        read: _FactsRead = (part, [(b * per_block + 2 + n_platforms, name) for b, name in poses])
        if len(self._facts_read) >= FACTS_READ_MAX:  # rows read from stored records: all new
            self._facts_read.clear()
        self._facts_read[id(facts)] = (facts, read)  # the list is kept: its id is not reused
        return read


class KitchenFeatures:
    """The kitchen's :class:`~planner.learning.features.StateFeatures`: nothing to fit."""

    kind = KIND

    def fit(self, records: Sequence[QueryLike], codec: ValueCodec) -> KitchenEncoder:
        return KitchenEncoder(layout="relative")

    def load(self, data: Mapping[str, Any], codec: ValueCodec) -> KitchenEncoder:
        try:
            return KitchenEncoder(
                max_blocks=int(data["max_blocks"]),
                platforms=tuple(str(p) for p in data["platforms"]),
                counted=tuple(str(p) for p in data["counted"]),
                room={str(k): int(v) for k, v in data.get("room", {}).items()},
                conf_spill=bool(data.get("conf_spill", True)),
                layout=str(data.get("layout", "names")),
            )
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise FeatureError(f"malformed kitchen features: missing or bad field {exc}") from exc


def _pose_features(value: Mapping[str, Any], where: str) -> list[float]:
    try:
        x, y, z, yaw = (float(value[k]) for k in ("x", "y", "z", "yaw"))
    except (KeyError, TypeError, ValueError) as exc:
        raise FeatureError(f"{where}: malformed pose {value!r}") from exc
    return [x, y, z, math.cos(yaw), math.sin(yaw)]


def room_left(block: Any, platform: Any, context: Mapping[str, Any]) -> list[float]:
    """``[unknown, room, blocks on it]`` for placing ``block`` on ``platform`` (see the module
    docstring). Blocks on the platform whose pose is not bound yet count, but leave no mark."""
    geometry = context.get("geometry")
    if not isinstance(geometry, Mapping) or not isinstance(platform, str):
        return [1.0, 0.0, 0.0]
    on, placed = _on_platform(context.get("facts", []), platform)
    values = context.get("values", {})
    return _room(block, platform, geometry, on, [values.get(n) for b, n in placed if b != block])


def _on_platform(facts: Any, platform: str) -> tuple[frozenset[Any], tuple[tuple[Any, Any], ...]]:
    """The blocks on ``platform`` and, in the facts' order, the ``(block, pose name)`` of their
    ``at-pose`` facts."""
    lists = [f for f in facts if isinstance(f, list)]
    on = frozenset(f[1] for f in lists if f[:1] == ["on"] and f[2:] == [platform])
    placed = tuple(
        (f[1], f[2]) for f in lists if f[:1] == ["at-pose"] and len(f) == 3 and f[1] in on
    )
    return on, placed


def _room(
    block: Any,
    platform: str,
    geometry: Mapping[str, Any],
    on: frozenset[Any],
    poses: Sequence[Any],
) -> list[float]:
    """:func:`room_left` from what it reads: the blocks on the platform, and the encoded poses
    (or None) of those but ``block``."""
    footprints, sizes = geometry.get("platforms", {}), geometry.get("blocks", {})
    if not isinstance(footprints, Mapping) or not isinstance(sizes, Mapping):
        raise FeatureError("context geometry: expected {'platforms': {...}, 'blocks': {...}}")
    box, size = footprints.get(platform), sizes.get(block)
    if box is None or size is None:
        return [1.0, 0.0, 0.0]
    xmin, xmax, ymin, ymax = feature_numbers(box, 4, f"context geometry platform {platform!r}")
    (half,) = (v / 2 for v in feature_numbers([size], 1, f"context geometry block {block!r}"))
    others = len(on - {block})
    centres = [(float(p["x"]), float(p["y"])) for p in poses if _is_pose(p)]
    if xmax - xmin < 2 * half or ymax - ymin < 2 * half:
        return [0.0, 0.0, float(others)]
    if not centres:
        return [0.0, ROOM_CAP, float(others)]
    xs, ys = _grid(xmin + half, xmax - half), _grid(ymin + half, ymax - half)
    cx, cy = np.array(centres).T
    dx2 = np.square(xs[:, None] - cx[None, :])  # (grid x, centre)
    dy2 = np.square(ys[:, None] - cy[None, :])  # (grid y, centre)
    nearest2 = (dx2[None, :, :] + dy2[:, None, :]).min(axis=2)  # squared, per grid point
    return [0.0, float(min(100.0 * math.sqrt(nearest2.max()), ROOM_CAP)), float(others)]


@functools.lru_cache(maxsize=256)
def _grid(low: float, high: float) -> npt.NDArray[np.float64]:
    """:data:`ROOM_GRID` candidate centres from ``low`` to ``high`` (a platform has few)."""
    out = np.linspace(low, high, ROOM_GRID)
    out.flags.writeable = False
    return out

"""Feature vectors of stream queries: local features of the inputs, global features of the scene.

A row is ``[slot 0 | slot 1 | ... | scene]``. Each input slot is a mask bit followed by the slot's
features: a name is one-hot over the slot's vocabulary plus an "unknown" bucket; a pose is
``[x, y, z, cos yaw, sin yaw]``; a grasp ``[is_top, position(3), quat_xyzw(4)]``; a conf
``[x, y, cos yaw, sin yaw, torso, arm(7)]``. An input that is not bound yet (``None``: the planner
scores a stream before the streams feeding it have been queried) is a zero vector with its mask
bit set to 1, as in the paper. The scene part has, for each block ``b1..b<max_blocks>``,
``[present, on table, on sink, on stove, held, x, y, cos yaw, sin yaw]`` (zeros when the block
is absent or its pose is not known) and then the number of blocks on the stove and on the sink.

A placement also gets the room left on its platform, after its input slots:
``[unknown, room, blocks on it]``. ``room`` is how far the block's centre can stay from every
block already there: the largest distance to the nearest of their centres over a grid of the
centres where the block fits on the platform, in centimetres (the training noise, 0.3 on every
feature, would drown a difference of a few centimetres in metres), capped at
:data:`ROOM_CAP`. It reads the platform's footprint and the block's size from the context's
``geometry`` (see :func:`planner.domains.kitchen.static_context`); without them ``unknown`` is
1. Where the last block goes onto a crowded stove, this one number tells success from failure
(on the validation trials of the shipped model, the fourth block onto the stove: AUC 0.98 for
the room alone, 0.96 for the model, 0.37 for the model before it; benchmarks/stove_room.py).

The layout of every stream (slot kinds, name vocabularies) is a :class:`FeatureSpec`, learned
from recorded queries by :meth:`Featurizer.fit` and saved inside the model file as a plain dict.
This module needs no torch.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal, Protocol, get_args

import numpy as np
import numpy.typing as npt

FEATURE_VERSION = 2  # bump whenever a row's layout or meaning changes: old models must not load

SlotKind = Literal["name", "pose", "grasp", "conf"]
SLOT_KINDS: tuple[SlotKind, ...] = get_args(SlotKind)
VALUE_WIDTHS: Mapping[str, int] = {"pose": 5, "grasp": 8, "conf": 11}

KNOWN_DOMAINS = ("kitchen",)
KITCHEN_PLATFORMS = ("table", "sink", "stove")  # one "on <platform>" feature each, in this order
KITCHEN_COUNTED = ("stove", "sink")  # "how many blocks are on it" features, in this order
KITCHEN_MAX_BLOCKS = 8  # b1..b8: the largest kitchen scene
# The kitchen's streams (domains/kitchen/stream.pddl): what each input slot holds.
KITCHEN_SLOTS: Mapping[str, tuple[SlotKind, ...]] = {
    "sample-grasp": ("name",),
    "sample-placement": ("name", "name"),
    "inverse-kinematics": ("name", "pose", "grasp"),
    "plan-motion": ("conf", "conf"),
}

# Streams that get the room-left features, and which of their inputs is the platform.
KITCHEN_ROOM: Mapping[str, int] = {"sample-placement": 1}
ROOM_WIDTH = 3  # unknown, room (cm), blocks on the platform
ROOM_CAP = 30.0  # centimetres: more room than this is plenty
ROOM_GRID = 9  # candidate centres per side of the platform

FloatArray = npt.NDArray[np.float32]


class FeatureError(ValueError):
    """A feature spec or a value does not fit; the message names the stream, slot or field."""


class QueryLike(Protocol):
    """What fitting reads of a recorded query (:class:`planner.store.QueryRecord` is one)."""

    @property
    def stream(self) -> str: ...

    @property
    def inputs(self) -> list[Any]: ...


# --- the spec --------------------------------------------------------------------------------


@dataclass(frozen=True)
class SlotSpec:
    """One input slot of a stream: its kind and, for names, the vocabulary seen in training."""

    kind: SlotKind
    vocabulary: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in SLOT_KINDS:
            raise FeatureError(f"unknown slot kind {self.kind!r} (known: {', '.join(SLOT_KINDS)})")
        if self.vocabulary and self.kind != "name":
            raise FeatureError(f"a {self.kind} slot has no vocabulary")
        if len(set(self.vocabulary)) != len(self.vocabulary):
            raise FeatureError(f"repeated names in vocabulary {list(self.vocabulary)}")

    @property
    def width(self) -> int:
        """Mask bit plus features (a name: one-hot with an unknown bucket)."""
        body = len(self.vocabulary) + 1 if self.kind == "name" else VALUE_WIDTHS[self.kind]
        return 1 + body


@dataclass(frozen=True)
class StreamLayout:
    stream: str
    slots: tuple[SlotSpec, ...]
    room: int | None = None  # the input naming the platform, for the room-left features

    def __post_init__(self) -> None:
        if self.room is not None and not (
            0 <= self.room < len(self.slots) and self.slots[self.room].kind == "name"
        ):
            raise FeatureError(f"stream {self.stream!r}: room input {self.room} is not a name")

    @property
    def width(self) -> int:
        return sum(s.width for s in self.slots) + (ROOM_WIDTH if self.room is not None else 0)


@dataclass(frozen=True)
class FeatureSpec:
    """Everything needed to rebuild a featurizer: saved in the model file as :meth:`to_dict`."""

    streams: tuple[StreamLayout, ...]
    version: int = FEATURE_VERSION
    domain: str = "kitchen"
    max_blocks: int = KITCHEN_MAX_BLOCKS  # scene features are padded to this many blocks
    platforms: tuple[str, ...] = KITCHEN_PLATFORMS
    counted: tuple[str, ...] = KITCHEN_COUNTED

    def __post_init__(self) -> None:
        if self.domain not in KNOWN_DOMAINS:
            raise FeatureError(
                f"no scene features for domain {self.domain!r} (known: {', '.join(KNOWN_DOMAINS)})"
            )
        if self.max_blocks < 1:
            raise FeatureError(f"max_blocks must be >= 1, got {self.max_blocks}")
        names = [s.stream for s in self.streams]
        if len(set(names)) != len(names):
            raise FeatureError(f"a stream has two layouts: {names}")
        if not set(self.counted) <= set(self.platforms):
            raise FeatureError(f"counted platforms {self.counted} are not all in {self.platforms}")

    @property
    def blocks(self) -> tuple[str, ...]:
        return tuple(f"b{i}" for i in range(1, self.max_blocks + 1))

    @property
    def scene_width(self) -> int:
        return self.max_blocks * (len(self.platforms) + 6) + len(self.counted)

    def layout(self, stream: str) -> StreamLayout | None:
        for layout in self.streams:
            if layout.stream == stream:
                return layout
        return None

    def to_dict(self) -> dict[str, Any]:
        return {
            "version": self.version,
            "domain": self.domain,
            "max_blocks": self.max_blocks,
            "platforms": list(self.platforms),
            "counted": list(self.counted),
            "streams": {
                layout.stream: [
                    {"kind": s.kind, "vocabulary": list(s.vocabulary)} for s in layout.slots
                ]
                for layout in self.streams
            },
            "room": {
                layout.stream: layout.room for layout in self.streams if layout.room is not None
            },
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> FeatureSpec:
        """The inverse of :meth:`to_dict`; a malformed dict raises :class:`FeatureError`."""
        try:
            room = {str(k): int(v) for k, v in data.get("room", {}).items()}
            streams = tuple(
                StreamLayout(
                    str(name),
                    tuple(
                        SlotSpec(s["kind"], tuple(str(v) for v in s["vocabulary"])) for s in slots
                    ),
                    room.get(str(name)),
                )
                for name, slots in data["streams"].items()
            )
            return cls(
                streams=streams,
                version=int(data["version"]),
                domain=str(data["domain"]),
                max_blocks=int(data["max_blocks"]),
                platforms=tuple(str(p) for p in data["platforms"]),
                counted=tuple(str(p) for p in data["counted"]),
            )
        except (KeyError, TypeError, AttributeError) as exc:
            raise FeatureError(f"malformed feature spec: missing or bad field {exc}") from exc


# --- the featurizer --------------------------------------------------------------------------


def _kind_of(value: Any) -> SlotKind | None:
    if isinstance(value, str):
        return "name"
    if isinstance(value, Mapping) and value.get("type") in VALUE_WIDTHS:
        kind: SlotKind = value["type"]
        return kind
    return None


def _numbers(value: Any, n: int, where: str) -> list[float]:
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != n:
        raise FeatureError(f"{where}: expected {n} numbers, got {value!r}")
    try:
        return [float(v) for v in value]
    except (TypeError, ValueError) as exc:
        raise FeatureError(f"{where}: expected {n} numbers, got {value!r}") from exc


def _pose_features(value: Mapping[str, Any], where: str) -> list[float]:
    try:
        x, y, z, yaw = (float(value[k]) for k in ("x", "y", "z", "yaw"))
    except (KeyError, TypeError, ValueError) as exc:
        raise FeatureError(f"{where}: malformed pose {value!r}") from exc
    return [x, y, z, math.cos(yaw), math.sin(yaw)]


def _grasp_features(value: Mapping[str, Any], where: str) -> list[float]:
    position = _numbers(value.get("position"), 3, f"{where}.position")
    quat = _numbers(value.get("quat_xyzw"), 4, f"{where}.quat_xyzw")
    return [1.0 if value.get("kind") == "top" else 0.0, *position, *quat]


def _conf_features(value: Mapping[str, Any], where: str) -> list[float]:
    x, y, yaw = _numbers(value.get("base"), 3, f"{where}.base")
    try:
        torso = float(value.get("torso", 0.0))
    except (TypeError, ValueError) as exc:
        raise FeatureError(f"{where}.torso: expected a number") from exc
    arm = _numbers(value.get("arm"), 7, f"{where}.arm")
    return [x, y, math.cos(yaw), math.sin(yaw), torso, *arm]


_VALUE_FEATURES = {"pose": _pose_features, "grasp": _grasp_features, "conf": _conf_features}


class Featurizer:
    """Fixed-length float32 rows for stream queries, per stream, following a :class:`FeatureSpec`.

    A stream the spec has no layout for (never seen in training) gets the scene features only.
    """

    def __init__(self, spec: FeatureSpec) -> None:
        if spec.version != FEATURE_VERSION:
            raise FeatureError(
                f"feature spec version {spec.version}, this code computes version "
                f"{FEATURE_VERSION}: retrain the model"
            )
        self._spec = spec
        self._block_index = {b: i for i, b in enumerate(spec.blocks)}
        self._platform_index = {p: i for i, p in enumerate(spec.platforms)}
        self._name_index = {
            layout.stream: [{v: i for i, v in enumerate(s.vocabulary)} for s in layout.slots]
            for layout in spec.streams
        }

    def __repr__(self) -> str:
        return f"Featurizer(domain={self._spec.domain!r}, streams={list(self.streams)})"

    @classmethod
    def fit(
        cls,
        records: Iterable[QueryLike],
        *,
        domain: str = "kitchen",
        max_blocks: int = KITCHEN_MAX_BLOCKS,
    ) -> Featurizer:
        """Learn each stream's slot kinds and name vocabularies from recorded queries.

        The kitchen's four streams always get a layout (kinds fixed by the domain), even with no
        records; another stream takes its slot kinds from the first record that binds them.
        """
        kinds: dict[str, list[SlotKind | None]] = {
            s: list(k) for s, k in (KITCHEN_SLOTS.items() if domain == "kitchen" else ())
        }
        names: dict[str, list[set[str]]] = {s: [set() for _ in k] for s, k in kinds.items()}
        for record in records:
            stream = record.stream
            if stream not in kinds:
                kinds[stream] = [None] * len(record.inputs)
                names[stream] = [set() for _ in record.inputs]
            slots = kinds[stream]
            if len(record.inputs) != len(slots):
                raise FeatureError(
                    f"stream {stream!r}: a record has {len(record.inputs)} inputs, "
                    f"expected {len(slots)}"
                )
            for i, value in enumerate(record.inputs):
                if value is None:
                    continue
                kind = _kind_of(value)
                if kind is None:
                    raise FeatureError(
                        f"stream {stream!r} input {i}: no features for value {value!r} "
                        f"(known kinds: {', '.join(SLOT_KINDS)})"
                    )
                if slots[i] is None:
                    slots[i] = kind
                elif slots[i] != kind:
                    raise FeatureError(
                        f"stream {stream!r} input {i}: expected a {slots[i]}, got a {kind}"
                    )
                if kind == "name":
                    names[stream][i].add(value)
        layouts = []
        for stream in sorted(kinds):
            slots_spec = []
            for i, kind in enumerate(kinds[stream]):
                if kind is None:
                    raise FeatureError(f"stream {stream!r} input {i}: never bound in the records")
                vocab = tuple(sorted(names[stream][i])) if kind == "name" else ()
                slots_spec.append(SlotSpec(kind, vocab))
            room = KITCHEN_ROOM.get(stream) if domain == "kitchen" else None
            layouts.append(StreamLayout(stream, tuple(slots_spec), room))
        return cls(FeatureSpec(streams=tuple(layouts), domain=domain, max_blocks=max_blocks))

    @classmethod
    def from_spec(cls, data: Mapping[str, Any]) -> Featurizer:
        """Rebuild from :meth:`FeatureSpec.to_dict` (as stored in a model file)."""
        return cls(FeatureSpec.from_dict(data))

    @property
    def spec(self) -> FeatureSpec:
        return self._spec

    @property
    def streams(self) -> tuple[str, ...]:
        return tuple(layout.stream for layout in self._spec.streams)

    def scene_offset(self, stream: str) -> int:
        """Where the scene features start in the rows of ``stream``."""
        return self.width(stream) - self._spec.scene_width

    def width(self, stream: str) -> int:
        """Length of the rows of ``stream``."""
        layout = self._spec.layout(stream)
        return (layout.width if layout is not None else 0) + self._spec.scene_width

    def feature_names(self, stream: str) -> list[str]:
        """A name for each column of ``stream``'s rows (for debugging and reports)."""
        out: list[str] = []
        layout = self._spec.layout(stream)
        for i, slot in enumerate(layout.slots if layout is not None else ()):
            out.append(f"in{i}.unbound")
            if slot.kind == "name":
                out += [f"in{i}.is_{v}" for v in slot.vocabulary] + [f"in{i}.is_unknown"]
            else:
                out += [f"in{i}.{slot.kind}[{j}]" for j in range(VALUE_WIDTHS[slot.kind])]
        if layout is not None and layout.room is not None:
            out += ["room.unknown", "room.cm", "room.blocks"]
        for b in self._spec.blocks:
            out += [f"{b}.{f}" for f in self._block_feature_names()]
        out += [f"n_on_{p}" for p in self._spec.counted]
        return out

    def _block_feature_names(self) -> list[str]:
        on = [f"on_{p}" for p in self._spec.platforms]
        return ["present", *on, "held", "x", "y", "cos_yaw", "sin_yaw"]

    def row(
        self, stream: str, inputs: Sequence[Any | None], context: Mapping[str, Any]
    ) -> FloatArray:
        """The feature row of one query of ``stream`` (``None`` inputs are not bound yet)."""
        out = np.zeros(self.width(stream), dtype=np.float32)
        layout = self._spec.layout(stream)
        offset = 0
        if layout is not None:
            if len(inputs) != len(layout.slots):
                raise FeatureError(
                    f"stream {stream!r} takes {len(layout.slots)} inputs, got {len(inputs)}"
                )
            for i, (slot, value) in enumerate(zip(layout.slots, inputs, strict=True)):
                self._slot(out, offset, stream, i, slot, value)
                offset += slot.width
            if layout.room is not None:
                out[offset : offset + ROOM_WIDTH] = room_left(
                    inputs[0], inputs[layout.room], context
                )
                offset += ROOM_WIDTH
        self._scene(out, offset, context)
        return out

    def matrix(
        self, stream: str, queries: Iterable[tuple[Sequence[Any | None], Mapping[str, Any]]]
    ) -> FloatArray:
        """Rows of many ``(inputs, context)`` queries of one stream, shape ``(n, width)``."""
        rows = [self.row(stream, inputs, context) for inputs, context in queries]
        if not rows:
            return np.zeros((0, self.width(stream)), dtype=np.float32)
        return np.stack(rows)

    def _slot(
        self, out: FloatArray, offset: int, stream: str, i: int, slot: SlotSpec, value: Any
    ) -> None:
        if value is None:
            out[offset] = 1.0  # unbound: mask bit set, features stay zero
            return
        where = f"stream {stream!r} input {i}"
        if slot.kind == "name":
            if not isinstance(value, str):
                raise FeatureError(f"{where}: expected a name, got {value!r}")
            index = self._name_index[stream][i].get(value, len(slot.vocabulary))
            out[offset + 1 + index] = 1.0
            return
        if _kind_of(value) != slot.kind:
            raise FeatureError(f"{where}: expected a {slot.kind}, got {value!r}")
        features = _VALUE_FEATURES[slot.kind](value, where)
        out[offset + 1 : offset + 1 + len(features)] = features

    def _scene(self, out: FloatArray, offset: int, context: Mapping[str, Any]) -> None:
        facts = context.get("facts", [])
        values = context.get("values", {})
        if not isinstance(facts, list) or not isinstance(values, Mapping):
            raise FeatureError("context: expected {'facts': [...], 'values': {...}}")
        n_platforms = len(self._spec.platforms)
        per_block = n_platforms + 6
        counts = dict.fromkeys(self._spec.counted, 0)
        for fact in facts:
            if not isinstance(fact, list) or not fact or not all(isinstance(a, str) for a in fact):
                raise FeatureError(f"context: malformed fact {fact!r}")
            predicate, *args = fact
            for arg in args:
                if arg in self._block_index:
                    out[offset + self._block_index[arg] * per_block] = 1.0  # present
            if not args or args[0] not in self._block_index:
                continue
            base = offset + self._block_index[args[0]] * per_block
            if predicate == "on" and len(args) == 2 and args[1] in self._platform_index:
                out[base + 1 + self._platform_index[args[1]]] = 1.0
                if args[1] in counts:
                    counts[args[1]] += 1
            elif predicate == "holding":
                out[base + 1 + n_platforms] = 1.0
            elif predicate == "at-pose" and len(args) == 2:
                pose = values.get(args[1])
                if isinstance(pose, Mapping) and _kind_of(pose) == "pose":
                    x, y, _z, cos_yaw, sin_yaw = _pose_features(pose, f"context value {args[1]}")
                    out[base + 2 + n_platforms : base + per_block] = [x, y, cos_yaw, sin_yaw]
        tail = offset + self._spec.max_blocks * per_block
        out[tail : tail + len(self._spec.counted)] = [counts[p] for p in self._spec.counted]


def room_left(block: Any, platform: Any, context: Mapping[str, Any]) -> list[float]:
    """``[unknown, room, blocks on it]`` for placing ``block`` on ``platform`` (see the module
    docstring). Blocks on the platform whose pose is not bound yet count, but leave no mark."""
    geometry = context.get("geometry")
    if not isinstance(geometry, Mapping) or not isinstance(platform, str):
        return [1.0, 0.0, 0.0]
    footprints, sizes = geometry.get("platforms", {}), geometry.get("blocks", {})
    if not isinstance(footprints, Mapping) or not isinstance(sizes, Mapping):
        raise FeatureError("context geometry: expected {'platforms': {...}, 'blocks': {...}}")
    box, size = footprints.get(platform), sizes.get(block)
    if box is None or size is None:
        return [1.0, 0.0, 0.0]
    xmin, xmax, ymin, ymax = _numbers(box, 4, f"context geometry platform {platform!r}")
    (half,) = (v / 2 for v in _numbers([size], 1, f"context geometry block {block!r}"))
    values = context.get("values", {})
    facts = [f for f in context.get("facts", []) if isinstance(f, list)]
    on = {f[1] for f in facts if f[:1] == ["on"] and f[2:] == [platform]}
    on.discard(block)
    centres = []
    for fact in facts:
        if fact[:1] == ["at-pose"] and len(fact) == 3 and fact[1] in on:
            pose = values.get(fact[2])
            if isinstance(pose, Mapping) and _kind_of(pose) == "pose":
                centres.append((float(pose["x"]), float(pose["y"])))
    if xmax - xmin < 2 * half or ymax - ymin < 2 * half:
        return [0.0, 0.0, float(len(on))]
    if not centres:
        return [0.0, ROOM_CAP, float(len(on))]
    xs = np.linspace(xmin + half, xmax - half, ROOM_GRID)
    ys = np.linspace(ymin + half, ymax - half, ROOM_GRID)
    grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 1, 2)
    nearest = np.linalg.norm(grid - np.asarray(centres)[None, :, :], axis=-1).min(axis=1)
    return [0.0, float(min(100.0 * nearest.max(), ROOM_CAP)), float(len(on))]

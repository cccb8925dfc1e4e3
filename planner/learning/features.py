"""Feature rows of stream queries: the stream's inputs (local) and the state it is queried in
(global), for any domain.

A row is ``[slot 0 | slot 1 | ... | stream part | state part]``:

- each **input slot** is a mask bit then the value's features: a ``name`` is one-hot over the
  names seen in training plus an "unknown" bucket; a ``number`` is itself; a ``vector`` its
  numbers; a domain's value type gives its own ``width`` numbers
  (:class:`planner.values.ValueType`). An input that is not bound yet (``None``: the planner
  scores a stream before the streams feeding it have been queried) is a zero vector with its
  mask bit set to 1, as in the paper.
- the **stream** and **state** parts come from the domain's :class:`StateFeatures` hook
  (``DomainSpec.features``). The default, :class:`FactFeatures`, is the paper's "global
  information" for any domain: the fluent facts that hold where the stream's output is needed and
  the values they hold (see its docstring). A domain may replace it with features of its own
  (the kitchen's room left on a platform).

The layout of every stream (slot kinds, name vocabularies) and the state encoder's parameters
are a :class:`FeatureSpec`, fit on recorded queries by :meth:`Featurizer.fit` and saved inside
the model file as a plain dict. This module needs no torch.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.abstract.instantiate import OPTIMISTIC_PREFIX
from planner.domains.spec import (
    Context,
    LoadedDomain,
    QueryLike,
    StateEncoder,
    StateFeatures,
)
from planner.values import JSON, OPAQUE, FeatureError, ValueCodec

__all__ = [
    "FEATURE_VERSION",
    "FactFeatures",
    "FeatureError",
    "FeatureSpec",
    "Featurizer",
    "SlotSpec",
    "StateEncoder",
    "StateFeatures",
    "StreamLayout",
]

FEATURE_VERSION = 3  # bump whenever a row's layout or meaning changes: old models must not load
MAX_FACT_KEYS = 128  # FactFeatures: the most frequent fact patterns kept (the rest only counted)
MAX_SEEN_FACTS = 100_000  # facts whose encoding a FactEncoder remembers (cleared beyond)
MAX_SEEN_CONTEXTS = 4096  # contexts whose state part a Featurizer remembers (cleared beyond)

FloatArray = npt.NDArray[np.float32]


def _makeup(context: Context) -> tuple[Any, ...]:
    """What ``context`` is made of: each entry's key and object, and each value's name and
    object, by identity. Two contexts of one make-up give the same features."""
    values = context.get("values")
    if not isinstance(values, Mapping):
        values = {}
    return (
        tuple(context),
        tuple([0 if k == "values" else id(v) for k, v in context.items()]),
        tuple(values),
        tuple(map(id, values.values())),
    )


# --- the generic state encoding -----------------------------------------------------------------


def _is_optimistic(name: str) -> bool:
    return name.startswith(OPTIMISTIC_PREFIX)


def _fact_key(fact: Sequence[str]) -> str:
    """A fact's pattern: optimistic objects (sampled values) become ``*``; problem objects keep
    their names. ``["at-pose", "b1", "opt-p3"]`` -> ``"at-pose b1 *"``."""
    return " ".join(["*" if _is_optimistic(a) else a for a in fact])


def _facts(context: Context) -> list[list[str]]:
    facts = context.get("facts", [])
    if not isinstance(facts, list):
        raise FeatureError("context: expected {'facts': [...], 'values': {...}}")
    for fact in facts:
        if not isinstance(fact, list) or not fact or not all(isinstance(a, str) for a in fact):
            raise FeatureError(f"context: malformed fact {fact!r}")
    return facts


def _values(context: Context) -> Mapping[str, Any]:
    values = context.get("values", {})
    if not isinstance(values, Mapping):
        raise FeatureError("context: expected {'facts': [...], 'values': {...}}")
    return values


@dataclass(frozen=True)
class _KeySlot:
    """One argument of a fact pattern that holds a value: its position and kind."""

    position: int  # 1-based: position 0 is the predicate
    kind: str | None  # None: never bound in the training queries (only its mask bit)
    size: int = 0  # a vector's length


@dataclass(frozen=True)
class FactEncoder:
    """The fluent facts of a query's state and the values they hold (:class:`FactFeatures`).

    The state part is: per fluent predicate seen in training, how many facts of it hold; then per
    fact pattern (``"on b1 stove"``, ``"at-pose b1 *"``: optimistic objects as ``*``; the
    :data:`MAX_FACT_KEYS` most frequent in training), how many facts of that pattern hold, and for
    each argument that holds a value, a mask bit (1: not bound yet) and the value's features.
    """

    predicates: tuple[str, ...]
    keys: tuple[tuple[str, tuple[_KeySlot, ...]], ...]
    codec: ValueCodec = field(repr=False, compare=False)
    _key_index: dict[str, int] = field(init=False, repr=False, compare=False)
    _key_offset: tuple[int, ...] = field(init=False, repr=False, compare=False)
    _pred_index: dict[str, int] = field(init=False, repr=False, compare=False)
    _width: int = field(init=False, repr=False, compare=False)
    _slots: tuple[tuple[tuple[_KeySlot, int], ...], ...] = field(
        init=False, repr=False, compare=False
    )
    _seen: dict[tuple[str, ...], tuple[int | None, int | None]] = field(
        init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        offsets = []
        at = len(self.predicates)
        for _, slots in self.keys:
            offsets.append(at)
            at += 1 + sum(1 + self._slot_width(s) for s in slots)
        object.__setattr__(self, "_key_index", {k: i for i, (k, _) in enumerate(self.keys)})
        object.__setattr__(self, "_key_offset", tuple(offsets))
        object.__setattr__(self, "_pred_index", {p: i for i, p in enumerate(self.predicates)})
        object.__setattr__(self, "_width", at)
        per_key = tuple(tuple((s, self._slot_width(s)) for s in ss) for _, ss in self.keys)
        object.__setattr__(self, "_slots", per_key)
        object.__setattr__(self, "_seen", {})

    def _slot_width(self, slot: _KeySlot) -> int:
        return 0 if slot.kind is None else self.codec.width(slot.kind, slot.size)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": FactFeatures.kind,
            "predicates": list(self.predicates),
            "keys": [
                [key, [[s.position, s.kind, s.size] for s in slots]] for key, slots in self.keys
            ],
        }

    @property
    def scene_width(self) -> int:
        return self._width

    def stream_width(self, stream: str) -> int:
        return 0

    def stream_features(
        self, stream: str, inputs: Sequence[JSON | None], context: Context
    ) -> Sequence[float]:
        return ()

    def _entry(self, fact: Any) -> tuple[int | None, int | None]:
        """A fact's predicate and pattern indices (None: not in the encoding); checked here, on
        the first sight of each fact, and remembered."""
        if not isinstance(fact, list) or not fact or not all(isinstance(a, str) for a in fact):
            raise FeatureError(f"context: malformed fact {fact!r}")
        entry = (self._pred_index.get(fact[0]), self._key_index.get(_fact_key(fact)))
        if len(self._seen) > MAX_SEEN_FACTS:
            self._seen.clear()
        self._seen[tuple(fact)] = entry
        return entry

    def scene_features(self, context: Context, out: FloatArray, offset: int) -> None:
        values = _values(context)
        facts = context.get("facts", [])
        if not isinstance(facts, list):
            raise FeatureError("context: expected {'facts': [...], 'values': {...}}")
        seen = self._seen
        for fact in facts:
            try:
                p, k = seen[tuple(fact)]
            except (KeyError, TypeError):
                p, k = self._entry(fact)
            if p is not None:
                out[offset + p] += 1.0
            if k is None:
                continue
            at = offset + self._key_offset[k]
            out[at] += 1.0
            at += 1
            for slot, width in self._slots[k]:
                name = fact[slot.position] if slot.position < len(fact) else None
                value = values.get(name) if name is not None else None
                if value is None or slot.kind is None or self.codec.kind_of(value) != slot.kind:
                    out[at] = 1.0  # not bound (or not of the kind seen in training)
                else:
                    out[at + 1 : at + 1 + width] = self.codec.features(
                        slot.kind, value, slot.size, "context value"
                    )
                at += 1 + width

    def finish_row(
        self,
        stream: str,
        inputs: Sequence[JSON | None],
        row: FloatArray,
        slots: Sequence[tuple[str, int, int]],
    ) -> None:
        return None

    def feature_names(self, stream: str) -> tuple[list[str], list[str]]:
        names = [f"n[{p}]" for p in self.predicates]
        for key, slots in self.keys:
            names.append(f"({key})")
            for s in slots:
                names.append(f"({key}).arg{s.position}.unbound")
                names += [
                    f"({key}).arg{s.position}.{s.kind}[{j}]" for j in range(self._slot_width(s))
                ]
        return [], names


class FactFeatures:
    """The default :class:`StateFeatures`: :class:`FactEncoder`, fit on the training queries'
    contexts (which patterns occur, what kind of value each argument holds)."""

    kind = "facts"

    def __init__(self, max_keys: int = MAX_FACT_KEYS) -> None:
        self.max_keys = max_keys

    def fit(self, records: Sequence[QueryLike], codec: ValueCodec) -> FactEncoder:
        predicates: set[str] = set()
        counts: Counter[str] = Counter()
        kinds: dict[str, dict[int, tuple[str | None, int]]] = {}
        for record in records:
            context = record.context
            values = _values(context)
            for fact in _facts(context):
                predicates.add(fact[0])
                key = _fact_key(fact)
                counts[key] += 1
                slots = kinds.setdefault(key, {})
                for i, arg in enumerate(fact[1:], start=1):
                    value = values.get(arg)
                    if value is None and not _is_optimistic(arg):
                        continue  # a problem object with no value: part of the pattern
                    kind = codec.kind_of(value) if value is not None else None
                    if kind == OPAQUE:
                        kind = None
                    size = len(value) if kind == "vector" and isinstance(value, list) else 0
                    known = slots.get(i)
                    if known is None or known[0] is None:
                        slots[i] = (kind, size)
        chosen = sorted(counts, key=lambda k: (-counts[k], k))[: self.max_keys]
        keys = tuple(
            (key, tuple(_KeySlot(i, kind, size) for i, (kind, size) in sorted(kinds[key].items())))
            for key in sorted(chosen)
        )
        return FactEncoder(tuple(sorted(predicates)), keys, codec)

    def load(self, data: Mapping[str, Any], codec: ValueCodec) -> FactEncoder:
        try:
            keys = tuple(
                (
                    str(key),
                    tuple(
                        _KeySlot(int(pos), None if kind is None else str(kind), int(size))
                        for pos, kind, size in slots
                    ),
                )
                for key, slots in data["keys"]
            )
            encoder = FactEncoder(tuple(str(p) for p in data["predicates"]), keys, codec)
        except (KeyError, TypeError, ValueError) as exc:
            raise FeatureError(f"malformed fact features: missing or bad field {exc}") from exc
        for _, slots in keys:
            for s in slots:
                builtin = s.kind is None or s.kind in ("number", "vector", "name")
                if not builtin and codec.value_type(str(s.kind)) is None:
                    raise FeatureError(
                        f"the model reads values of type {s.kind!r}, which this domain does "
                        f"not declare (its value types: {', '.join(codec.names) or 'none'})"
                    )
        return encoder


# --- the spec ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SlotSpec:
    """One input slot of a stream: its kind, the names seen in training (names) or the length
    (vectors)."""

    kind: str
    vocabulary: tuple[str, ...] = ()
    size: int = 0

    def __post_init__(self) -> None:
        if self.vocabulary and self.kind != "name":
            raise FeatureError(f"a {self.kind} slot has no vocabulary")
        if len(set(self.vocabulary)) != len(self.vocabulary):
            raise FeatureError(f"repeated names in vocabulary {list(self.vocabulary)}")
        if (self.kind == "vector") != (self.size > 0):
            raise FeatureError(f"a {self.kind} slot of size {self.size}: only vectors have one")


@dataclass(frozen=True)
class StreamLayout:
    stream: str
    slots: tuple[SlotSpec, ...]


@dataclass(frozen=True)
class FeatureSpec:
    """Everything needed to rebuild a featurizer: saved in the model file as :meth:`to_dict`."""

    streams: tuple[StreamLayout, ...]
    domain: str
    state: Mapping[str, Any]  # the state encoder's to_dict(), with its "kind"
    version: int = FEATURE_VERSION

    def __post_init__(self) -> None:
        names = [s.stream for s in self.streams]
        if len(set(names)) != len(names):
            raise FeatureError(f"a stream has two layouts: {names}")
        if not isinstance(self.state.get("kind"), str):
            raise FeatureError("the feature spec's state part names no kind")

    def layout(self, stream: str) -> StreamLayout | None:
        for layout in self.streams:
            if layout.stream == stream:
                return layout
        return None

    def to_dict(self) -> dict[str, Any]:
        return {
            "version": self.version,
            "domain": self.domain,
            "streams": {
                layout.stream: [
                    {"kind": s.kind, "vocabulary": list(s.vocabulary), "size": s.size}
                    for s in layout.slots
                ]
                for layout in self.streams
            },
            "state": dict(self.state),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> FeatureSpec:
        """The inverse of :meth:`to_dict`; a malformed dict raises :class:`FeatureError`."""
        try:
            streams = tuple(
                StreamLayout(
                    str(name),
                    tuple(
                        SlotSpec(
                            str(s["kind"]),
                            tuple(str(v) for v in s["vocabulary"]),
                            int(s.get("size", 0)),
                        )
                        for s in slots
                    ),
                )
                for name, slots in data["streams"].items()
            )
            return cls(
                streams=streams,
                domain=str(data["domain"]),
                state=dict(data["state"]),
                version=int(data["version"]),
            )
        except (KeyError, TypeError, AttributeError) as exc:
            raise FeatureError(f"malformed feature spec: missing or bad field {exc}") from exc


# --- the featurizer ------------------------------------------------------------------------------


def _state_features(domain: LoadedDomain) -> StateFeatures:
    hook = domain.spec.features
    return hook if hook is not None else FactFeatures()


class Featurizer:
    """Fixed-length float32 rows for stream queries, per stream, following a :class:`FeatureSpec`.

    A stream the spec has no layout for (never seen in training) gets the state part only.
    """

    def __init__(self, spec: FeatureSpec, codec: ValueCodec, state: StateEncoder) -> None:
        if spec.version != FEATURE_VERSION:
            raise FeatureError(
                f"feature spec version {spec.version}, this code computes version "
                f"{FEATURE_VERSION}: retrain the model"
            )
        self._spec = spec
        self._codec = codec
        self._state = state
        # The state part of the contexts featurized lately, by what they are made of (see
        # _scene_part).
        self._scene_parts: dict[tuple[Any, ...], tuple[Context, FloatArray]] = {}
        self._stream_parts: dict[tuple[Any, ...], tuple[Context, list[Any], FloatArray]] = {}
        self._slot_parts: dict[tuple[Any, ...], tuple[list[Any], FloatArray]] = {}
        self._layouts = {layout.stream: layout for layout in spec.streams}
        self._name_index = {
            layout.stream: [{v: i for i, v in enumerate(s.vocabulary)} for s in layout.slots]
            for layout in spec.streams
        }
        self._slot_widths = {
            layout.stream: [self._slot_width(s) for s in layout.slots] for layout in spec.streams
        }
        self._slot_places: dict[str, list[tuple[str, int, int]]] = {}
        for layout in spec.streams:
            at, places = 0, []
            for slot, width in zip(layout.slots, self._slot_widths[layout.stream], strict=True):
                places.append((slot.kind, at, width))
                at += width
            self._slot_places[layout.stream] = places
        self._where = {
            layout.stream: [f"stream {layout.stream!r} input {i}" for i in range(len(layout.slots))]
            for layout in spec.streams
        }
        for layout in spec.streams:  # every kind must be one this domain has
            for i, s in enumerate(layout.slots):
                if s.kind not in ("name", "number", "vector") and codec.value_type(s.kind) is None:
                    raise FeatureError(
                        f"stream {layout.stream!r} input {i}: the model reads values of type "
                        f"{s.kind!r}, which this domain does not declare (its value types: "
                        f"{', '.join(codec.names) or 'none'})"
                    )

    def _slot_width(self, slot: SlotSpec) -> int:
        """Mask bit plus features (a name: one-hot with an unknown bucket)."""
        if slot.kind == "name":
            return 2 + len(slot.vocabulary)
        return 1 + self._codec.width(slot.kind, slot.size)

    def __repr__(self) -> str:
        return f"Featurizer(domain={self._spec.domain!r}, streams={list(self.streams)})"

    @classmethod
    def fit(cls, records: Iterable[QueryLike], *, domain: LoadedDomain) -> Featurizer:
        """Learn each stream's slot kinds, name vocabularies and vector lengths, and fit the
        domain's state encoder, from recorded queries.

        The streams of ``DomainSpec.input_kinds`` always get a layout (kinds given by the
        domain), even with no records; another stream takes its slot kinds from the records
        that bind them.
        """
        records = list(records)
        codec = domain.codec
        kinds: dict[str, list[str | None]] = {
            s: list(k) for s, k in domain.spec.input_kinds.items()
        }
        sizes: dict[str, list[int]] = {s: [0] * len(k) for s, k in kinds.items()}
        names: dict[str, list[set[str]]] = {s: [set() for _ in k] for s, k in kinds.items()}
        known = ", ".join(("name", "number", "vector", *codec.names))
        for record in records:
            stream = record.stream
            if stream not in kinds:
                kinds[stream] = [None] * len(record.inputs)
                sizes[stream] = [0] * len(record.inputs)
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
                kind = codec.kind_of(value)
                if kind == OPAQUE:
                    raise FeatureError(
                        f"stream {stream!r} input {i}: values of Python type "
                        f"{value.get('python_type')} have no value type in domain "
                        f"{domain.name!r}: declare a ValueType for them (docs/domains.md)"
                    )
                if kind is None:
                    raise FeatureError(
                        f"stream {stream!r} input {i}: no features for value {value!r} "
                        f"(known kinds: {known})"
                    )
                if slots[i] is None:
                    slots[i] = kind
                elif slots[i] != kind:
                    raise FeatureError(
                        f"stream {stream!r} input {i}: expected a {slots[i]}, got a {kind}"
                    )
                if kind == "name":
                    names[stream][i].add(value)
                elif kind == "vector":
                    if sizes[stream][i] and sizes[stream][i] != len(value):
                        raise FeatureError(
                            f"stream {stream!r} input {i}: vectors of {sizes[stream][i]} and "
                            f"{len(value)} numbers"
                        )
                    sizes[stream][i] = len(value)
        layouts = []
        for stream in sorted(kinds):
            slots_spec = []
            for i, kind in enumerate(kinds[stream]):
                if kind is None:
                    raise FeatureError(f"stream {stream!r} input {i}: never bound in the records")
                vocab = tuple(sorted(names[stream][i])) if kind == "name" else ()
                slots_spec.append(SlotSpec(kind, vocab, sizes[stream][i]))
            layouts.append(StreamLayout(stream, tuple(slots_spec)))
        state = _state_features(domain).fit(records, codec)
        spec = FeatureSpec(streams=tuple(layouts), domain=domain.name, state=state.to_dict())
        return cls(spec, codec, state)

    @classmethod
    def from_spec(cls, data: Mapping[str, Any], *, domain: LoadedDomain) -> Featurizer:
        """Rebuild from :meth:`FeatureSpec.to_dict` (as stored in a model file)."""
        spec = FeatureSpec.from_dict(data)
        hook = _state_features(domain)
        kind = spec.state.get("kind")
        if kind != hook.kind:
            raise FeatureError(
                f"the model's state features are {kind!r}, domain {domain.name!r} computes "
                f"{hook.kind!r}: retrain the model"
            )
        return cls(spec, domain.codec, hook.load(spec.state, domain.codec))

    @property
    def spec(self) -> FeatureSpec:
        return self._spec

    @property
    def state(self) -> StateEncoder:
        return self._state

    @property
    def streams(self) -> tuple[str, ...]:
        return tuple(layout.stream for layout in self._spec.streams)

    @property
    def scene_width(self) -> int:
        return self._state.scene_width

    def scene_offset(self, stream: str) -> int:
        """Where the state part starts in the rows of ``stream``."""
        return self.width(stream) - self._state.scene_width

    def slots(self, stream: str) -> list[tuple[str, int]]:
        """``(kind, width)`` of each input slot of ``stream`` (mask bit included)."""
        layout = self._layouts.get(stream)
        if layout is None:
            return []
        return [(s.kind, w) for s, w in zip(layout.slots, self._slot_widths[stream], strict=True)]

    def width(self, stream: str) -> int:
        """Length of the rows of ``stream``."""
        slots = sum(self._slot_widths.get(stream, ()))
        return slots + self._state.stream_width(stream) + self._state.scene_width

    def feature_names(self, stream: str) -> list[str]:
        """A name for each column of ``stream``'s rows (for debugging and reports)."""
        out: list[str] = []
        layout = self._layouts.get(stream)
        for i, slot in enumerate(layout.slots if layout is not None else ()):
            out.append(f"in{i}.unbound")
            if slot.kind == "name":
                out += [f"in{i}.is_{v}" for v in slot.vocabulary] + [f"in{i}.is_unknown"]
            else:
                width = self._codec.width(slot.kind, slot.size)
                out += [f"in{i}.{slot.kind}[{j}]" for j in range(width)]
        stream_part, scene_part = self._state.feature_names(stream)
        return out + stream_part + scene_part

    def row(self, stream: str, inputs: Sequence[Any | None], context: Context) -> FloatArray:
        """The feature row of one query of ``stream`` (``None`` inputs are not bound yet).

        A row is put together from three parts, each computed once for what it reads and kept:
        the input slots by the input objects, the stream part by those and the context's
        make-up, the state part by the make-up (:func:`_makeup`). In a search most rows share
        all three with rows made before; contexts and inputs are read, never changed."""
        return self._row(stream, inputs, context, _makeup(context))

    def _row(
        self,
        stream: str,
        inputs: Sequence[Any | None],
        context: Context,
        makeup: tuple[Any, ...],
    ) -> FloatArray:
        layout = self._layouts.get(stream)
        parts: list[FloatArray] = []
        if layout is not None:
            if len(inputs) != len(layout.slots):
                raise FeatureError(
                    f"stream {stream!r} takes {len(layout.slots)} inputs, got {len(inputs)}"
                )
            parts.append(self._slots_part(stream, layout, inputs))
        if self._state.stream_width(stream):
            parts.append(self._stream_part(stream, inputs, context, makeup))
        parts.append(self._scene_part(context, makeup))
        out = np.concatenate(parts)
        if layout is not None:
            self._state.finish_row(stream, inputs, out, self._slot_places[stream])
        return out

    def _slots_part(
        self, stream: str, layout: StreamLayout, inputs: Sequence[Any | None]
    ) -> FloatArray:
        """The input slots of a row, computed once per stream and input objects (kept with
        them, so their ids are not reused)."""
        key = (stream, *map(id, inputs))
        hit = self._slot_parts.get(key)
        if hit is not None:
            return hit[1]
        widths = self._slot_widths[stream]
        wheres = self._where[stream]
        out = np.zeros(sum(widths), dtype=np.float32)
        offset = 0
        for i, slot in enumerate(layout.slots):
            value = inputs[i]
            if value is None:
                out[offset] = 1.0  # unbound: mask bit set, features stay zero
            elif slot.kind == "name":
                if not isinstance(value, str):
                    raise FeatureError(f"{wheres[i]}: expected a name, got {value!r}")
                index = self._name_index[stream][i].get(value, len(slot.vocabulary))
                out[offset + 1 + index] = 1.0
            else:
                features = self._codec.features(slot.kind, value, slot.size, wheres[i])
                out[offset + 1 : offset + 1 + len(features)] = features
            offset += widths[i]
        if len(self._slot_parts) >= MAX_SEEN_CONTEXTS:
            self._slot_parts.clear()
        self._slot_parts[key] = (list(inputs), out)
        return out

    def _scene_part(self, context: Context, makeup: tuple[Any, ...]) -> FloatArray:
        """The state part of ``context``'s rows, computed once per make-up of the context
        (:func:`_makeup`). A search's contexts share their objects: one facts list per state
        (planner.search.queries), each bound value encoded once, so a state part is computed
        again only where a binding changed it. The first context of a make-up is kept with its
        part, which keeps its objects, so their ids are not reused; contexts are read, never
        changed."""
        hit = self._scene_parts.get(makeup)
        if hit is not None:
            return hit[1]
        part = np.zeros(self._state.scene_width, dtype=np.float32)
        self._state.scene_features(context, part, 0)
        if len(self._scene_parts) >= MAX_SEEN_CONTEXTS:
            self._scene_parts.clear()
        self._scene_parts[makeup] = (context, part)
        return part

    def _stream_part(
        self,
        stream: str,
        inputs: Sequence[Any | None],
        context: Context,
        makeup: tuple[Any, ...],
    ) -> FloatArray:
        """The stream part of a row, computed once per stream, input objects and make-up of
        the context (as :meth:`_scene_part`; the inputs are kept with it too)."""
        key = (stream, *map(id, inputs), makeup)
        hit = self._stream_parts.get(key)
        if hit is not None:
            return hit[2]
        part = np.asarray(self._state.stream_features(stream, inputs, context), dtype=np.float32)
        if len(part) != self._state.stream_width(stream):
            raise FeatureError(
                f"stream {stream!r}: the state features gave a stream part of {len(part)} "
                f"numbers, expected {self._state.stream_width(stream)}"
            )
        if len(self._stream_parts) >= MAX_SEEN_CONTEXTS:
            self._stream_parts.clear()
        self._stream_parts[key] = (context, list(inputs), part)
        return part

    def matrix(
        self, stream: str, queries: Iterable[tuple[Sequence[Any | None], Context]]
    ) -> FloatArray:
        """Rows of many ``(inputs, context)`` queries of one stream, shape ``(n, width)``.
        Queries made in one state share a context object: its make-up is read once."""
        makeups: dict[int, tuple[Any, ...]] = {}  # by context object, alive during the call
        rows = []
        for inputs, context in queries:
            makeup = makeups.get(id(context))
            if makeup is None:
                makeup = makeups[id(context)] = _makeup(context)
            rows.append(self._row(stream, inputs, context, makeup))
        if not rows:
            return np.zeros((0, self.width(stream)), dtype=np.float32)
        return np.stack(rows)

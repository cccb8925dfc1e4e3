"""Value types: how a domain's Python values (poses, grasps, trajectories) become JSON and features.

Samplers work on Python objects; everything that leaves a run works on JSON: events, the store,
plan files, REST, the page's inspector, and the feature rows of the learned models (which are
computed from the stored JSON, so a model trains on exactly what was recorded). A domain declares
one :class:`ValueType` per kind of value its samplers produce; :class:`ValueCodec` combines them
with the built-in kinds:

- ``name``: a string (a problem object such as ``b1`` or ``stove``), JSON as itself;
- ``number``: an int or float (not bool), JSON as itself, one feature;
- ``vector``: a tuple, list or 1-D numpy array of numbers, JSON as a list, one feature a number
  (the length is learned when a model is fit).

A declared type's JSON is an object ``{"type": NAME, ...}``; ``NAME`` is how the JSON is told
apart when it is read back. A value of a Python type that no value type covers is stored as
``{"type": "opaque", "python_type": ..., "repr": ...}`` (planning goes on, a warning names the
type once); it cannot be read back or used as a model input, and the errors say so.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

log = logging.getLogger(__name__)

JSON = Any  # a JSON value: str, int, float, bool, None, lists and str-keyed dicts of them
BUILTIN_KINDS = ("name", "number", "vector")  # kinds every domain has (see the module docstring)
OPAQUE = "opaque"  # the "type" of a value no value type covers
RESERVED = (*BUILTIN_KINDS, OPAQUE, "none")  # names a domain's value type may not take


class ValueDataError(ValueError):
    """Base of the value errors (a ValueError, so the CLI reports it in one line)."""


class ValueTypeError(ValueDataError):
    """A value type is declared wrongly (no codec, no encoder, a reserved or repeated name)."""


class ValueDecodeError(ValueDataError):
    """JSON that does not decode to a value; the message names where it is (``values.opt-p3``)."""


class FeatureError(ValueDataError):
    """A value or a feature spec does not fit; the message names the stream, slot or field."""


@dataclass(frozen=True)
class ValueType:
    """One kind of value of a domain, with its JSON codec and its feature encoder.

    ``encode`` gives the JSON fields of a value (without ``"type"``, which the codec adds);
    ``decode`` reads those fields back (the dict it gets still holds ``"type"``); ``features``
    reads the same JSON dict and returns exactly ``width`` numbers for the learned models (keep
    them of order 1: metres, cosines and sines of angles, 0/1 flags). ``label`` is an optional
    one-line description for the dashboard's inspector.
    """

    name: str
    python_type: type | tuple[type, ...]
    encode: Callable[[Any], Mapping[str, JSON]]
    decode: Callable[[Mapping[str, JSON]], Any]
    features: Callable[[Mapping[str, JSON]], Sequence[float]]
    width: int
    label: Callable[[Mapping[str, JSON]], str] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise ValueTypeError(f"value type name {self.name!r} is not an identifier")
        if self.name in RESERVED:
            raise ValueTypeError(
                f"value type {self.name!r}: the name is reserved ({', '.join(RESERVED)})"
            )
        missing = [
            part
            for part, fn in (("encode", self.encode), ("decode", self.decode))
            if not callable(fn)
        ]
        if missing:
            verb = "must be functions" if len(missing) > 1 else "must be a function"
            raise ValueTypeError(
                f"value type {self.name!r} has no codec: {' and '.join(missing)} {verb} "
                "(encode: the JSON fields of a value; decode: a value from its JSON)"
            )
        if not callable(self.features):
            raise ValueTypeError(
                f"value type {self.name!r} has no feature encoder: features must be a function "
                "from its JSON to `width` numbers (the learned models read it)"
            )
        if isinstance(self.width, bool) or not isinstance(self.width, int) or self.width < 1:
            raise ValueTypeError(f"value type {self.name!r}: width must be >= 1, got {self.width}")
        kinds = self.python_type if isinstance(self.python_type, tuple) else (self.python_type,)
        if not kinds or not all(isinstance(k, type) for k in kinds):
            raise ValueTypeError(
                f"value type {self.name!r}: python_type must be a class or a tuple of classes"
            )


@dataclass
class ValueCodec:
    """The built-in kinds plus a domain's value types (see the module docstring)."""

    types: tuple[ValueType, ...] = ()
    _by_name: dict[str, ValueType] = field(init=False, repr=False)
    _by_class: dict[type, ValueType | None] = field(init=False, repr=False)
    _warned: set[str] = field(init=False, repr=False, default_factory=set)

    def __post_init__(self) -> None:
        self._by_name = {}
        for vt in self.types:
            if not isinstance(vt, ValueType):
                raise ValueTypeError(f"expected a ValueType, got {type(vt).__name__}: {vt!r}")
            if vt.name in self._by_name:
                raise ValueTypeError(f"two value types are called {vt.name!r}")
            self._by_name[vt.name] = vt
        self._by_class = {}

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._by_name)

    def value_type(self, name: str) -> ValueType | None:
        return self._by_name.get(name)

    def _type_of(self, value: Any) -> ValueType | None:
        cls = type(value)
        if cls not in self._by_class:
            found = None
            for vt in self.types:
                if isinstance(value, vt.python_type):
                    found = vt
                    break
            self._by_class[cls] = found
        return self._by_class[cls]

    # --- JSON ------------------------------------------------------------------------------------

    def encode(self, value: Any) -> JSON:
        """A value as JSON (strings stay strings, numbers numbers, sequences lists)."""
        if value is None or isinstance(value, str | bool | int):
            return value
        if isinstance(value, float):
            return value
        vt = self._type_of(value)
        if vt is not None:
            return {"type": vt.name, **vt.encode(value)}
        if isinstance(value, list | tuple):
            return [self.encode(v) for v in value]
        tolist = getattr(value, "tolist", None)  # numpy arrays and scalars
        if callable(tolist) and type(value).__module__.startswith("numpy"):
            return self.encode(tolist())
        return self._opaque(value)

    def _opaque(self, value: Any) -> JSON:
        qualname = f"{type(value).__module__}.{type(value).__qualname__}"
        if qualname not in self._warned:
            self._warned.add(qualname)
            log.warning(
                "values of type %s have no value type: they are stored as text, cannot be read "
                "back and give no model features (declare a ValueType in the domain)",
                qualname,
            )
        return {"type": OPAQUE, "python_type": qualname, "repr": repr(value)[:200]}

    def decode(self, data: JSON, where: str) -> Any:
        """The value of ``data`` (as :meth:`encode` made it); :class:`ValueDecodeError` names
        ``where`` and what is wrong."""
        if data is None or isinstance(data, str | bool | int | float):
            return data
        if isinstance(data, list):
            return tuple(self.decode(v, f"{where}[{i}]") for i, v in enumerate(data))
        if not isinstance(data, dict):
            raise ValueDecodeError(f"{where}: expected JSON data, got {type(data).__name__}")
        kind = data.get("type")
        if kind == OPAQUE:
            raise ValueDecodeError(
                f"{where}: a value of {data.get('python_type', 'an unknown type')} was stored as "
                "text (its domain declares no value type for it) and cannot be read back"
            )
        vt = self._by_name.get(kind) if isinstance(kind, str) else None
        if vt is None:
            known = ", ".join(self._by_name) or "none"
            raise ValueDecodeError(f"{where}.type: unknown value type {kind!r} (known: {known})")
        try:
            return vt.decode(data)
        except ValueDecodeError:
            raise
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise ValueDecodeError(f"{where}: malformed {kind}: {exc}") from exc

    # --- features --------------------------------------------------------------------------------

    def kind_of(self, data: JSON) -> str | None:
        """The kind of a JSON value: a built-in kind, a declared type's name, ``opaque``, or
        None for JSON no kind describes (null, a list of non-numbers, an unknown type)."""
        if isinstance(data, str):
            return "name"
        if isinstance(data, bool) or data is None:
            return None
        if isinstance(data, int | float):
            return "number"
        if isinstance(data, list):
            ok = all(isinstance(v, int | float) and not isinstance(v, bool) for v in data)
            return "vector" if data and ok else None
        if isinstance(data, dict):
            kind = data.get("type")
            if kind == OPAQUE:
                return OPAQUE
            return kind if isinstance(kind, str) and kind in self._by_name else None
        return None

    def width(self, kind: str, size: int = 0) -> int:
        """Feature width of a kind (``size``: a vector's length, learned when fitting)."""
        if kind == "number":
            return 1
        if kind == "vector":
            return size
        vt = self._by_name.get(kind)
        if vt is None:
            raise ValueTypeError(f"no value type {kind!r} (known: {', '.join(self.names)})")
        return vt.width

    def features(self, kind: str, data: JSON, size: int, where: str) -> list[float]:
        """The feature numbers of one JSON value of ``kind``; a mismatch names ``where``."""
        if kind == "number":
            if isinstance(data, bool) or not isinstance(data, int | float):
                raise FeatureError(f"{where}: expected a number, got {_short(data)}")
            return [_finite(float(data), where)]
        if kind == "vector":
            if not isinstance(data, list) or len(data) != size:
                raise FeatureError(
                    f"{where}: expected a list of {size} numbers, got {_short(data)}"
                )
            try:
                return [_finite(float(v), where) for v in data]
            except (TypeError, ValueError) as exc:
                raise FeatureError(f"{where}: expected numbers, got {_short(data)}") from exc
        vt = self._by_name.get(kind)
        if vt is None:
            raise FeatureError(f"{where}: no value type {kind!r} in this domain")
        if not isinstance(data, dict) or data.get("type") != kind:
            raise FeatureError(f"{where}: expected a {kind}, got {_short(data)}")
        try:
            out = [float(v) for v in vt.features(data)]
        except FeatureError:
            raise
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise FeatureError(f"{where}: malformed {kind} {_short(data)}: {exc}") from exc
        if len(out) != vt.width:
            raise FeatureError(
                f"value type {kind!r}: features gave {len(out)} numbers, its width is {vt.width}"
            )
        return out

    def label(self, data: JSON) -> str:
        """A short description of a JSON value for people (the inspector)."""
        kind = self.kind_of(data)
        vt = self._by_name.get(kind) if kind is not None else None
        if vt is not None and vt.label is not None:
            try:
                return vt.label(data)
            except (KeyError, TypeError, ValueError, IndexError):
                pass
        if isinstance(data, float):
            return f"{data:.4g}"
        if kind == "vector":
            return "(" + ", ".join(f"{float(v):.3g}" for v in data) + ")"
        return _short(data, 80)


def _finite(value: float, where: str) -> float:
    if not math.isfinite(value):
        raise FeatureError(f"{where}: {value} is not a finite number")
    return value


def _short(data: JSON, n: int = 120) -> str:
    text = repr(data)
    return text if len(text) <= n else text[: n - 3] + "..."


def numbers(data: JSON, n: int, where: str) -> list[float]:
    """``n`` numbers from a JSON list (for value types' codecs and encoders)."""
    if not isinstance(data, list) or len(data) != n:
        raise ValueDecodeError(f"{where}: expected a list of {n} numbers, got {_short(data)}")
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in data):
        raise ValueDecodeError(f"{where}: expected numbers, got {_short(data)}")
    return [float(v) for v in data]


# --- Python shapes: what a JSON value was in Python, where decoding alone would not say -------


def python_shape(value: Any) -> JSON:
    """What :meth:`ValueCodec.decode` cannot tell from a value's JSON: that it was a numpy array
    (``"ndarray:float64"``), a list (``["list", [item shapes]]``) or a tuple holding such
    (``["tuple", [...]]``); None where decoding gives the value back as it was (names,
    numbers, tuples of them, a declared value type's values). Plan files keep it beside the
    JSON, so a validator gets back the numpy arrays and lists its samplers made."""
    if value is None or isinstance(value, str | bool | int | float):
        return None
    if type(value).__module__.startswith("numpy") and hasattr(value, "dtype"):
        if getattr(value, "ndim", 0) == 0:
            return f"scalar:{value.dtype}"
        return f"ndarray:{value.dtype}"
    if isinstance(value, list | tuple):
        items = [python_shape(v) for v in value]
        if isinstance(value, tuple) and all(i is None for i in items):
            return None
        return [type(value).__name__, items]
    return None


def restore(value: Any, shape: JSON, where: str) -> Any:
    """``value`` (as decoded) made again what :func:`python_shape` said it was."""
    if shape is None:
        return value
    if isinstance(shape, str) and shape.partition(":")[0] in ("ndarray", "scalar"):
        import numpy as np  # only where a plan holds numpy values

        kind, _, dtype = shape.partition(":")
        try:
            array = np.asarray(value, dtype=np.dtype(dtype))
        except (TypeError, ValueError) as exc:
            raise ValueDecodeError(f"{where}: not a numpy {dtype} value: {exc}") from exc
        return array[()] if kind == "scalar" else array
    if (
        isinstance(shape, list)
        and len(shape) == 2
        and shape[0] in ("list", "tuple")
        and isinstance(shape[1], list)
        and isinstance(value, tuple | list)
        and len(shape[1]) == len(value)
    ):
        pairs = enumerate(zip(value, shape[1], strict=True))
        items = [restore(v, s, f"{where}[{i}]") for i, (v, s) in pairs]
        return items if shape[0] == "list" else tuple(items)
    raise ValueDecodeError(f"{where}: its Python shape {_short(shape)} does not fit the value")


def check_value_types(types: Iterable[Any], where: str) -> tuple[ValueType, ...]:
    """The value types of a domain, each checked; the error names ``where`` (the domain)."""
    out = []
    for i, vt in enumerate(types):
        if not isinstance(vt, ValueType):
            raise ValueTypeError(
                f"{where}: value_types[{i}] is a {type(vt).__name__}, expected a ValueType "
                "(name, python_type, encode, decode, features, width)"
            )
        out.append(vt)
    ValueCodec(tuple(out))  # repeated names
    return tuple(out)

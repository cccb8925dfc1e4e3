"""Adapters that bind a Python callable to a declared stream.

Three kinds, as in PDDLStream's ``from_fn``/``from_gen_fn``/``from_test``:

- :func:`from_fn`: ``fn(*inputs) -> tuple | None``; every query calls it again (a sampler).
- :func:`from_gen_fn`: ``gen_fn(*inputs) -> Iterator[tuple]``; every query takes the next item
  of one generator per input binding; an exhausted generator is a failed query.
- :func:`from_test`: ``test(*inputs) -> bool``; a stream with no outputs.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Iterator
from dataclasses import dataclass, field
from typing import Any, Literal

AdapterKind = Literal["fn", "gen", "test"]
Outputs = tuple[Any, ...]


@dataclass
class StreamAdapter:
    """A callable behind a stream name; ``next_outputs`` answers one query."""

    kind: AdapterKind
    fn: Callable[..., Any]
    _generators: dict[Hashable, Iterator[Any]] = field(default_factory=dict, repr=False)

    def next_outputs(self, inputs: tuple[Any, ...], key: Hashable) -> Outputs | None:
        """One query: the outputs, or ``None`` for a failure. May raise (the runtime records it)."""
        if self.kind == "test":
            return () if bool(self.fn(*inputs)) else None
        if self.kind == "fn":
            out = self.fn(*inputs)
            return None if out is None else tuple(out)
        gen = self._generators.get(key)
        if gen is None:
            gen = iter(self.fn(*inputs))
            self._generators[key] = gen
        try:
            out = next(gen)
        except StopIteration:
            return None
        return None if out is None else tuple(out)

    @property
    def callable_name(self) -> str:
        return getattr(self.fn, "__qualname__", repr(self.fn))


def from_fn(fn: Callable[..., tuple[Any, ...] | None]) -> StreamAdapter:
    """A function returning one output tuple, or ``None`` when it fails."""
    return StreamAdapter("fn", fn)


def from_gen_fn(gen_fn: Callable[..., Any]) -> StreamAdapter:
    """A generator function yielding output tuples."""
    return StreamAdapter("gen", gen_fn)


def from_test(test: Callable[..., bool]) -> StreamAdapter:
    """A boolean test for a stream with no outputs."""
    return StreamAdapter("test", test)

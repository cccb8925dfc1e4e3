"""Binding declared streams to Python callables, and timed, failure-safe queries."""

from __future__ import annotations

import logging
import time
from collections.abc import Hashable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

from planner.pddl.structs import Stream, StreamSet
from planner.streams.adapters import Failure, Outputs, StreamAdapter, StreamContext

log = logging.getLogger(__name__)


class StreamBindingError(Exception):
    """A declared stream has no binding, or a binding names an undeclared stream."""

    def __init__(self, message: str, *, stream: str, file: str) -> None:
        self.stream = stream
        self.file = file
        super().__init__(message)


@runtime_checkable
class Timed(Protocol):
    """An output that takes time to execute (a trajectory): its duration in seconds."""

    @property
    def seconds(self) -> float: ...


@dataclass(frozen=True)
class QueryResult:
    """One stream query: outputs (``None`` on failure) and what it cost."""

    stream: str
    outputs: Outputs | None
    wall_s: float
    cpu_s: float
    error: str | None = None  # set when the sampler raised or returned a malformed result
    reused: bool = False  # the outputs of an identical earlier query; no sampler ran
    reason: str | None = None  # why the sampler found nothing, when it said (a Failure)

    @property
    def execution_s(self) -> float:
        """Seconds to execute what the query produced (trajectories); 0 if nothing moves."""
        if self.outputs is None:
            return 0.0
        return sum(float(o.seconds) for o in self.outputs if isinstance(o, Timed))

    @property
    def success(self) -> bool:
        return self.outputs is not None


@dataclass(frozen=True)
class BoundStream:
    declaration: Stream
    adapter: StreamAdapter


def bind_streams(streams: StreamSet, bindings: Mapping[str, StreamAdapter]) -> StreamRuntime:
    """Check that declarations and bindings match one to one, then build the runtime."""
    for name in streams.names:
        if name not in bindings:
            raise StreamBindingError(
                f"{streams.source}: stream {name!r} is declared but has no Python binding",
                stream=name,
                file=streams.source,
            )
    for name, adapter in bindings.items():
        if name not in streams.names:
            raise StreamBindingError(
                f"a binding is given for stream {name!r}, but {streams.source} declares no such "
                f"stream (declared: {', '.join(streams.names)})",
                stream=name,
                file=streams.source,
            )
        decl = streams.stream(name)
        if adapter.kind == "test" and not decl.is_test:
            raise StreamBindingError(
                f"{streams.source}: stream {name!r} has outputs "
                f"{' '.join(decl.output_names)} but is bound to a boolean test",
                stream=name,
                file=streams.source,
            )
    return StreamRuntime({n: BoundStream(streams.stream(n), bindings[n]) for n in streams.names})


class StreamRuntime:
    """Answers stream queries; a sampler that raises is a failed query, never a crash."""

    def __init__(self, streams: Mapping[str, BoundStream]) -> None:
        self._streams = dict(streams)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._streams)

    def declaration(self, name: str) -> Stream:
        return self._bound(name).declaration

    def _bound(self, name: str) -> BoundStream:
        try:
            return self._streams[name]
        except KeyError:
            raise KeyError(f"unknown stream {name!r} (known: {', '.join(self._streams)})") from None

    def query(
        self,
        name: str,
        inputs: tuple[Any, ...],
        *,
        key: Hashable = None,
        context: StreamContext | None = None,
    ) -> QueryResult:
        """Query stream ``name`` once on input values; ``key`` identifies the input binding."""
        bound = self._bound(name)
        decl = bound.declaration
        if len(inputs) != len(decl.inputs):
            raise ValueError(
                f"stream {name} takes {len(decl.inputs)} inputs, {len(inputs)} were given"
            )
        t_wall, t_cpu = time.perf_counter(), time.process_time()
        error: str | None = None
        reason: str | None = None
        outputs: Outputs | None
        try:
            answer = bound.adapter.next_outputs(inputs, key if key is not None else inputs, context)
            if isinstance(answer, Failure):
                outputs, reason = None, str(answer.reason)  # stored as text, whatever it was
            else:
                outputs = answer
        except Exception as exc:  # a sampler's failure is data, not a crash
            outputs = None
            error = f"{type(exc).__name__}: {exc}"
            log.warning("stream %s raised %s", name, error)
        wall, cpu = time.perf_counter() - t_wall, time.process_time() - t_cpu
        if outputs is not None and len(outputs) != len(decl.outputs):
            error = (
                f"stream {name} returned {len(outputs)} outputs, "
                f"its declaration has {len(decl.outputs)}"
            )
            log.warning(error)
            outputs = None
        return QueryResult(name, outputs, wall, cpu, error, reason=reason)

"""Binding declared streams to Python callables, and timed, failure-safe queries."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

from planner.pddl.structs import Stream, StreamFunction, StreamSet
from planner.streams.adapters import (
    Failure,
    Last,
    Outputs,
    StreamAdapter,
    StreamContext,
    from_function,
    from_test,
    value_key,
)

log = logging.getLogger(__name__)


class StreamBindingError(Exception):
    """A declared stream has no binding, or a binding names an undeclared stream."""

    def __init__(self, message: str, *, stream: str, file: str) -> None:
        self.stream = stream
        self.file = file
        super().__init__(message)


class FunctionValueError(ValueError):
    """A stream function returned something that is not a non-negative number."""


# Seconds to execute what a stream produced: (stream name, its outputs) -> seconds.
Durations = Callable[[str, tuple[Any, ...]], float]


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
    cpu_s: float  # of the thread that ran the sampler
    error: str | None = None  # set when the sampler raised or returned a malformed result
    reused: bool = False  # the outputs of an identical earlier query; no sampler ran
    reason: str | None = None  # why the sampler found nothing, when it said (a Failure)
    # The stream will find nothing more for these inputs: a Failure's word, or a success that
    # was the last (an adapters.Last: a PDDLStream function's one output).
    exhausted: bool = False
    # Seconds to execute the outputs, from the domain's DomainSpec.execution_s; None: the
    # outputs' own ``seconds`` properties.
    duration_s: float | None = None

    @property
    def execution_s(self) -> float:
        """Seconds to execute what the query produced (trajectories); 0 if nothing moves."""
        if self.outputs is None:
            return 0.0
        if self.duration_s is not None:
            return self.duration_s
        # isinstance(o, Timed) asks just this, at a hundred times the cost (typing's protocol
        # check); a search reads it twice a query.
        return sum(float(o.seconds) for o in self.outputs if hasattr(o, "seconds"))

    @property
    def success(self) -> bool:
        return self.outputs is not None


@dataclass(frozen=True)
class BoundStream:
    declaration: Stream
    adapter: StreamAdapter


def _rule_test(*inputs: Any) -> bool:
    """A rule's test: its certified facts follow from its domain, always."""
    return True


def _as_adapters(
    streams: StreamSet,
    bindings: Mapping[str, StreamAdapter | Callable[..., Any]],
    *,
    strict: bool,
) -> dict[str, StreamAdapter]:
    """PDDLStream's stream-map conventions: names match case-insensitively, a
    ``(:function ...)`` or ``(:predicate ...)`` may be a plain Python function, and an entry
    the stream file never declares is left out (PDDLStream ignores it; ``strict`` refuses it)."""
    functions = {f.name for f in streams.functions}
    lazy = {s.name for s in streams.streams if s.kind == "predicate"}
    declared = set(streams.binding_names) | {s.name for s in streams.streams}
    out: dict[str, StreamAdapter] = {}
    for raw, binding in bindings.items():
        name = raw.lower() if isinstance(raw, str) else raw
        if name in out:
            raise StreamBindingError(
                f"two bindings for stream {name!r} (names ignore case)",
                stream=name,
                file=streams.source,
            )
        if name not in declared:
            _undeclared(streams, raw, name, strict=strict)
            continue
        if not isinstance(binding, StreamAdapter):
            if not callable(binding):
                raise StreamBindingError(
                    f"the binding of {raw!r} is a {type(binding).__name__}, not a stream "
                    "adapter (from_gen_fn, from_fn, from_test, ...) or a function",
                    stream=name,
                    file=streams.source,
                )
            if name in functions:
                binding = from_function(binding)
            elif name in lazy:
                binding = from_test(binding)
            else:
                raise StreamBindingError(
                    f"{streams.source}: stream {name!r} is bound to a plain function; wrap it "
                    "in an adapter that says how it answers (from_gen_fn, from_fn, from_test; "
                    "planner.streams.pddlstream for PDDLStream's)",
                    stream=name,
                    file=streams.source,
                )
        out[name] = binding
    return out


_told: set[tuple[str, str]] = set()  # (stream file, entry) already logged in this process


def _undeclared(streams: StreamSet, raw: Any, name: Any, *, strict: bool) -> None:
    """A stream-map entry that names nothing in the stream file: PDDLStream ignores it (a
    helper kept in the map, such as a collision check the tests call), so it is left out with
    one warning; a strict domain refuses it."""
    needed = ", ".join(streams.binding_names) or "none"
    if strict:
        raise StreamBindingError(
            f"a binding is given for stream {name!r}, but {streams.source} declares no such "
            f"stream (declared: {needed}); PDDLStream ignores such an entry, a strict domain "
            "refuses it",
            stream=str(name),
            file=streams.source,
        )
    if (streams.source, str(name)) not in _told:
        _told.add((streams.source, str(name)))
        log.warning(
            "stream map entry %r is left out: %s declares no stream, function or predicate "
            "of that name (declared: %s); PDDLStream ignores it too",
            raw,
            streams.source,
            needed,
        )


def bind_streams(
    streams: StreamSet,
    bindings: Mapping[str, StreamAdapter | Callable[..., Any]],
    *,
    strict: bool = False,
    durations: Durations | None = None,
) -> StreamRuntime:
    """Check that declarations and bindings match one to one, then build the runtime.

    Streams, lazily evaluated predicates and functions each need a binding (a predicate a
    boolean test, a function :func:`~planner.streams.adapters.from_function`, or for either a
    plain function, as PDDLStream's stream maps have them); rules need none. Names match
    case-insensitively. An entry naming nothing the stream file declares is left out with a
    warning, as PDDLStream does; with ``strict`` (a strict domain's) it is an error.
    ``durations`` says how long outputs take to execute (``DomainSpec.execution_s``).
    """
    bindings = _as_adapters(streams, bindings, strict=strict)
    needed = streams.binding_names
    for name in needed:
        if name not in bindings:
            raise StreamBindingError(
                f"{streams.source}: stream {name!r} is declared but has no Python binding",
                stream=name,
                file=streams.source,
            )
    rules = {s.name for s in streams.streams if s.kind == "rule"}
    for name, adapter in bindings.items():
        if name in rules:
            raise StreamBindingError(
                f"{streams.source}: {name!r} is a rule; rules need no Python binding",
                stream=name,
                file=streams.source,
            )
        _check_kind(streams, name, adapter)
    bound = {
        s.name: BoundStream(s, bindings[s.name] if s.kind != "rule" else from_test(_rule_test))
        for s in streams.streams
    }
    functions = {f.name: (f, bindings[f.name]) for f in streams.functions}
    return StreamRuntime(bound, functions, durations=durations)


def _check_kind(streams: StreamSet, name: str, adapter: StreamAdapter) -> None:
    def refuse(message: str) -> StreamBindingError:
        return StreamBindingError(f"{streams.source}: {message}", stream=name, file=streams.source)

    if name in {f.name for f in streams.functions}:
        if adapter.kind != "function":
            raise refuse(f"{name!r} is a (:function ...); bind it with from_function")
        return
    if adapter.kind == "function":
        raise refuse(f"{name!r} is a stream, not a (:function ...); from_function is for those")
    decl = streams.stream(name)
    if decl.kind == "predicate" and adapter.kind != "test":
        raise refuse(f"{name!r} is a (:predicate ...); bind it to a boolean test (from_test)")
    if adapter.kind == "test" and not decl.is_test:
        raise refuse(
            f"stream {name!r} has outputs {' '.join(decl.output_names)} but is bound to a "
            "boolean test"
        )


class StreamRuntime:
    """Answers stream queries; a sampler that raises is a failed query, never a crash.

    Also evaluates the stream file's numeric functions (:meth:`evaluate`)."""

    def __init__(
        self,
        streams: Mapping[str, BoundStream],
        functions: Mapping[str, tuple[StreamFunction, StreamAdapter]] | None = None,
        *,
        durations: Durations | None = None,
    ) -> None:
        self._streams = dict(streams)
        self._functions = dict(functions or {})
        self._durations = durations

    def execution_seconds(self, name: str, outputs: Sequence[Any]) -> float:
        """Seconds to execute what stream ``name`` produced: the domain's
        ``DomainSpec.execution_s`` when it has one, else the outputs' ``seconds`` properties
        (0 when none has one)."""
        if self._durations is not None:
            seconds = self._durations(name, tuple(outputs))
            if isinstance(seconds, bool) or not isinstance(seconds, int | float):
                raise FunctionValueError(
                    f"execution_s of stream {name} gave {seconds!r}, not a number of seconds"
                )
            if not seconds >= 0 or seconds == float("inf"):
                raise FunctionValueError(
                    f"execution_s of stream {name} gave {seconds}; seconds are finite and "
                    "non-negative"
                )
            return float(seconds)
        return sum(float(o.seconds) for o in outputs if hasattr(o, "seconds"))

    @property
    def times_outputs(self) -> bool:
        """Whether the domain says how long outputs take (DomainSpec.execution_s)."""
        return self._durations is not None

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._streams)

    @property
    def function_names(self) -> tuple[str, ...]:
        return tuple(self._functions)

    def declaration(self, name: str) -> Stream:
        return self._bound(name).declaration

    def _bound(self, name: str) -> BoundStream:
        try:
            return self._streams[name]
        except KeyError:
            raise KeyError(f"unknown stream {name!r} (known: {', '.join(self._streams)})") from None

    def _function(self, name: str) -> tuple[StreamFunction, StreamAdapter]:
        try:
            return self._functions[name]
        except KeyError:
            known = ", ".join(self._functions) or "none"
            raise KeyError(f"unknown function {name!r} (known: {known})") from None

    def state_reads(self) -> dict[str, frozenset[str]]:
        """Per stream whose sampler cannot read the whole state, the fluents it reads: its
        declared ``:fluents`` (none for most PDDLStream streams, which read only their inputs).
        A stream bound with ``context=True`` reads the whole state and is not listed."""
        return {
            name: frozenset(bound.declaration.fluents)
            for name, bound in self._streams.items()
            if not bound.adapter.uses_context
        }

    def lower_bound(self, name: str) -> float:
        """What planning assumes function ``name`` is worth before its inputs are bound."""
        return self._function(name)[1].lower_bound

    def evaluate(self, name: str, inputs: tuple[Any, ...]) -> float:
        """The value of function ``name`` on bound input values (non-negative)."""
        decl, adapter = self._function(name)
        if len(inputs) != len(decl.inputs):
            raise ValueError(
                f"function {name} takes {len(decl.inputs)} inputs, {len(inputs)} were given"
            )
        value = adapter.fn(*inputs)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise FunctionValueError(f"function {name} returned {value!r}, not a number")
        if value < 0 or value != value:
            raise FunctionValueError(f"function {name} returned {value}; costs are non-negative")
        return float(value)

    def query(
        self,
        name: str,
        inputs: tuple[Any, ...],
        *,
        key: Hashable = None,
        context: StreamContext | None = None,
    ) -> QueryResult:
        """Query stream ``name`` once on input values; ``key`` identifies the input binding
        (None: the input values themselves, numpy arrays and lists included: ``value_key``).

        A lazily evaluated predicate succeeds when its test says false (planning assumed it
        false); a rule always succeeds."""
        bound = self._bound(name)
        decl = bound.declaration
        if len(inputs) != len(decl.inputs):
            raise ValueError(
                f"stream {name} takes {len(decl.inputs)} inputs, {len(inputs)} were given"
            )
        fluents = None
        if decl.fluents:
            fluents = context.fluent_facts(decl.fluents) if context is not None else []
        # CPU seconds are the calling thread's, where the sampler runs (the process's other
        # threads, such as a store's writer, are not the query's). The wall clock is read
        # outside the CPU clock's reads, so the seconds a busy machine holds up those system
        # calls are the query's, not the search's.
        t_wall = time.perf_counter()
        t_cpu = time.thread_time()
        error: str | None = None
        reason: str | None = None
        exhausted = False
        outputs: Outputs | None
        try:
            if decl.kind == "predicate":
                holds = bound.adapter.test(inputs, context)
                outputs = None if holds else ()
                if holds:
                    reason = f"{decl.certified[0]} holds"
            else:
                answer = bound.adapter.next_outputs(
                    inputs, key if key is not None else value_key(inputs), context, fluents
                )
                if isinstance(answer, Failure):
                    outputs, reason = None, str(answer.reason)  # stored as text, whatever it was
                    exhausted = answer.exhausted
                elif isinstance(answer, Last):  # a success, and nothing more for these inputs
                    outputs, exhausted = tuple(answer.outputs), True
                else:
                    outputs = answer
        except Exception as exc:  # a sampler's failure is data, not a crash
            outputs = None
            error = f"{type(exc).__name__}: {exc}"
            log.warning("stream %s raised %s", name, error)
        cpu = time.thread_time() - t_cpu
        wall = time.perf_counter() - t_wall
        if outputs is not None and len(outputs) != len(decl.outputs):
            error = (
                f"stream {name} returned {len(outputs)} outputs, "
                f"its declaration has {len(decl.outputs)}"
            )
            log.warning(error)
            outputs = None
        duration: float | None = None
        if outputs and self._durations is not None:
            try:  # the domain's hook, outside the query's clocks
                duration = self.execution_seconds(name, outputs)
            except Exception as exc:  # the domain's word on its outputs: a failed query
                error = f"execution_s raised {type(exc).__name__}: {exc}"
                log.warning("stream %s: %s", name, error)
                outputs = None
        return QueryResult(
            name,
            outputs,
            wall,
            cpu,
            error,
            reason=reason,
            exhausted=exhausted,
            duration_s=duration,
        )

"""Adapters that bind a Python callable to a declared stream.

Three kinds, as in PDDLStream's ``from_fn``/``from_gen_fn``/``from_test``:

- :func:`from_fn`: ``fn(*inputs) -> tuple | None``; every query calls it again (a sampler).
- :func:`from_gen_fn`: ``gen_fn(*inputs) -> Iterator[tuple]``; every query takes the next item
  of one generator per input binding; an exhausted generator is a failed query.
- :func:`from_test`: ``test(*inputs) -> bool``; a stream with no outputs (a false test may
  return a :class:`Failure` to say why), or a lazily evaluated ``(:predicate ...)`` (its
  query succeeds when the test says false).
- :func:`from_function`: ``fn(*inputs) -> float``; a ``(:function ...)`` of the stream file,
  with the lower bound planning uses while its inputs are not bound.

A sampler that finds nothing may return (or yield) :class:`Failure` instead of ``None`` to say
why; the reason is recorded with the failed query. A stream that declares ``:fluents`` gets
``fluents=`` too: the facts of those predicates that hold where its outputs are needed, as
tuples ``(predicate, value, ...)`` of the objects' values.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from planner.pddl.structs import Atom

AdapterKind = Literal["fn", "gen", "test", "function"]
Outputs = tuple[Any, ...]
FluentFact = tuple[Any, ...]  # (predicate, value of each argument)


@dataclass(frozen=True)
class Failure:
    """A sampler's "nothing found", with the reason (falsy, like the ``None`` it replaces).
    ``exhausted``: the stream will find nothing more for these inputs, however often it is asked
    again (an ended generator, a function that gave its one output): the tree search does not
    query that node again."""

    reason: str
    exhausted: bool = False

    def __bool__(self) -> bool:
        return False


@dataclass(frozen=True)
class Last:
    """A sampler's output that is its last for these inputs (a PDDLStream function's one
    output, the last item of a list): a success after which the tree search does not ask the
    same node again, so no query is spent only to hear that the stream has nothing more."""

    outputs: tuple[Any, ...]


@dataclass(frozen=True)
class StreamContext:
    """What holds when a stream's outputs are first needed: the symbolic state of the plan at
    that step and the values bound so far. Samplers that take ``context`` see the world as it
    will be (which blocks already sit on the stove, what the hand holds)."""

    state: frozenset[Atom]
    values: Mapping[str, Any]

    def holds(self, predicate: str) -> list[tuple[str, ...]]:
        """Arguments of every fact of ``predicate`` in the state."""
        return [a.args for a in self.state if a.predicate == predicate]

    def fluent_facts(self, predicates: tuple[str, ...]) -> list[FluentFact]:
        """The facts of ``predicates`` in the state, as ``(predicate, value, ...)`` with each
        object's value (its name where it has none), in a fixed order."""
        wanted = set(predicates)
        facts = sorted(a for a in self.state if a.predicate in wanted)  # filter, then sort
        return [(a.predicate, *(self.values.get(x, x) for x in a.args)) for a in facts]


def value_key(value: Any) -> Hashable:
    """A hashable stand-in for a value, equal for equal values: what an adapter's memory of
    input bindings is keyed on when the caller gives no key. A numpy array is keyed on its
    dtype, shape and bytes, a list or tuple on its items, a dict on its items; any other
    unhashable value on its identity."""
    if isinstance(value, str | int | float | bool | type(None)):
        return value
    if isinstance(value, tuple | list):
        return (type(value).__name__, tuple(value_key(v) for v in value))
    if isinstance(value, dict):
        return ("dict", tuple((value_key(k), value_key(v)) for k, v in value.items()))
    tobytes = getattr(value, "tobytes", None)
    if callable(tobytes) and hasattr(value, "dtype") and hasattr(value, "shape"):
        return ("ndarray", str(value.dtype), tuple(value.shape), tobytes())
    try:
        hash(value)
    except TypeError:
        return ("id", id(value))
    hashable: Hashable = value
    return hashable


TEST_ANSWERED = "the test answered for these inputs, and its answer does not change"
TEST_FALSE = "the test says false (and will again for these inputs)"
GENERATOR_ENDED = "the generator is exhausted"
GENERATOR_ENDED_BEFORE = "the generator ended before (asked again)"
# PDDLStream's functions and lists (planner.streams.pddlstream), here so that what restates an
# adapter's contract is known in one place.
ONCE = "from_fn gives one output for these inputs, and it was given"
ALL_GIVEN = "from_list_fn's list for these inputs is used up"
# Answers no sampler gave: the adapter restating its contract (a function's one output already
# given, a list used up, a test or a generator asked again). They say nothing of the sampler,
# so training leaves them out (planner.learning.train) and so do the priors.
RESTATING = frozenset({TEST_ANSWERED, GENERATOR_ENDED_BEFORE, ONCE, ALL_GIVEN})


def restates_contract(reason: str | None) -> bool:
    """Whether a failed query's reason only restates its adapter's contract (:data:`RESTATING`):
    no sampler ran to give it."""
    return reason in RESTATING


@dataclass
class StreamAdapter:
    """A callable behind a stream name; ``next_outputs`` answers one query.

    With ``uses_context`` the callable also receives ``context=`` (a :class:`StreamContext`,
    or ``None`` when the caller has none).
    """

    kind: AdapterKind
    fn: Callable[..., Any]
    uses_context: bool = False
    lower_bound: float = 0.0  # functions only: the value planning assumes before binding
    # Tests only: the answer is the same however often it is asked (PDDLStream's tests), so a
    # second query of the same input binding, and a false answer, are exhausted failures.
    once: bool = False
    _generators: dict[Hashable, Iterator[Any]] = field(default_factory=dict, repr=False)
    _ended: set[Hashable] = field(default_factory=set, repr=False)  # generators that ended

    def __post_init__(self) -> None:
        if self.lower_bound < 0:
            raise ValueError(f"a lower bound must not be negative, got {self.lower_bound}")

    def _call(
        self,
        inputs: tuple[Any, ...],
        context: StreamContext | None,
        fluents: list[FluentFact] | None = None,
    ) -> Any:
        kwargs: dict[str, Any] = {}
        if self.uses_context:
            kwargs["context"] = context
        if fluents is not None:
            kwargs["fluents"] = fluents
        return self.fn(*inputs, **kwargs)

    def test(
        self,
        inputs: tuple[Any, ...],
        context: StreamContext | None = None,
        fluents: list[FluentFact] | None = None,
    ) -> bool:
        """A test's answer."""
        return bool(self._call(inputs, context, fluents))

    def next_outputs(
        self,
        inputs: tuple[Any, ...],
        key: Hashable,
        context: StreamContext | None = None,
        fluents: list[FluentFact] | None = None,
    ) -> Outputs | Last | Failure | None:
        """One query: the outputs (:class:`Last` when nothing more will come for these
        inputs), or ``None`` / a :class:`Failure` for a failure. May raise (the runtime records
        it). ``fluents`` goes to a sampler that declares ``:fluents``."""
        if self.kind == "function":
            raise TypeError("a function is evaluated, not queried")
        if self.kind == "test":
            if self.once:
                if key in self._generators:
                    return Failure(TEST_ANSWERED, exhausted=True)
                self._generators[key] = iter(())
            verdict = self._call(inputs, context, fluents)
            if isinstance(verdict, Failure):
                return verdict
            if bool(verdict):
                return Last(()) if self.once else ()
            return Failure(TEST_FALSE, exhausted=True) if self.once else None
        if self.kind == "fn":
            out = self._call(inputs, context, fluents)
            return out if out is None or isinstance(out, Failure) else tuple(out)
        if key in self._ended:
            return Failure(GENERATOR_ENDED_BEFORE, exhausted=True)
        gen = self._generators.get(key)
        if gen is None:
            gen = iter(self._call(inputs, context, fluents))
            self._generators[key] = gen
        try:
            out = next(gen)
        except StopIteration:
            self._ended.add(key)
            del self._generators[key]
            return Failure(GENERATOR_ENDED, exhausted=True)
        if out is None or isinstance(out, Failure | Last):
            return out
        return tuple(out)

    @property
    def callable_name(self) -> str:
        return getattr(self.fn, "__qualname__", repr(self.fn))


def from_fn(
    fn: Callable[..., tuple[Any, ...] | Failure | None], *, context: bool = False
) -> StreamAdapter:
    """A function returning one output tuple, or ``None`` (or a :class:`Failure`) when it fails."""
    return StreamAdapter("fn", fn, uses_context=context)


def from_gen_fn(gen_fn: Callable[..., Any], *, context: bool = False) -> StreamAdapter:
    """A generator function yielding output tuples (the context is the first query's)."""
    return StreamAdapter("gen", gen_fn, uses_context=context)


def from_test(test: Callable[..., bool | Failure], *, context: bool = False) -> StreamAdapter:
    """A boolean test for a stream with no outputs (a :class:`Failure` is false, with a reason)."""
    return StreamAdapter("test", test, uses_context=context)


def from_function(fn: Callable[..., float], *, lower_bound: float = 0.0) -> StreamAdapter:
    """A numeric function of bound inputs (a ``(:function ...)``): ``fn(*inputs) -> float``,
    non-negative. Planning uses ``lower_bound`` (default 0, PDDLStream's) where an input is
    not bound yet, and ``fn``'s value where every input is."""
    return StreamAdapter("function", fn, lower_bound=lower_bound)

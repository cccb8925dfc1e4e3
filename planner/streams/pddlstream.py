"""PDDLStream's stream map, as PDDLStream users write it.

A PDDLStream ``stream_map`` plugs in unchanged: import these instead of
``pddlstream.language.generator``'s and return the same dictionary from a domain's
``bindings``. Each has PDDLStream's signature and meaning:

==========================  =======================================================  ===========
adapter                     the callable                                             one query
==========================  =======================================================  ===========
``from_gen_fn(g)``          ``g(*inputs) -> iterator of output tuples`` (``None``:    next item
                            nothing this time)
``from_list_gen_fn(g)``     ``g(*inputs) -> iterator of lists of output tuples``     next tuple
``from_sampler(s)``         ``s(*inputs) -> output tuple``, called again and again   one call
``from_fn(f)``              ``f(*inputs) -> output tuple | None``, once per inputs   its one
                                                                                     output
``from_list_fn(f)``         ``f(*inputs) -> list of output tuples``, once per inputs next tuple
``from_test(t)``            ``t(*inputs) -> bool`` (a stream without outputs)         the answer
``from_constant(c)``        the output tuple ``c``, once per inputs                  ``c``
``negate_test(t)``          ``not t(*inputs)`` (a plain function, for ``from_test``)  -
``fn_from_constant(c)``     a ``(:function ...)`` worth ``c`` everywhere             -
``empty_gen()``             a generator that never yields (every query fails)        -
==========================  =======================================================  ===========

As in PDDLStream, a ``(:function ...)`` or a ``(:predicate ...)`` may be bound to a plain
Python function (:func:`planner.streams.runtime.bind_streams` wraps it), stream names match
case-insensitively, and a stream that declares ``:fluents`` gets ``fluents=[(predicate, value,
...), ...]`` (lower-case predicate names). Unlike PDDLStream, every query is timed and
recorded, and a sampler that raises is a failed query.

This project's own :func:`planner.streams.from_fn` is PDDLStream's ``from_sampler`` (it calls
again on every query); these keep PDDLStream's names for PDDLStream's meanings.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from typing import Any

from planner.pddl.structs import (
    And,
    Atom,
    Domain,
    Exists,
    ForAll,
    Formula,
    FunctionTerm,
    Imply,
    Literal,
    Not,
    Or,
    Problem,
    TypedName,
)
from planner.streams.adapters import ALL_GIVEN, ONCE, Failure, Last, StreamAdapter

log = logging.getLogger(__name__)

__all__ = [
    "PDDLStreamProblemError",
    "empty_gen",
    "fn_from_constant",
    "from_constant",
    "from_fn",
    "from_gen_fn",
    "from_list_fn",
    "from_list_gen_fn",
    "from_sampler",
    "from_test",
    "negate_test",
    "problem_from_init",
]

NONE_FOUND = "from_fn found no output for these inputs (and will not)"
EMPTY_LIST = "from_list_fn's list for these inputs is empty"


def from_gen_fn(gen_fn: Callable[..., Iterable[Sequence[Any] | None]]) -> StreamAdapter:
    """``gen_fn(*inputs)`` returns an iterator of output tuples; each query takes the next one
    (``None`` is a query that found nothing; the end of the iterator, exhaustion)."""
    return StreamAdapter("gen", gen_fn)


def from_list_gen_fn(
    list_gen_fn: Callable[..., Iterable[Sequence[Sequence[Any]]]],
) -> StreamAdapter:
    """``list_gen_fn(*inputs)`` returns an iterator of lists of output tuples; each query
    takes the next tuple (an empty list is a query that found nothing)."""

    def one_by_one(*inputs: Any, **kwargs: Any) -> Iterator[Sequence[Any] | None]:
        for batch in list_gen_fn(*inputs, **kwargs):
            if not batch:
                yield None
            else:
                yield from batch

    one_by_one.__qualname__ = getattr(list_gen_fn, "__qualname__", "list_gen_fn")
    return StreamAdapter("gen", one_by_one)


def from_sampler(sampler: Callable[..., Sequence[Any] | None]) -> StreamAdapter:
    """``sampler(*inputs)`` returns one output tuple; every query calls it again."""
    return StreamAdapter("fn", sampler)


def from_fn(fn: Callable[..., Sequence[Any] | None]) -> StreamAdapter:
    """``fn(*inputs)`` returns the output tuple (or ``None``): one output per input binding,
    as PDDLStream's functions; a second query of the same binding finds nothing new."""

    def once(*inputs: Any, **kwargs: Any) -> Iterator[Last | Failure]:
        out = fn(*inputs, **kwargs)
        yield Failure(NONE_FOUND, exhausted=True) if out is None else Last(tuple(out))
        while True:
            yield Failure(ONCE, exhausted=True)

    once.__qualname__ = getattr(fn, "__qualname__", "fn")
    return StreamAdapter("gen", once)


def from_list_fn(list_fn: Callable[..., Sequence[Sequence[Any]] | None]) -> StreamAdapter:
    """``list_fn(*inputs)`` returns a list of output tuples, once per input binding; each
    query takes the next one."""

    def each(*inputs: Any, **kwargs: Any) -> Iterator[Sequence[Any] | Last | Failure]:
        outputs = list(list_fn(*inputs, **kwargs) or [])
        if not outputs:
            yield Failure(EMPTY_LIST, exhausted=True)
        yield from outputs[:-1]
        if outputs:
            yield Last(tuple(outputs[-1]))
        while True:
            yield Failure(ALL_GIVEN, exhausted=True)

    each.__qualname__ = getattr(list_fn, "__qualname__", "list_fn")
    return StreamAdapter("gen", each)


def from_test(test: Callable[..., Any]) -> StreamAdapter:
    """``test(*inputs)`` returns whether the stream's certified facts hold (a stream without
    outputs, or a ``(:predicate ...)``). As in PDDLStream, the answer for an input binding does
    not change: it is asked once (a false answer, or a second query, is exhausted)."""
    return StreamAdapter("test", test, once=True)


def from_constant(constant: Sequence[Any]) -> StreamAdapter:
    """The output tuple ``constant``, once per input binding."""
    values = tuple(constant)
    return from_fn(lambda *inputs, **kwargs: values)


def negate_test(test: Callable[..., Any]) -> Callable[..., bool]:
    """The test that says the opposite of ``test``."""

    def negated(*inputs: Any, **kwargs: Any) -> bool:
        return not test(*inputs, **kwargs)

    negated.__qualname__ = f"not {getattr(test, '__qualname__', 'test')}"
    return negated


def fn_from_constant(constant: float) -> Callable[..., float]:
    """A ``(:function ...)`` worth ``constant`` whatever its inputs."""

    def value(*inputs: Any, **kwargs: Any) -> float:
        return constant

    value.__qualname__ = f"constant {constant}"
    return value


def empty_gen() -> StreamAdapter:
    """A stream that never finds anything."""
    return from_gen_fn(lambda *inputs, **kwargs: iter(()))


# --- PDDLStream's init and goal --------------------------------------------------------------


class PDDLStreamProblemError(ValueError):
    """A PDDLStream-style ``init`` or ``goal`` that does not fit the domain; the message names
    the entry (``init[3]``, ``goal``) and what was expected."""


def _is_name(value: Any) -> bool:
    return isinstance(value, str) and not value.startswith("?")


class _Objects:
    """Python values to object names: strings are names (PDDLStream's constants); any other
    value gets ``v0``, ``v1``, ... once (by identity, then by equality where it is hashable)."""

    def __init__(self, constants: Iterable[str]) -> None:
        self.names: list[str] = []
        self.values: dict[str, Any] = {}
        self._by_id: dict[int, str] = {}
        self._by_value: dict[Any, str] = {}
        self._taken = set(constants)
        self._spelled: dict[str, str] = {}  # a name as first written

    def name(self, value: Any) -> str:
        if _is_name(value):
            name = str(value).lower()  # PDDL's names are case-insensitive
            seen = self._spelled.setdefault(name, value)
            if seen != value:
                raise PDDLStreamProblemError(
                    f"{seen!r} and {value!r} are one name in PDDL (names ignore case)"
                )
            if name != value:  # the samplers get the string as written
                self.values[name] = value
            if name not in self._taken and name not in self.names:
                self.names.append(name)
            return name
        found = self._by_id.get(id(value))
        if found is not None:
            return found
        try:
            found = self._by_value.get(value)
        except TypeError:  # unhashable (a list, a numpy array): by identity only
            found = None
        if found is not None:
            return found
        i = len(self._by_id)
        while f"v{i}" in self._taken:
            i += 1
        name = f"v{i}"
        self._taken.add(name)
        self.names.append(name)
        self.values[name] = value
        self._by_id[id(value)] = name
        with contextlib.suppress(TypeError):  # unhashable: found by identity only
            self._by_value[value] = name
        return name


def _fact(entry: Any, where: str) -> tuple[str, tuple[Any, ...]]:
    if not isinstance(entry, tuple | list) or not entry or not isinstance(entry[0], str):
        raise PDDLStreamProblemError(
            f"{where}: expected a fact such as ('AtPose', 'b1', pose), got {entry!r}"
        )
    return entry[0].lower(), tuple(entry[1:])


_CONNECTIVES = ("and", "or", "not", "imply", "exists", "forall")


def _variables(spec: Any, where: str) -> tuple[TypedName, ...]:
    """A quantifier's variables: ``['?p', '?q']`` (or one ``'?p'``)."""
    names = [spec] if isinstance(spec, str) else spec
    if not isinstance(names, list | tuple) or not names:
        raise PDDLStreamProblemError(f"{where}: expected a list of variables such as ['?p']")
    out = []
    for name in names:
        if not isinstance(name, str) or not name.startswith("?") or len(name) < 2:
            raise PDDLStreamProblemError(f"{where}: expected a variable such as '?p', got {name!r}")
        out.append(TypedName(name.lower()))
    return tuple(out)


def _formula(
    goal: Any, objects: _Objects, domain: Domain, where: str, scope: frozenset[str]
) -> Formula:
    """A goal formula from PDDLStream's tuples: a fact, ``('and' | 'or', part, ...)``,
    ``('not', part)``, ``('imply', condition, consequence)``, ``('exists' | 'forall',
    ['?x', ...], body)``; in a quantifier's body its variables are written ``'?x'``."""
    predicate, args = _fact(goal, where)
    if predicate in ("and", "or"):
        parts = tuple(
            _formula(part, objects, domain, f"{where}[{i + 1}]", scope)
            for i, part in enumerate(args)
        )
        return And(parts) if predicate == "and" else Or(parts)
    if predicate == "not":
        if len(args) != 1:
            raise PDDLStreamProblemError(f"{where}: expected ('not', part)")
        inner = _formula(args[0], objects, domain, f"{where}[1]", scope)
        return Literal(inner.atom, not inner.positive) if isinstance(inner, Literal) else Not(inner)
    if predicate == "imply":
        if len(args) != 2:
            raise PDDLStreamProblemError(f"{where}: expected ('imply', condition, consequence)")
        return Imply(
            _formula(args[0], objects, domain, f"{where}[1]", scope),
            _formula(args[1], objects, domain, f"{where}[2]", scope),
        )
    if predicate in ("exists", "forall"):
        if len(args) != 2:
            raise PDDLStreamProblemError(f"{where}: expected ('{predicate}', ['?x', ...], body)")
        variables = _variables(args[0], f"{where}[1]")
        inner_scope = scope | {v.name for v in variables}
        body = _formula(args[1], objects, domain, f"{where}[2]", inner_scope)
        return Exists(variables, body) if predicate == "exists" else ForAll(variables, body)
    return Literal(_atom(predicate, args, objects, domain, where, scope))


def _goal(goal: Any, objects: _Objects, domain: Domain, where: str) -> list[Formula]:
    """The goal's conjuncts (a top-level ``and`` is split)."""
    formula = _formula(goal, objects, domain, where, frozenset())
    return list(formula.parts) if isinstance(formula, And) else [formula]


def _atom(
    predicate: str,
    args: tuple[Any, ...],
    objects: _Objects,
    domain: Domain,
    where: str,
    scope: frozenset[str] = frozenset(),
) -> Atom:
    if predicate in _CONNECTIVES:
        raise PDDLStreamProblemError(f"{where}: ({predicate} ...) belongs in the goal, not init")
    known = {p.name: p.arity for p in domain.predicates}
    if predicate in known and known[predicate] != len(args):
        raise PDDLStreamProblemError(
            f"{where}: predicate {predicate!r} takes {known[predicate]} arguments, "
            f"{len(args)} given ({domain.places.get(predicate, domain.source)})"
        )
    names = []
    for a in args:
        if isinstance(a, str) and a.startswith("?"):
            if a.lower() not in scope:
                raise PDDLStreamProblemError(
                    f"{where}: variable {a} is not quantified (an ('exists', ['{a}'], ...) "
                    "or ('forall', ...) around it binds it)"
                )
            names.append(a.lower())
        else:
            names.append(objects.name(a))
    return Atom(predicate, tuple(names))


def problem_from_init(
    domain: Domain,
    init: Iterable[Any],
    goal: Any,
    *,
    name: str = "problem",
    constant_map: Mapping[str, Any] | None = None,
    values: Mapping[str, Any] | None = None,
    source: str = "<python>",
) -> Problem:
    """A :class:`~planner.pddl.Problem` from PDDLStream's ``init`` and ``goal``: facts as tuples
    whose first item is the predicate (any case) and whose arguments are Python values
    (strings are object names, any other value becomes an object ``v0``, ``v1``, ... with that
    value); ``('=', ('Dist', a, b), 3.5)`` gives a function its value; the goal is a fact or a
    formula of PDDLStream's tuples: ``('and' | 'or', part, ...)``, ``('not', part)``,
    ``('imply', a, b)``, ``('exists' | 'forall', ['?x', ...], body)``. Errors name ``source``
    (the scene file) and the entry (``init[3]``, ``goal[2]``). ``constant_map`` maps the domain's
    constants to their values (PDDLStream's ``constant_map``); ``values`` adds values that no
    fact names (a scene's geometry for the samplers). Predicates the domain does not declare
    are declared by their use, as everywhere (planner.pddl.structs.problem_predicates)."""
    prefix = "" if source == "<python>" else f"{source}: "  # errors name the file
    constants = {c.name for c in domain.constants}
    objects = _Objects(constants)
    for const, value in (constant_map or {}).items():
        if const.lower() not in constants:
            raise PDDLStreamProblemError(
                f"{prefix}constant_map: {const!r} is not a constant of domain {domain.name}"
            )
        objects.values[const.lower()] = value
        objects._by_id[id(value)] = const.lower()
    facts: set[Atom] = set()
    numbers: dict[FunctionTerm, float] = {}
    for i, entry in enumerate(init):
        where = f"{prefix}init[{i}]"
        predicate, args = _fact(entry, where)
        if predicate == "=":
            if len(args) != 2:
                raise PDDLStreamProblemError(f"{where}: expected ('=', (function, ...), number)")
            fname, fargs = _fact(args[0], where)
            value = args[1]
            if isinstance(value, bool) or not isinstance(value, int | float) or value < 0:
                raise PDDLStreamProblemError(
                    f"{where}: a function's value must be a non-negative number, got {value!r}"
                )
            if fname == "total-cost":
                continue
            numbers[FunctionTerm(fname, tuple(objects.name(a) for a in fargs))] = value
            continue
        facts.add(_atom(predicate, args, objects, domain, where))
    parts = _goal(goal, objects, domain, f"{prefix}goal")
    all_values: dict[str, Any] = dict(values or {})
    all_values.update(objects.values)
    try:
        return Problem(
            name,
            domain.name,
            tuple(TypedName(n) for n in objects.names),
            frozenset(facts),
            tuple(p for p in parts if isinstance(p, Literal)),
            source,
            all_values,
            goal_conditions=tuple(p for p in parts if not isinstance(p, Literal)),
            function_values=numbers,
        )
    except ValueError as exc:
        raise PDDLStreamProblemError(f"{prefix}{exc}") from exc

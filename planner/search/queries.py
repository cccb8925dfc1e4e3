"""One query context and one query identity, for everything that reads a query: the search
(which records it and reuses results by identity), the learned policy (which predicts it) and
training (which reads the recorded context back).

A query's **context** is the world its sampler sees where its output is first needed: the
fluent facts of the plan's state there, the encoded values of their objects, and the domain's
static context (JSON, as events and the store carry it, and as the models read it). Its
**identity** is its stream, its encoded inputs and its context.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable, Collection, Mapping, Sequence
from typing import Any

from planner.pddl.structs import Atom


def query_context(
    state: Collection[Atom],
    values: Mapping[str, Any],
    *,
    fluents: Collection[str],
    static_context: Mapping[str, Any],
    encode: Callable[[Any], Any],
) -> dict[str, Any]:
    """The context of a query made in ``state`` with ``values`` bound (see the module). Its
    ``facts`` list is shared by every context of the same state: read it, do not change it."""
    facts, names = _fluent_facts(frozenset(state), frozenset(fluents))
    encoded = {
        n: encode(values[n]) for n in names if n in values and not isinstance(values[n], str)
    }
    return {**static_context, "facts": facts, "values": encoded}


@functools.lru_cache(maxsize=65536)
def _fluent_facts(
    state: frozenset[Atom], fluents: frozenset[str]
) -> tuple[list[list[str]], tuple[str, ...]]:
    """The fluent facts of ``state`` as sorted lists, and the names they hold, sorted (a
    search's states are few and asked for again and again)."""
    facts = sorted(a for a in state if a.predicate in fluents)
    names = tuple(sorted({x for a in facts for x in a.args}))
    return [[a.predicate, *a.args] for a in facts], names


def remembered(encode: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """``encode`` that encodes each value object once (values are immutable): a search reads
    the same bound values in the queries, events and model rows of every node below the one
    that bound them, and what is kept by the identity of an encoded value (feature parts) is
    then found again. Wrapping a remembered encoder returns it, so callers share one memory."""
    if getattr(encode, "remembers", False):
        return encode
    seen: dict[int, tuple[Any, Any]] = {}

    def encoded(value: Any) -> Any:
        hit = seen.get(id(value))
        if hit is not None and hit[0] is value:
            return hit[1]
        out = encode(value)
        seen[id(value)] = (value, out)  # the value is kept, so its id is not reused
        return out

    encoded.remembers = True  # type: ignore[attr-defined]  # read by remembered() above
    return encoded


def query_identity(stream: str, inputs: Sequence[Any], context: Mapping[str, Any]) -> str:
    """The identity of a query from its encoded inputs and its context (see the module); two
    queries with one identity give the same outcome as far as the domain can tell."""
    facts = context.get("facts", [])
    values = dict(context.get("values", {}))
    rest = {k: v for k, v in context.items() if k not in ("facts", "values")}
    return json.dumps([stream, list(inputs), facts, values, rest], sort_keys=True, default=str)

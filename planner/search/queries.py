"""One query context and one query identity, for everything that reads a query: the search
(which records it), the reuse of results, the learned policy (which predicts it and pools what
its failures teach) and training (which reads the recorded context back).

A query's **context** is the world its sampler sees where its output is first needed: the
fluent facts of the plan's state there, the encoded values of their objects, and the domain's
static context (JSON, as events and the store carry it, and as the models read it). Its
**identity** is its stream, its encoded inputs and its context; ``ignore`` leaves out facts of
predicates that do not change the outcome (``DomainSpec.evidence_ignore``) and the values only
they name.
"""

from __future__ import annotations

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
    """The context of a query made in ``state`` with ``values`` bound (see the module)."""
    facts = sorted(a for a in state if a.predicate in fluents)
    names = {x for a in facts for x in a.args}
    encoded = {
        n: encode(values[n])
        for n in sorted(names)
        if n in values and not isinstance(values[n], str)
    }
    return {**static_context, "facts": [[a.predicate, *a.args] for a in facts], "values": encoded}


def query_identity(
    stream: str,
    inputs: Sequence[Any],
    context: Mapping[str, Any],
    *,
    ignore: Collection[str] = (),
) -> str:
    """The identity of a query from its encoded inputs and its context (see the module); two
    queries with one identity give the same outcome as far as the domain can tell."""
    facts = context.get("facts", [])
    if ignore:
        facts = [f for f in facts if f[0] not in ignore]
        names = {x for f in facts for x in f[1:]}
        values = {n: v for n, v in context.get("values", {}).items() if n in names}
    else:
        values = dict(context.get("values", {}))
    rest = {k: v for k, v in context.items() if k not in ("facts", "values")}
    return json.dumps([stream, list(inputs), facts, values, rest], sort_keys=True, default=str)

"""Binding a skeleton's optimistic objects to sampler outputs.

:func:`bind_sequentially` is the simplest binder: query the streams of one stream plan in order,
retrying a failed stream a few times and restarting from the first stream when it keeps failing.
It is what a test or a user uses to check a domain's samplers end to end; the tree search of
issue 4 decides which stream to query next instead.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from planner.abstract.instantiate import StreamInstance
from planner.abstract.skeleton import AbstractPlan, symbolic_states
from planner.pddl.structs import Atom, Domain, Problem
from planner.streams.adapters import StreamContext
from planner.streams.runtime import QueryResult, StreamRuntime

log = logging.getLogger(__name__)

# Told of every query bind_sequentially makes: the restart, the stream's index in the plan,
# the stream instance, its input values, the context it saw and the result.
QueryObserver = Callable[
    [int, int, StreamInstance, tuple[Any, ...], StreamContext, QueryResult], None
]


@dataclass(frozen=True)
class BoundPlan:
    """A skeleton whose every optimistic object has a value."""

    skeleton: AbstractPlan
    values: Mapping[str, Any] = field(repr=False)  # object name -> value (real ones included)

    def value(self, name: str) -> Any:
        return self.values[name]


def stream_contexts(plan: AbstractPlan, domain: Domain, problem: Problem) -> list[frozenset[Atom]]:
    """For each stream of the plan, the symbolic state before the first action that needs it."""
    if not plan.first_use:
        raise ValueError("the plan carries no first-use steps (build it with plan_abstract)")
    states = symbolic_states(plan.actions, domain, problem.init)
    return [states[step] for step in plan.first_use]


def bind_sequentially(
    plan: AbstractPlan,
    domain: Domain,
    problem: Problem,
    runtime: StreamRuntime,
    *,
    attempts: int = 10,
    restarts: int = 5,
    observe: QueryObserver | None = None,
) -> tuple[BoundPlan | None, list[QueryResult]]:
    """Bind ``plan`` by querying its streams in order; return the bound plan (or ``None``) and
    every query made (each also told to ``observe`` as it is made)."""
    if attempts < 1 or restarts < 1:
        raise ValueError("attempts and restarts must be at least 1")
    contexts = stream_contexts(plan, domain, problem)
    queries: list[QueryResult] = []
    for restart in range(restarts):
        values: dict[str, Any] = {
            o.name: problem.values.get(o.name, o.name) for o in problem.objects
        }
        for i, (inst, state) in enumerate(zip(plan.stream_plan, contexts, strict=True)):
            inputs = tuple(values[name] for name in inst.inputs)
            context = StreamContext(state, values)
            for _ in range(attempts):
                result = runtime.query(
                    inst.stream, inputs, key=(restart, inst.stream, inst.inputs), context=context
                )
                queries.append(result)
                if observe is not None:
                    observe(restart, i, inst, inputs, context, result)
                if result.outputs is not None:
                    values.update(zip(inst.outputs, result.outputs, strict=True))
                    break
            else:
                log.info("restart %d: stream %d %s failed %d times", restart, i, inst, attempts)
                break
        else:
            return BoundPlan(plan, values), queries
    return None, queries

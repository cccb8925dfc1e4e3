"""Binding a skeleton's optimistic objects to sampler outputs.

:func:`bind_sequentially` is the simplest binder: query the streams of one stream plan in order,
retrying a failed stream a few times and restarting from the first stream when it keeps failing.
It is what a test or a user uses to check a domain's samplers end to end; the tree search
(``mcts.py``) decides which stream to query next instead.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from planner.abstract.instantiate import StreamInstance
from planner.abstract.skeleton import AbstractPlan, symbolic_states
from planner.pddl.semantics import Universe
from planner.pddl.structs import Atom, Domain, FunctionTerm, Problem
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
    cost: float | None = None  # the plan's cost with its bound values (see plan_cost)

    def value(self, name: str) -> Any:
        return self.values[name]


def plan_states(plan: AbstractPlan, domain: Domain, problem: Problem) -> list[frozenset[Atom]]:
    """The fluent state before each action of ``plan`` and after the last, its conditional
    effects evaluated with the facts its streams certify."""
    if not any(domain.action(a.name).effects for a in plan.actions):
        return symbolic_states(plan.actions, domain, problem.init)
    universe = Universe.of_problem(
        domain, problem, (o for inst in plan.stream_plan for o in inst.typed_outputs)
    )
    certified = {a for inst in plan.stream_plan if inst.kind != "predicate" for a in inst.certified}
    return symbolic_states(
        plan.actions, domain, problem.init, universe=universe, certified=certified
    )


def stream_contexts(plan: AbstractPlan, domain: Domain, problem: Problem) -> list[frozenset[Atom]]:
    """For each stream of the plan, the symbolic state before the first action that needs it."""
    if not plan.first_use:
        raise ValueError("the plan carries no first-use steps (build it with plan_abstract)")
    states = plan_states(plan, domain, problem)
    return [states[step] for step in plan.first_use]


def shared_states(
    states: Sequence[Sequence[frozenset[Atom]]],
    seen: dict[frozenset[Atom], frozenset[Atom]] | None = None,
) -> list[list[frozenset[Atom]]]:
    """``states`` (one list per plan) with one object for each distinct state: the k plans of
    a problem pass through many of the same states, and what reads a state (query contexts,
    feature rows, the learned policy's keys) then finds it by identity instead of comparing
    its facts one by one. ``seen`` keeps the objects across calls (plans that come later)."""
    seen = {} if seen is None else seen
    return [[seen.setdefault(s, s) for s in plan_states] for plan_states in states]


class PlanCostError(ValueError):
    """A bound plan's cost cannot be computed (a cost term has no value)."""


def plan_cost(
    plan: AbstractPlan,
    domain: Domain,
    problem: Problem,
    values: Mapping[str, Any],
    runtime: StreamRuntime | None = None,
) -> float:
    """The cost of ``plan`` once its objects are bound to ``values``: each action's number
    plus its function terms, valued from the problem's ``:init`` or by the stream file's
    Python function on the bound values. Without action costs, the number of actions."""
    if not domain.uses_action_costs:
        return float(len(plan.actions))
    total = 0.0
    functions = set(runtime.function_names) if runtime is not None else set()
    for action in plan.actions:
        schema = domain.action(action.name)
        mapping = dict(zip(schema.param_names, action.args, strict=True))
        total += schema.cost or 0.0
        for term in schema.cost_terms:
            ground: FunctionTerm = term.substitute(mapping)
            if ground in problem.function_values:
                total += problem.function_values[ground]
            elif runtime is not None and ground.name in functions:
                inputs = tuple(values.get(a, problem.values.get(a, a)) for a in ground.args)
                total += runtime.evaluate(ground.name, inputs)
            else:
                raise PlanCostError(f"{action}: the cost {ground} has no value")
    return total


def bind_sequentially(
    plan: AbstractPlan,
    domain: Domain,
    problem: Problem,
    runtime: StreamRuntime,
    *,
    attempts: int = 10,
    restarts: int = 5,
    observe: QueryObserver | None = None,
    stop: Callable[[], bool] | None = None,
) -> tuple[BoundPlan | None, list[QueryResult]]:
    """Bind ``plan`` by querying its streams in order; return the bound plan (or ``None``) and
    every query made (each also told to ``observe`` as it is made). ``stop`` is asked before
    each query: when it says so, the binding ends there with no plan (a run's budget spent)."""
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
                if stop is not None and stop():
                    return None, queries
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
            return BoundPlan(
                plan, values, plan_cost(plan, domain, problem, values, runtime)
            ), queries
    return None, queries

"""The order in which a search binds a stream plan's streams.

A stream plan comes from the action plan in action order: each block's grasp, placements, IK
and motions follow one another. Binding in that order pays for a block's motions (about 2 s of
OMPL each in the kitchen) before the cheap tests of the next block have run, and when a cheap
test fails (the fourth block finds no room on the stove) everything bound after the choice to
blame is thrown away with it.

:func:`order_streams` moves each stream as early as what it reads allows: its inputs, and the
optimistic objects in the fluent facts of its context that its sampler reads (a placement sees
where the earlier blocks stand, so it comes after their placements; it does not read where the
robot stands, so it need not wait for the IK before it). Among the streams that could go next it
takes the one with the least expected seconds per failure (:func:`seconds_per_failure`): the
classic rule for ordering independent tests (Simon & Kadane), here with the learned models'
predictions. In the kitchen that binds every grasp, placement and IK (milliseconds) before the
first motion, so a crowded stove is found and re-sampled before any motion is planned.
"""

from __future__ import annotations

import heapq
from collections.abc import Collection, Mapping, Sequence

from planner.abstract.skeleton import AbstractPlan
from planner.pddl.structs import Atom
from planner.search.learned import StreamCost

FAILURE_MIN = 1e-3  # a stream never looks certain to succeed (keeps the ratio finite)


def seconds_per_failure(cost: StreamCost) -> float:
    """Expected seconds of one query divided by its chance of failing: the lower, the sooner
    the stream should run (cheap and doubtful first, expensive and sure last)."""
    p = min(max(cost.p_s, 0.0), 1.0)
    seconds = p * cost.r_s + (1.0 - p) * cost.r_f
    return max(seconds, 0.0) / max(1.0 - p, FAILURE_MIN)


def dependencies(
    plan: AbstractPlan,
    states: Sequence[frozenset[Atom]],
    fluents: frozenset[str],
    unread: Mapping[str, Collection[str]] | None = None,
) -> list[set[int]]:
    """Per stream, the streams that must be bound before it: those producing its inputs or an
    object of its context's fluent facts, except the facts of the fluents ``unread`` names for
    that stream (its sampler never reads them)."""
    unread = unread or {}
    if len(states) != len(plan.stream_plan):
        raise ValueError(
            f"one context per stream is needed: {len(states)} for {len(plan.stream_plan)}"
        )
    producer = {o: i for i, inst in enumerate(plan.stream_plan) for o in inst.outputs}
    deps: list[set[int]] = []
    for i, inst in enumerate(plan.stream_plan):
        read = set(inst.inputs)
        skip = unread.get(inst.stream, ())
        read.update(
            x
            for a in states[i]
            if a.predicate in fluents and a.predicate not in skip
            for x in a.args
        )
        mine = {producer[o] for o in read if o in producer} - {i}
        if any(j > i for j in mine):
            raise ValueError(
                f"stream {i} ({inst}) reads an object made by a later stream: "
                "the plan's contexts are not in binding order"
            )
        deps.append(mine)
    return deps


def order_streams(
    plan: AbstractPlan,
    states: Sequence[frozenset[Atom]],
    fluents: frozenset[str],
    scores: Sequence[float],
    unread: Mapping[str, Collection[str]] | None = None,
) -> tuple[AbstractPlan, list[frozenset[Atom]]]:
    """``plan`` with its streams reordered (and ``states``, the context of each stream, to
    match): at each step the stream with the lowest score among those whose dependencies are
    bound (:func:`dependencies`), ties in the plan's own order. Scores are usually
    :func:`seconds_per_failure`."""
    if len(scores) != len(plan.stream_plan):
        raise ValueError(
            f"one score per stream is needed: {len(scores)} for a plan of {len(plan.stream_plan)}"
        )
    deps = dependencies(plan, states, fluents, unread)
    waiting = [len(d) for d in deps]
    users: list[list[int]] = [[] for _ in deps]
    for i, d in enumerate(deps):
        for j in d:
            users[j].append(i)
    ready = [(scores[i], i) for i, n in enumerate(waiting) if n == 0]
    heapq.heapify(ready)
    order: list[int] = []
    while ready:
        _, i = heapq.heappop(ready)
        order.append(i)
        for u in users[i]:
            waiting[u] -= 1
            if waiting[u] == 0:
                heapq.heappush(ready, (scores[u], u))
    if len(order) != len(deps):  # cannot happen: dependencies point to earlier streams
        raise RuntimeError("stream dependencies form a cycle")
    first_use = tuple(plan.first_use[i] for i in order) if plan.first_use else ()
    reordered = AbstractPlan(
        plan.actions, tuple(plan.stream_plan[i] for i in order), plan.cost, first_use
    )
    return reordered, [states[i] for i in order]

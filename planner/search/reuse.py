"""Which queries the search may answer with an earlier identical query's result.

A query is identified by its stream, its encoded inputs and its context
(:mod:`planner.search.queries`: the same JSON the search records and the models read). A
success may stand in for a new query only where nothing downstream depends
on which sample it is: no later stream takes its outputs, no fluent fact holds them (in the
kitchen, a motion's trajectory, which only the action that moves uses).
"""

from __future__ import annotations

from collections.abc import Sequence

from planner.abstract.skeleton import AbstractPlan
from planner.pddl.structs import Atom


def reusable_streams(
    plan: AbstractPlan, states: Sequence[frozenset[Atom]], fluents: frozenset[str]
) -> list[bool]:
    """Per stream of ``plan``: are its outputs read by nothing (no stream takes them as input,
    no fluent fact of any context holds them)? Then an earlier success of the same query is as
    good as a new one: it cannot make anything downstream fail."""
    read = {x for inst in plan.stream_plan for x in inst.inputs}
    read.update(x for state in states for a in state if a.predicate in fluents for x in a.args)
    return [bool(inst.outputs) and not (set(inst.outputs) & read) for inst in plan.stream_plan]

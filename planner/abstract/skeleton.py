"""From an action plan over optimistic objects to its stream plan, and checks on both."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from planner.abstract.instantiate import OPTIMISTIC_PREFIX, OptimisticInstantiation, StreamInstance
from planner.pddl.structs import Atom, Domain, Literal, Problem


@dataclass(frozen=True, order=True)
class GroundAction:
    """An action applied to objects (real or optimistic)."""

    name: str
    args: tuple[str, ...]

    @classmethod
    def parse(cls, text: str) -> GroundAction:
        """``'(move q0 opt-q1 opt-t2)'`` or ``'move q0 opt-q1 opt-t2'``."""
        parts = text.strip().strip("()").split()
        if not parts:
            raise ValueError(f"empty action in plan: {text!r}")
        return cls(parts[0].lower(), tuple(p.lower() for p in parts[1:]))

    def __str__(self) -> str:
        return f"({' '.join((self.name, *self.args))})"


@dataclass(frozen=True)
class AbstractPlan:
    """An action plan and the stream plan that must succeed to bind it."""

    actions: tuple[GroundAction, ...]
    stream_plan: tuple[StreamInstance, ...]
    cost: float
    first_use: tuple[int, ...] = ()  # per stream: index of the first action that needs it

    def __post_init__(self) -> None:
        if self.first_use and len(self.first_use) != len(self.stream_plan):
            raise ValueError("first_use needs one action index per stream of the stream plan")

    @property
    def optimistic_objects(self) -> tuple[str, ...]:
        return tuple(o for inst in self.stream_plan for o in inst.outputs)


class PlanReplayError(Exception):
    """A plan or stream plan does not replay from the initial state."""


def _is_optimistic(name: str) -> bool:
    return name.startswith(OPTIMISTIC_PREFIX)


def _ground(domain: Domain, action: GroundAction) -> tuple[list[Literal], list[Atom], list[Atom]]:
    schema = domain.action(action.name)
    if len(schema.params) != len(action.args):
        raise PlanReplayError(
            f"{action}: {schema.name} takes {len(schema.params)} arguments, got {len(action.args)}"
        )
    mapping = dict(zip(schema.param_names, action.args, strict=True))
    return (
        [lit.substitute(mapping) for lit in schema.preconditions],
        [a.substitute(mapping) for a in schema.add_effects],
        [a.substitute(mapping) for a in schema.del_effects],
    )


def _holds(lit: Literal, state: set[Atom] | frozenset[Atom]) -> bool:
    if lit.is_equality:
        equal = lit.atom.args[0] == lit.atom.args[1]
        return equal == lit.positive
    return (lit.atom in state) == lit.positive


def recover_stream_plan(
    actions: Sequence[GroundAction],
    domain: Domain,
    problem: Problem,
    inst: OptimisticInstantiation,
    *,
    cache: dict[GroundAction, tuple[Atom, ...]] | None = None,
) -> tuple[tuple[StreamInstance, ...], tuple[int, ...]]:
    """The streams whose certified facts the plan needs, with the streams they depend on, and
    for each the index of the first action that needs it (``len(actions)``: only the goal).

    Ordered as the plan needs them: by the first action that needs a stream (directly or
    through a stream that consumes its outputs), then by level, which keeps producers before
    consumers. Early actions' streams come first, so a search meets their failures early.
    """
    cache = {} if cache is None else cache
    first_step: dict[int, int] = {}

    def need(index: int, step: int) -> None:
        stack = [index]
        while stack:
            i = stack.pop()
            if i in first_step:
                continue
            first_step[i] = step
            for atom in inst.instances[i].domain:
                if atom not in problem.init and atom in inst.certifier:
                    stack.append(inst.certifier[atom])

    for step, action in enumerate(actions):
        wanted = cache.get(action)
        if wanted is None:
            pre, _, _ = _ground(domain, action)
            wanted = tuple(lit.atom for lit in pre if lit.positive and not lit.is_equality)
            cache[action] = wanted
        for atom in wanted:
            if atom not in problem.init and atom in inst.certifier:
                need(inst.certifier[atom], step)
    for lit in problem.goal:
        if lit.positive and lit.atom not in problem.init and lit.atom in inst.certifier:
            need(inst.certifier[lit.atom], len(actions))
    order = sorted(first_step, key=lambda i: (first_step[i], inst.instances[i].level, i))
    return tuple(inst.instances[i] for i in order), tuple(first_step[i] for i in order)


def symbolic_states(
    actions: Sequence[GroundAction], domain: Domain, init: frozenset[Atom]
) -> list[frozenset[Atom]]:
    """The fluent state before each action, and after the last (no precondition checks)."""
    states = [init]
    state = set(init)
    for action in actions:
        _, adds, dels = _ground(domain, action)
        state.difference_update(dels)
        state.update(adds)
        states.append(frozenset(state))
    return states


def replay(plan: AbstractPlan, domain: Domain, problem: Problem) -> None:
    """Check a plan fact by fact; raise :class:`PlanReplayError` at the first violation.

    Streams run first, in order: each one's domain facts must hold in the initial state or be
    certified by an earlier stream, and its inputs must be real or already produced. Then every
    action's preconditions must hold in the state (static certified facts included), and the
    goal at the end.
    """
    certified: set[Atom] = set()
    produced: set[str] = set()
    for step, inst in enumerate(plan.stream_plan):
        for name in inst.inputs:
            if _is_optimistic(name) and name not in produced:
                raise PlanReplayError(f"stream {step} {inst}: input {name} is not produced earlier")
        for atom in inst.domain:
            if atom not in problem.init and atom not in certified:
                raise PlanReplayError(f"stream {step} {inst}: domain fact {atom} does not hold")
        certified.update(inst.certified)
        produced.update(inst.outputs)
    state = set(problem.init) | certified
    for step, action in enumerate(plan.actions):
        for name in action.args:
            if _is_optimistic(name) and name not in produced:
                raise PlanReplayError(f"action {step} {action}: {name} is bound by no stream")
        pre, adds, dels = _ground(domain, action)
        for lit in pre:
            if not _holds(lit, state):
                raise PlanReplayError(f"action {step} {action}: precondition {lit} does not hold")
        state.difference_update(dels)
        state.update(adds)
    for lit in problem.goal:
        if not _holds(lit, state):
            raise PlanReplayError(f"goal {lit} does not hold after the plan")


def canonical_key(
    actions: Sequence[GroundAction], stream_plan: Iterable[StreamInstance]
) -> tuple[str, ...]:
    """The skeleton's identity for the search: its stream plan as a set, with optimistic
    objects renamed by first appearance in the actions.

    Plans that differ only in which optimistic object is which get one key; so do plans that
    differ only in the order of actions that need no stream (when ``clean`` happens), since the
    search would bind exactly the same streams for both.
    """
    names: dict[str, str] = {}
    for action in actions:
        for obj in action.args:
            if _is_optimistic(obj) and obj not in names:
                names[obj] = f"?{len(names)}"

    def rename(obj: str) -> str:
        if _is_optimistic(obj) and obj not in names:
            names[obj] = f"?{len(names)}"
        return names.get(obj, obj)

    return tuple(
        sorted(
            " ".join((s.stream, *map(rename, s.inputs), "->", *map(rename, s.outputs)))
            for s in stream_plan
        )
    )


def action_multiset(
    actions: Iterable[GroundAction], ignore: Iterable[str] = ()
) -> frozenset[tuple[GroundAction, int]]:
    """The plan's actions without their order (``ignore`` drops actions by name)."""
    skip = set(ignore)
    return frozenset(Counter(a for a in actions if a.name not in skip).items())

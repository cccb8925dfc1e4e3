"""From an action plan over optimistic objects to its stream plan, and checks on both."""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass

from planner.abstract.instantiate import (
    OPTIMISTIC_PREFIX,
    OptimisticInstantiation,
    StreamInstance,
    fact_bindings,
)
from planner.abstract.support import Explainer, Support
from planner.pddl.semantics import Evaluator, Universe, index_facts
from planner.pddl.structs import (
    Action,
    Atom,
    ConditionalEffect,
    Domain,
    Formula,
    FunctionTerm,
    Literal,
    Problem,
    Stream,
    StreamFunction,
    StreamSet,
)


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


def _schema(domain: Domain, action: GroundAction) -> tuple[Action, dict[str, str]]:
    schema = domain.action(action.name)
    if len(schema.params) != len(action.args):
        raise PlanReplayError(
            f"{action}: {schema.name} takes {len(schema.params)} arguments, got {len(action.args)}"
        )
    return schema, dict(zip(schema.param_names, action.args, strict=True))


def _simple(domain: Domain, problem: Problem, inst: OptimisticInstantiation) -> bool:
    """STRIPS actions, a goal of literals and no lazy tests: the stream plan follows from
    literals alone."""
    return domain.is_strips and not problem.goal_conditions and not inst.tests


def recover_stream_plan(
    actions: Sequence[GroundAction],
    domain: Domain,
    problem: Problem,
    inst: OptimisticInstantiation,
    *,
    cache: dict[GroundAction, tuple[Atom, ...]] | None = None,
    streams: StreamSet | None = None,
    preconditions: Sequence[Formula | None] | None = None,
) -> tuple[tuple[StreamInstance, ...], tuple[int, ...]]:
    """The streams whose certified facts the plan needs, with the streams they depend on, and
    for each the index of the first action that needs it (``len(actions)``: only the goal).

    Ordered as the plan needs them: by the first action that needs a stream (directly or
    through a stream that consumes its outputs), then by level, which keeps producers before
    consumers. Early actions' streams come first, so a search meets their failures early.
    A ``(:rule ...)`` is never in a stream plan: the streams certifying its domain facts are,
    and its own facts follow from theirs.

    With ADL conditions, derived predicates, conditional effects or lazy tests, what an action
    needs is the support of its precondition in the optimistic state before it
    (:mod:`planner.abstract.support`), of its conditional effects' conditions (whether or not
    they fire, so that they do the same once bound) and of its cost's function domain.
    ``preconditions`` may give, per action, the disjunct of its precondition the planner
    planned it by (:class:`planner.abstract.compile.PlannerTask`).
    """
    if preconditions is not None and len(preconditions) != len(actions):
        raise ValueError("one precondition (or None) per action is needed")
    cache = {} if cache is None else cache
    first_step: dict[int, int] = {}
    rules: set[int] = set()  # rules needed: not queried, their facts follow (see replay)

    def need(index: int, step: int) -> None:
        stack = [index]
        while stack:
            i = stack.pop()
            if i in first_step or i in rules:
                continue
            if inst.instances[i].kind == "rule":
                rules.add(i)
            else:
                first_step[i] = step
            for atom in inst.instances[i].domain:
                if atom not in problem.init and atom in inst.certifier:
                    stack.append(inst.certifier[atom])

    if _simple(domain, problem, inst):
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
    else:
        _recover_adl(actions, domain, problem, inst, streams, need, first_step, preconditions)
    order = sorted(first_step, key=lambda i: (first_step[i], inst.instances[i].level, i))
    return tuple(inst.instances[i] for i in order), tuple(first_step[i] for i in order)


def _recover_adl(
    actions: Sequence[GroundAction],
    domain: Domain,
    problem: Problem,
    inst: OptimisticInstantiation,
    streams: StreamSet | None,
    need: Callable[[int, int], None],
    needed: Mapping[int, int],
    preconditions: Sequence[Formula | None] | None,
) -> None:
    universe = Universe.of_problem(domain, problem, inst.objects)
    certified = index_facts(inst.facts)  # the same for every step: indexed once
    functions = {f.name: f for f in streams.functions} if streams is not None else {}
    state: frozenset[Atom] = frozenset(problem.init)
    # Lazily evaluated predicates are false in O but may hold in R: their (absent) facts must
    # not narrow the candidates of a quantifier.
    lazy = frozenset(a.predicate for a in inst.tests)

    def demand(support: Support | None, what: str, step: int) -> None:
        if support is None:
            raise PlanReplayError(
                f"{what} does not hold even with every stream's facts (the top-k planner's "
                "plan and this planner's reading of the domain disagree)"
            )
        for i in sorted(support):
            need(i, step)

    for step, action in enumerate(actions):
        schema, mapping = _schema(domain, action)
        ev = Evaluator(domain, universe, state, background=certified, uncertain=lazy)
        ex = Explainer(domain, ev, inst, problem.init, needed)
        for name in action.args:
            if _is_optimistic(name) and name in inst.producer:
                need(inst.producer[name], step)
        chosen = preconditions[step] if preconditions is not None else None
        condition = chosen if chosen is not None else schema.precondition
        demand(
            ex.formula(condition.substitute(mapping), {}, True),
            f"action {step} {action}: its precondition",
            step,
        )
        for term in schema.cost_terms:
            fn = functions.get(term.name)
            ground = term.substitute(mapping)
            if ground in problem.function_values or fn is None:
                continue
            values = dict(zip(fn.inputs, ground.args, strict=True))
            for atom in fn.domain:
                demand(ex.atom(atom.substitute(values), True), f"the domain of {ground}", step)
        for effect in schema.effects:
            grounded = effect.substitute(mapping)
            if grounded.condition is None:
                continue
            for env in _effect_bindings(ev, grounded):
                fires = ev.holds(grounded.condition, env)
                demand(
                    ex.formula(grounded.condition, env, fires),
                    f"action {step} {action}: the condition of {effect}",
                    step,
                )
        state = ev.effects(schema, action.args).apply(state)
    ev = Evaluator(domain, universe, state, background=certified, uncertain=lazy)
    ex = Explainer(domain, ev, inst, problem.init, needed)
    demand(ex.formula(problem.goal_formula, {}, True), "the goal", len(actions))


def _effect_bindings(ev: Evaluator, effect: ConditionalEffect) -> list[dict[str, str]]:
    """Bindings of a conditional effect's variables whose condition could hold once bound
    (the others have a positive fact of the condition missing even optimistically)."""
    if not effect.variables:
        return [{}]
    assert effect.condition is not None
    return list(ev.witnesses(effect.variables, effect.condition, {}))


def symbolic_states(
    actions: Sequence[GroundAction],
    domain: Domain,
    init: frozenset[Atom],
    *,
    universe: Universe | None = None,
    certified: Collection[Atom] = (),
) -> list[frozenset[Atom]]:
    """The fluent state before each action, and after the last (no precondition checks).

    Conditional effects read the state with ``certified`` (the stream facts) added, and
    quantified ones range over ``universe``'s objects."""
    states = [init]
    if all(not domain.action(a.name).effects for a in actions):
        state = set(init)
        for action in actions:
            _, adds, dels = _ground(domain, action)
            state.difference_update(dels)
            state.update(adds)
            states.append(frozenset(state))
        return states
    if universe is None:
        raise ValueError("conditional effects need the universe of objects to be evaluated")
    extra = index_facts(certified)
    current = init
    for action in actions:
        schema, _ = _schema(domain, action)
        ev = Evaluator(domain, universe, current, background=extra)
        current = ev.effects(schema, action.args).apply(current)
        states.append(current)
    return states


def replay(
    plan: AbstractPlan, domain: Domain, problem: Problem, streams: StreamSet | None = None
) -> None:
    """Check a plan fact by fact; raise :class:`PlanReplayError` at the first violation.

    Streams run first, in order: each one's domain facts must hold in the initial state or be
    certified by an earlier stream, and its inputs must be real or already produced. Then every
    action's arguments must exist and have their parameter's type, its precondition must hold
    in the state (static certified facts and derived predicates included), and the goal at the
    end. A lazily evaluated predicate (``streams`` says which) is false only where the stream
    plan tests it: a condition that depends on an untested one does not hold. The stream
    file's rules add their facts wherever their domain holds.
    """
    certified: set[Atom] = set()
    produced: set[str] = set()
    tested: set[Atom] = set()
    universe = Universe.of_problem(domain, problem)
    rules = [s for s in streams.streams if s.kind == "rule"] if streams is not None else []
    certified |= _rule_closure(rules, problem.init, certified)
    for step, inst in enumerate(plan.stream_plan):
        for name in inst.inputs:
            if _is_optimistic(name) and name not in produced:
                raise PlanReplayError(f"stream {step} {inst}: input {name} is not produced earlier")
        for atom in inst.domain:
            if atom not in problem.init and atom not in certified:
                raise PlanReplayError(f"stream {step} {inst}: domain fact {atom} does not hold")
        if inst.kind == "predicate":
            if inst.certified[0] in problem.init:
                raise PlanReplayError(
                    f"stream {step} {inst}: tests {inst.certified[0]}, which holds initially"
                )
            tested.add(inst.certified[0])
        else:
            certified.update(inst.certified)
            certified |= _rule_closure(rules, problem.init, certified)
        produced.update(inst.outputs)
        for obj in inst.typed_outputs:
            universe.add(obj)
    state: frozenset[Atom] = frozenset(problem.init) | certified
    lazy = _LazyFacts(streams, problem, tested)
    simple = domain.is_strips and not lazy.predicates and not problem.goal_conditions
    functions = {f.name: f for f in streams.functions} if streams is not None else {}
    for step, action in enumerate(plan.actions):
        schema, mapping = _schema(domain, action)
        for name, param in zip(action.args, schema.params, strict=True):
            if _is_optimistic(name) and name not in produced:
                raise PlanReplayError(f"action {step} {action}: {name} is bound by no stream")
            if not universe.fits(name, param):
                kind = "object" if name not in universe else param.type_text()
                raise PlanReplayError(
                    f"action {step} {action}: {name} is not a known {kind} ({param.name})"
                )
        if simple:
            pre, adds, dels = _ground(domain, action)
            for lit in pre:
                if not _holds(lit, state):
                    raise PlanReplayError(
                        f"action {step} {action}: precondition {lit} does not hold"
                    )
            state = (state - set(dels)) | set(adds)
            continue
        ev = lazy.evaluator(domain, universe, state)
        for part in (*schema.preconditions, *schema.conditions):
            _check(ev, part.substitute(mapping), f"action {step} {action}: precondition", lazy)
        for term in schema.cost_terms:
            _check_cost(term.substitute(mapping), problem, functions, state, f"action {step}")
        state = ev.effects(schema, action.args).apply(state)
    if simple:
        for lit in problem.goal:
            if not _holds(lit, state):
                raise PlanReplayError(f"goal {lit} does not hold after the plan")
        return
    ev = lazy.evaluator(domain, universe, state)
    for part in (*problem.goal, *problem.goal_conditions):
        _check(ev, part, "goal", lazy, after=" after the plan")


def _rule_closure(
    rules: Sequence[Stream], init: frozenset[Atom], certified: set[Atom]
) -> set[Atom]:
    """The facts the rules add to ``init`` and ``certified`` (applied until none is new)."""
    if not rules:
        return set()
    facts: dict[str, set[tuple[str, ...]]] = defaultdict(set)
    for atom in (*init, *certified):
        facts[atom.predicate].add(atom.args)
    new: set[Atom] = set()
    changed = True
    while changed:
        changed = False
        for rule in rules:
            for binding in fact_bindings(rule.domain, facts):
                for atom in rule.certified:
                    fact = atom.substitute(binding)
                    if fact not in init and fact not in certified and fact not in new:
                        new.add(fact)
                        facts[fact.predicate].add(fact.args)
                        changed = True
    return new


class _LazyFacts:
    """What replay knows of lazily evaluated predicates: true where initial, false where the
    stream plan tested them or their domain does not hold, unknown elsewhere."""

    def __init__(self, streams: StreamSet | None, problem: Problem, tested: set[Atom]) -> None:
        self.tests = (
            {s.certified[0].predicate: s for s in streams.streams if s.kind == "predicate"}
            if streams is not None
            else {}
        )
        self.predicates = frozenset(self.tests)
        self.init = problem.init
        self.tested = tested
        self.asked: list[Atom] = []  # unknown atoms a check depended on
        self._state: frozenset[Atom] = frozenset()

    def evaluator(self, domain: Domain, universe: Universe, state: frozenset[Atom]) -> Evaluator:
        self._state = state
        return Evaluator(domain, universe, state, unknown=self.unknown, uncertain=self.predicates)

    def unknown(self, atom: Atom) -> bool:
        decl = self.tests.get(atom.predicate)
        if decl is None or atom in self.tested:
            return False
        mapping = dict(zip(decl.inputs, atom.args, strict=True))
        if not all(a.substitute(mapping) in self._state for a in decl.domain):
            return False  # outside its domain the predicate is false
        self.asked.append(atom)
        return True


def _check(ev: Evaluator, formula: Formula, what: str, lazy: _LazyFacts, after: str = "") -> None:
    lazy.asked.clear()
    value = ev.truth(formula, {})
    if value is True:
        return
    if value is False:
        raise PlanReplayError(f"{what} {formula} does not hold{after}")
    untested = ", ".join(sorted({str(a) for a in lazy.asked}))
    raise PlanReplayError(
        f"{what} {formula} depends on {untested}, lazily evaluated but tested by no stream "
        "of the plan"
    )


def _check_cost(
    term: FunctionTerm,
    problem: Problem,
    functions: Mapping[str, StreamFunction],
    state: frozenset[Atom],
    what: str,
) -> None:
    """A function-valued cost must have a value: in the initial state, or by its stream
    function where that function's domain holds."""
    if term in problem.function_values:
        return
    fn = functions.get(term.name)
    if fn is None:
        if any(t.name == term.name for t in problem.function_values) or functions:
            raise PlanReplayError(f"{what}: the cost {term} has no value (none in :init)")
        return  # no stream file given: the value comes from a function replay cannot see
    mapping = dict(zip(fn.inputs, term.args, strict=True))
    for atom in fn.domain:
        if atom.substitute(mapping) not in state:
            raise PlanReplayError(
                f"{what}: the cost {term} is undefined: the domain fact "
                f"{atom.substitute(mapping)} of function {fn.name} does not hold"
            )


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

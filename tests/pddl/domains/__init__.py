"""Small test domains, one per construct of the language, with pure-Python samplers.

Each case is a folder here (``domain.pddl``, ``stream.pddl``, ``problem.pddl``) and an entry
in :data:`CASES`: the values of its objects, its samplers, and a check of a bound plan against
the real values (poses that overlap, offsets that tip over, a cost that does not add up). The
helpers run a case through any planner: :func:`abstract` (K* or SymK), :func:`search` (a
:class:`TreeSearch` with any policy), :func:`bound` (the solution as a :class:`BoundPlan`).
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from planner.abstract import AbstractConfig, AbstractResult, plan_abstract, replay
from planner.abstract.skeleton import AbstractPlan
from planner.pddl import Domain, Problem, StreamSet, load_domain, load_problem, load_streams
from planner.search.binding import BoundPlan, plan_cost, stream_contexts
from planner.search.mcts import BaselinePolicy, Policy, SearchResult, TreeSearch
from planner.streams import (
    Failure,
    StreamAdapter,
    StreamRuntime,
    bind_streams,
    from_fn,
    from_function,
    from_test,
)

HERE = Path(__file__).resolve().parent


@dataclass(frozen=True)
class Block:
    """A block's value: its name (to tell blocks apart in fluents) and width."""

    name: str
    width: float = 1.0


Log = list[tuple[str, tuple[Any, ...], Any]]  # (stream, inputs, what else the sampler saw)
Bindings = Callable[[random.Random, Log], Mapping[str, StreamAdapter]]


@dataclass(frozen=True)
class Case:
    """One test domain: parsed files, object values, samplers and a value-level check."""

    name: str
    constructs: tuple[str, ...]  # the language constructs it exercises
    domain: Domain
    streams: StreamSet
    problem: Problem
    make_bindings: Bindings = field(repr=False)
    check: Callable[[Case, BoundPlan], None] = field(repr=False)

    def runtime(self, seed: int, log: Log | None = None) -> StreamRuntime:
        return bind_streams(
            self.streams, self.make_bindings(random.Random(seed), log if log is not None else [])
        )

    @property
    def initial_values(self) -> dict[str, Any]:
        return {o.name: o.name for o in self.problem.objects} | dict(self.problem.values)

    def value(self, bound: BoundPlan, name: str) -> Any:
        return bound.values.get(name, self.problem.values.get(name, name))


def load(name: str) -> Case:
    """The case called ``name`` (see :data:`CASES`)."""
    spec = CASES[name]
    folder = HERE / name
    domain = load_domain(folder / "domain.pddl")
    streams = load_streams(folder / "stream.pddl", domain)
    parsed = load_problem(folder / "problem.pddl", domain)
    problem = Problem(
        parsed.name,
        parsed.domain_name,
        parsed.objects,
        parsed.init,
        parsed.goal,
        parsed.source,
        values=spec.values,
        goal_conditions=parsed.goal_conditions,
        function_values=parsed.function_values,
    )
    return Case(name, spec.constructs, domain, streams, problem, spec.bindings, spec.check)


def abstract(
    case: Case, backend: str, *, k: int = 8, seed: int = 0, problem: Problem | None = None
) -> AbstractResult:
    """k skeletons of ``case`` from the top-k planner ``backend``; every one replays."""
    target = problem or case.problem
    result = plan_abstract(
        case.domain,
        case.streams,
        target,
        AbstractConfig(k=k, backend=backend, timeout_s=120),
        functions=case.runtime(seed),
    )
    for plan in result.plans:
        replay(plan, case.domain, target, case.streams)
    return result


def search(
    case: Case,
    plans: Sequence[AbstractPlan],
    *,
    seed: int = 0,
    policy: Callable[[list[list[Any]]], Policy] | None = None,
    budget_s: float = 30.0,
    log: Log | None = None,
) -> tuple[TreeSearch, SearchResult]:
    """A tree search over ``plans`` (the baseline unless ``policy`` builds another from the
    plans' stream contexts)."""
    states = [stream_contexts(p, case.domain, case.problem) for p in plans]
    chosen = policy(states) if policy is not None else BaselinePolicy()
    ts = TreeSearch(
        plans,
        states,
        case.initial_values,
        case.runtime(seed, log),
        chosen,
        fluents=case.domain.fluent_predicates,
    )
    return ts, ts.run(deadline=time.perf_counter() + budget_s)


def bound(case: Case, ts: TreeSearch, result: SearchResult, seed: int = 0) -> BoundPlan:
    """The solution of a search, with its real cost."""
    assert result.solved and result.plan_index is not None
    skeleton = ts.skeletons[result.plan_index]
    values = {**case.initial_values, **result.values}
    cost = plan_cost(skeleton, case.domain, case.problem, values, case.runtime(seed))
    return BoundPlan(skeleton, values, cost)


# --- the line world: blocks of some width at positions x inside regions (lo, hi) -----------


def _uniform(rng: random.Random, block: Block, region: tuple[float, float]) -> float:
    lo, hi = region
    return rng.uniform(lo + block.width / 2, hi - block.width / 2)


def _overlap(b1: Block, x1: float, b2: Block, x2: float) -> bool:
    return abs(x1 - x2) < (b1.width + b2.width) / 2


def _line_check(case: Case, plan: BoundPlan) -> None:
    """Blocks end where the plan puts them, inside their regions, overlapping nowhere."""
    where: dict[str, float] = {}
    for obj in case.problem.objects:
        if obj.type == "block" or obj.type in ("tool",):
            start = next(
                a.args[1]
                for a in case.problem.init
                if a.predicate == "at" and a.args[0] == obj.name
            )
            where[obj.name] = float(case.problem.values[start])
    for action in plan.skeleton.actions:
        if action.name == "place":
            b, p, r = action.args
            block, x = case.value(plan, b), float(case.value(plan, p))
            lo, hi = case.value(plan, r)
            assert lo + block.width / 2 - 1e-9 <= x <= hi - block.width / 2 + 1e-9, (b, x, r)
            where[b] = x
    names = sorted(where)
    for i, n1 in enumerate(names):
        for n2 in names[i + 1 :]:
            b1, b2 = case.value(plan, n1), case.value(plan, n2)
            assert not _overlap(b1, where[n1], b2, where[n2]), (n1, where[n1], n2, where[n2])


def _line_values(
    blocks: Mapping[str, float], regions: Mapping[str, tuple[float, float]]
) -> dict[str, Any]:
    values: dict[str, Any] = dict(regions)
    for name, x in blocks.items():
        values[name] = Block(name)
        values[f"x0-{name}"] = x
    return values


def _pose_sampler(rng: random.Random, log: Log) -> StreamAdapter:
    def sample(block: Block, region: tuple[float, float]) -> tuple[float]:
        log.append(("sample-pose", (block, region), None))
        return (_uniform(rng, block, region),)

    return from_fn(sample)


def _cfree(b1: Block, x1: float, b2: Block, x2: float) -> bool:
    return not _overlap(b1, x1, b2, x2)


@dataclass(frozen=True)
class _Spec:
    constructs: tuple[str, ...]
    values: dict[str, Any]
    bindings: Bindings
    check: Callable[[Case, BoundPlan], None]


# --- derived --------------------------------------------------------------------------------

LINE = _line_values({"a": 1.0, "b": 4.0}, {"start": (0.0, 10.0), "goal": (20.0, 22.6)})


def _derived_bindings(rng: random.Random, log: Log) -> Mapping[str, StreamAdapter]:
    return {"sample-pose": _pose_sampler(rng, log), "test-cfree": from_test(_cfree)}


# --- tower ----------------------------------------------------------------------------------

TIP = 0.3  # a block on another tips over beyond this offset from its centre


def _tower_bindings(rng: random.Random, log: Log) -> Mapping[str, StreamAdapter]:
    return {
        "sample-offset": from_fn(lambda b, c: (rng.uniform(-1.0, 1.0),)),
        "test-stable": from_test(lambda b, c, o: abs(o) <= TIP),
    }


def _tower_check(case: Case, plan: BoundPlan) -> None:
    stacks = [a for a in plan.skeleton.actions if a.name == "stack"]
    assert stacks
    for action in stacks:
        assert abs(case.value(plan, action.args[2])) <= TIP, action


# --- disjunction ----------------------------------------------------------------------------

LEFT_REACH, RIGHT_REACH = 6.0, 14.0  # the left arm reaches x <= 6, the right one x >= 14
DISJUNCTION = _line_values(
    {"egg": 5.5},
    {"start": (5.0, 15.0), "left-bin": (0.0, 4.0), "right-bin": (16.0, 20.0), "box": (8, 9)},
)


def _disjunction_bindings(rng: random.Random, log: Log) -> Mapping[str, StreamAdapter]:
    return {
        "sample-pose": _pose_sampler(rng, log),
        "test-left": from_test(lambda b, x: x <= LEFT_REACH),
        "test-right": from_test(lambda b, x: x >= RIGHT_REACH),
    }


def _disjunction_check(case: Case, plan: BoundPlan) -> None:
    for action in plan.skeleton.actions:
        if action.name == "place":
            lo, hi = case.value(plan, action.args[2])
            assert lo <= float(case.value(plan, action.args[1])) <= hi, action
    for action in plan.skeleton.actions:
        x = float(case.value(plan, action.args[1]))
        assert x <= LEFT_REACH or x >= RIGHT_REACH, (action, x)  # some arm reaches it


# --- quantifiers ----------------------------------------------------------------------------


def _quantifier_bindings(rng: random.Random, log: Log) -> Mapping[str, StreamAdapter]:
    def grasp(block: Block) -> tuple[float] | Failure:
        if rng.random() < 0.5:
            return Failure("no grasp found")
        return (rng.uniform(-0.4, 0.4),)

    return {
        "sample-pose": _pose_sampler(rng, log),
        "sample-grasp": from_fn(grasp),
        "test-cfree": from_test(_cfree),
    }


# --- effects --------------------------------------------------------------------------------

STABLE = (0.2, 0.8)  # a slot carries its block safely between these positions on the tray


def _effects_bindings(rng: random.Random, log: Log) -> Mapping[str, StreamAdapter]:
    return {
        "sample-slot": from_fn(lambda b: (rng.random(),)),
        "test-stable": from_test(lambda s, place: STABLE[0] <= s <= STABLE[1]),
        "plan-route": from_fn(lambda a, b: (f"route {a}->{b}",)),
    }


def _effects_check(case: Case, plan: BoundPlan) -> None:
    """Every block rides in a stable slot (else the carry drops it)."""
    loads = [a for a in plan.skeleton.actions if a.name == "load"]
    assert {a.args[0] for a in loads} == {"a", "b"}
    for action in loads:
        slot = case.value(plan, action.args[1])
        assert STABLE[0] <= slot <= STABLE[1], action


# --- either ---------------------------------------------------------------------------------

EITHER = _line_values(
    {"cube": 1.0, "hammer": 3.0, "vice": 6.0}, {"start": (0.0, 10.0), "goal": (20.0, 30.0)}
)


def _either_bindings(rng: random.Random, log: Log) -> Mapping[str, StreamAdapter]:
    return {"sample-pose": _pose_sampler(rng, log)}


def _either_check(case: Case, plan: BoundPlan) -> None:
    assert all(a.args[0] != "vice" for a in plan.skeleton.actions)  # a fixture is never moved
    for action in plan.skeleton.actions:
        if action.name == "place":
            lo, hi = case.value(plan, action.args[2])
            assert lo <= float(case.value(plan, action.args[1])) <= hi


# --- costs ----------------------------------------------------------------------------------


def _costs_bindings(rng: random.Random, log: Log) -> Mapping[str, StreamAdapter]:
    return {"sample-grasp": from_fn(lambda b: (rng.choice(["top", "side"]),))}


def _costs_check(case: Case, plan: BoundPlan) -> None:
    """The bound plan costs its roads (from the problem's :init) plus 1 per pick or place."""
    from planner.pddl import FunctionTerm

    expected = 0.0
    for action in plan.skeleton.actions:
        if action.name == "drive":
            expected += case.problem.function_values[FunctionTerm("road", action.args)]
        else:
            expected += 1.0
    assert plan.cost == expected


# --- functions ------------------------------------------------------------------------------

VIEW_MIN, VIEW_MAX = 0.5, 2.0  # a view is this far from the block
DIST_BOUND = 0.5  # the declared lower bound of (dist ?q1 ?q2): no two views are closer
FUNCTIONS = {"q0": 0.0, "a": 10.0, "b": -3.0}


def _functions_bindings(rng: random.Random, log: Log) -> Mapping[str, StreamAdapter]:
    def view(block_x: float) -> tuple[float]:
        return (block_x + rng.choice([-1.0, 1.0]) * rng.uniform(VIEW_MIN, VIEW_MAX),)

    def dist(q1: float, q2: float) -> float:
        log.append(("dist", (q1, q2), None))
        return abs(q1 - q2)

    return {
        "sample-view": from_fn(view),
        "dist": from_function(dist, lower_bound=DIST_BOUND),
    }


def _functions_check(case: Case, plan: BoundPlan) -> None:
    """The bound plan costs the distance it really moves, plus 1 per inspection."""
    expected = 0.0
    for action in plan.skeleton.actions:
        if action.name == "move":
            q1, q2 = (float(case.value(plan, q)) for q in action.args)
            expected += abs(q1 - q2)
        else:
            expected += 1.0
    assert plan.cost is not None and abs(plan.cost - expected) < 1e-9, (plan.cost, expected)


# --- fluents --------------------------------------------------------------------------------

FLUENTS = _line_values({"a": 1.0, "b": 3.0, "c": 5.0}, {"start": (0.0, 10.0), "goal": (20.0, 23.5)})


def _fluent_bindings(rng: random.Random, log: Log) -> Mapping[str, StreamAdapter]:
    def sample(
        block: Block, region: tuple[float, float], *, fluents: list[tuple[Any, ...]]
    ) -> tuple[float] | Failure:
        log.append(("sample-free-pose", (block, region), list(fluents)))
        standing = [(f[1], float(f[2])) for f in fluents if f[0] == "at" and f[1] != block]
        for _ in range(50):
            x = _uniform(rng, block, region)
            if not any(_overlap(block, x, other, ox) for other, ox in standing):
                return (x,)
        return Failure(f"no free place for {block.name} in 50 tries")

    return {"sample-free-pose": from_fn(sample)}


# --- predicate ------------------------------------------------------------------------------


def _predicate_bindings(rng: random.Random, log: Log) -> Mapping[str, StreamAdapter]:
    def collide(b1: Block, x1: float, b2: Block, x2: float) -> bool:
        log.append(("collide", (b1, x1, b2, x2), None))
        return _overlap(b1, x1, b2, x2)

    return {"sample-pose": _pose_sampler(rng, log), "collide": from_test(collide)}


# --- rule -----------------------------------------------------------------------------------

REACH = 22.0  # the gripper reaches x <= 22: half the goal poses
RULE = _line_values({"a": 1.0}, {"start": (0.0, 10.0), "goal": (20.0, 24.0)})


def _rule_bindings(rng: random.Random, log: Log) -> Mapping[str, StreamAdapter]:
    return {
        "sample-pose": _pose_sampler(rng, log),
        "test-reachable": from_test(lambda b, x: x <= REACH),
    }


def _rule_check(case: Case, plan: BoundPlan) -> None:
    _line_check(case, plan)
    place = next(a for a in plan.skeleton.actions if a.name == "place")
    assert float(case.value(plan, place.args[1])) <= REACH


CASES: dict[str, _Spec] = {
    "derived": _Spec(
        (":derived", "exists", "not", "and", "negated derived precondition"),
        LINE,
        _derived_bindings,
        _line_check,
    ),
    "safe": _Spec(
        (":derived", "forall and imply in a derived body", "derived precondition"),
        LINE,
        _derived_bindings,
        _line_check,
    ),
    "tower": _Spec(
        (":derived (recursive)", "or in a derived body", "derived goal"),
        {"a": Block("a"), "b": Block("b"), "c": Block("c")},
        _tower_bindings,
        _tower_check,
    ),
    "disjunction": _Spec(
        ("or", "imply", "or in the goal"),
        DISJUNCTION,
        _disjunction_bindings,
        _disjunction_check,
    ),
    "quantifiers": _Spec(
        ("exists", "forall", "forall in the goal"),
        LINE,
        _quantifier_bindings,
        _line_check,
    ),
    "effects": _Spec(
        ("when", "forall effect"),
        {"a": Block("a"), "b": Block("b")},
        _effects_bindings,
        _effects_check,
    ),
    "either": _Spec(("either",), EITHER, _either_bindings, _either_check),
    "costs": _Spec(("numeric function costs from :init",), {}, _costs_bindings, _costs_check),
    "functions": _Spec(
        ("stream :function costs",), FUNCTIONS, _functions_bindings, _functions_check
    ),
    "fluents": _Spec(("stream :fluents",), FLUENTS, _fluent_bindings, _line_check),
    "predicate": _Spec(("stream :predicate",), LINE, _predicate_bindings, _line_check),
    "rule": _Spec(("stream :rule",), RULE, _rule_bindings, _rule_check),
}

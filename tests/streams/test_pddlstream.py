"""PDDLStream's stream map as it is: its adapters with PDDLStream's meanings, plain functions for
(:function ...) and (:predicate ...), PDDLStream's init and goal, and a tiny domain brought over
unchanged (tests/streams/pddlstream_tiny) planned by the baseline and the learned planner."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pytest

from planner.api import plan
from planner.domains import load_domain_folder
from planner.pddl import Atom, Literal, parse_domain, parse_streams
from planner.pddl.parser import with_stream_declarations
from planner.pddl.structs import Exists, ForAll, Imply, Or
from planner.streams import Failure, Last, StreamBindingError, bind_streams
from planner.streams.adapters import TEST_ANSWERED, TEST_FALSE
from planner.streams.pddlstream import (
    ALL_GIVEN,
    EMPTY_LIST,
    NONE_FOUND,
    ONCE,
    PDDLStreamProblemError,
    empty_gen,
    fn_from_constant,
    from_constant,
    from_fn,
    from_gen_fn,
    from_list_fn,
    from_list_gen_fn,
    from_sampler,
    from_test,
    negate_test,
    problem_from_init,
)

TINY = Path(__file__).resolve().parent / "pddlstream_tiny"


def answers(adapter: Any, n: int, *inputs: Any, key: Any = "k") -> list[Any]:
    return [adapter.next_outputs(inputs, key) for _ in range(n)]


def test_from_fn_gives_one_output_per_input_binding() -> None:
    calls: list[float] = []

    def ik(p: float) -> tuple[float]:
        calls.append(p)
        return (p + 1,)

    adapter = from_fn(ik)
    assert answers(adapter, 3, 2.0) == [  # its one output is its last: the search asks no more
        Last((3.0,)),
        Failure(ONCE, exhausted=True),
        Failure(ONCE, exhausted=True),
    ]
    assert answers(adapter, 1, 5.0, key="other") == [Last((6.0,))]
    assert calls == [2.0, 5.0]
    assert answers(from_fn(lambda p: None), 2, 1.0) == [
        Failure(NONE_FOUND, exhausted=True),
        Failure(ONCE, exhausted=True),
    ]


def test_generators_lists_samplers_and_constants() -> None:
    def gen(x: int) -> Any:
        yield (x,)
        yield None  # nothing this time, not the end
        yield (x + 1,)

    assert answers(from_gen_fn(gen), 4, 1) == [
        (1,),
        None,
        (2,),
        Failure("the generator is exhausted", exhausted=True),
    ]

    def batches(x: int) -> Any:
        yield [(x,), (x + 1,)]
        yield []
        yield [(x + 2,)]

    assert answers(from_list_gen_fn(batches), 5, 0)[:4] == [(0,), (1,), None, (2,)]
    assert answers(from_list_fn(lambda x: [(x,), (-x,)]), 3, 4) == [
        (4,),
        Last((-4,)),
        Failure(ALL_GIVEN, exhausted=True),
    ]
    assert answers(from_list_fn(lambda x: []), 2, 4) == [
        Failure(EMPTY_LIST, exhausted=True),
        Failure(ALL_GIVEN, exhausted=True),
    ]
    draws = iter(range(10))
    assert answers(from_sampler(lambda x: (next(draws),)), 3, 0) == [(0,), (1,), (2,)]
    assert answers(from_constant((7, 8)), 2, 0) == [Last((7, 8)), Failure(ONCE, exhausted=True)]
    assert answers(empty_gen(), 1, 0)[0] == Failure("the generator is exhausted", exhausted=True)
    assert from_test(negate_test(lambda x: x > 2)).next_outputs((1,), "k") == Last(())
    said_no = from_test(lambda x: x > 2)
    assert said_no.next_outputs((1,), "k") == Failure(TEST_FALSE, exhausted=True)
    # PDDLStream's tests answer once per input binding: asking again is exhausted at once
    said_yes = from_test(lambda x: x > 2)
    assert said_yes.next_outputs((3,), "k") == Last(())
    assert said_yes.next_outputs((3,), "k") == Failure(TEST_ANSWERED, exhausted=True)
    assert said_yes.next_outputs((3,), "other") == Last(())
    assert fn_from_constant(2.5)("anything") == 2.5


DOMAIN = """(define (domain d)
  (:predicates (at ?q))
  (:action go :parameters (?a ?b)
    :precondition (and (at ?a) (Link ?a ?b) (not (Closed ?b)))
    :effect (and (at ?b) (not (at ?a)) (increase (total-cost) (Dist ?a ?b)))))
"""
STREAMS = """(define (stream d)
  (:stream sample-link :inputs (?a) :domain (Place ?a) :outputs (?b)
    :certified (and (Place ?b) (Link ?a ?b)))
  (:predicate (Closed ?b) (Place ?b))
  (:function (Dist ?a ?b) (and (Place ?a) (Place ?b))))
"""


def test_a_stream_map_binds_plain_functions_and_ignores_case() -> None:
    domain = parse_domain(DOMAIN)
    streams = parse_streams(STREAMS, domain, file="stream.pddl")
    runtime = bind_streams(
        streams,
        {
            "Sample-Link": from_fn(lambda a: (a + 1,)),
            "Closed": lambda b: b > 3,
            "DIST": lambda a, b: abs(b - a),
        },
    )
    assert runtime.evaluate("dist", (1, 4)) == 3
    assert runtime.query("closed", (5,)).success is False  # it holds: planning assumed not
    assert runtime.query("sample-link", (1,)).outputs == (2,)
    with pytest.raises(StreamBindingError, match="'sample-link' is bound to a plain function"):
        bind_streams(streams, {"sample-link": lambda a: (a,), "closed": bool, "dist": max})
    # an entry the stream file never declares (a helper kept in the map) is left out, as
    # PDDLStream does, with a warning that names it; a strict domain refuses it
    helper = {"sample-link": from_fn(lambda a: (a,)), "closed": bool, "dist": max}
    helper["collision"] = lambda p, q: p == q
    assert "collision" not in bind_streams(streams, helper).names
    with pytest.raises(StreamBindingError, match=r"'collision'.*declares no such stream"):
        bind_streams(streams, helper, strict=True)
    with pytest.raises(StreamBindingError, match="two bindings for stream 'closed'"):
        bind_streams(streams, {"closed": bool, "CLOSED": bool})


def test_problem_from_pddlstream_init_and_goal() -> None:
    domain = with_stream_declarations(
        parse_domain(DOMAIN), parse_streams(STREAMS, parse_domain(DOMAIN))
    )
    pose = (1.0, 2.0)
    problem = problem_from_init(
        domain,
        [("Place", "Home"), ("Place", pose), ("at", "Home"), ("=", ("Dist", "Home", pose), 2.5)],
        ("and", ("at", pose), ("not", ("at", "Home"))),
        name="p",
    )
    assert {o.name for o in problem.objects} == {"home", "v0"}
    assert problem.values["v0"] == pose and problem.values["home"] == "Home"
    assert Atom("place", ("v0",)) in problem.init and Atom("at", ("home",)) in problem.init
    assert problem.goal == (
        Literal(Atom("at", ("v0",))),
        Literal(Atom("at", ("home",)), positive=False),
    )
    assert list(problem.function_values.values()) == [2.5]
    with pytest.raises(PDDLStreamProblemError, match=r"init\[1\]: predicate 'place' takes 1"):
        problem_from_init(domain, [("Place", "a"), ("Place", "a", "b")], ("at", "a"))
    with pytest.raises(PDDLStreamProblemError, match=r"init\[0\]: expected a fact such as"):
        problem_from_init(domain, ["Place"], ("at", "a"))
    with pytest.raises(
        PDDLStreamProblemError, match=r"scene\.json: goal: variable \?q is not quantified"
    ):
        problem_from_init(domain, [("Place", "a")], ("at", "?q"), source="scene.json")
    with pytest.raises(PDDLStreamProblemError, match="'a' and 'A' are one name"):
        problem_from_init(domain, [("Place", "a"), ("Place", "A")], ("at", "a"))


def test_goals_built_from_python_take_the_whole_language() -> None:
    """PDDLStream's goals are tuples built in Python: ``or``, ``not`` over a compound,
    ``imply`` and quantifiers over ``'?x'`` variables become the goal's formulas; the
    literal conjuncts stay literals."""
    domain = with_stream_declarations(
        parse_domain(DOMAIN), parse_streams(STREAMS, parse_domain(DOMAIN))
    )
    pose = (1.0, 2.0)
    problem = problem_from_init(
        domain,
        [("Place", "Home"), ("Place", pose), ("at", "Home")],
        (
            "and",
            ("not", ("at", "Home")),
            ("or", ("at", pose), ("exists", ["?q"], ("and", ("Place", "?q"), ("at", "?q")))),
            ("forall", ["?q"], ("imply", ("at", "?q"), ("Place", "?q"))),
        ),
    )
    assert problem.goal == (Literal(Atom("at", ("home",)), positive=False),)
    either, every = problem.goal_conditions
    assert isinstance(either, Or) and isinstance(either.parts[1], Exists)
    assert str(either) == "(or (at v0) (exists (?q - object) (and (place ?q) (at ?q))))"
    assert isinstance(every, ForAll) and isinstance(every.body, Imply)
    with pytest.raises(PDDLStreamProblemError, match=r"goal\[1\]: expected a variable"):
        problem_from_init(domain, [("at", "Home")], ("exists", ["q"], ("at", "?q")))


@pytest.mark.slow
@pytest.mark.parametrize("planner", ["baseline", "learned"])
def test_a_pddlstream_domain_plans_unchanged(planner: str) -> None:
    loaded = load_domain_folder(TINY)
    calls = loaded.spec.bindings.__globals__["CALLS"]  # type: ignore[union-attr]
    calls.clear()
    result = plan("tiny-2", planner, domain=loaded, seed=3, budget_s=60)
    assert result.status == "solved" and result.valid, result.message
    values = {**result.problem.values, **result.values}
    placed = {a.args[0]: values[a.args[1]] for a in result.actions if a.name == "place"}
    assert set(placed) == {"a", "b"} and all(5.5 <= p <= 7.0 for p in placed.values())
    assert abs(placed["a"] - placed["b"]) >= 1.0  # the fluent stream kept them apart
    # the fluent stream saw the pose of the block placed before, as PDDLStream gives it
    first = next(a for a in result.actions if a.name == "place")
    later = [f for b, f in calls if b != first.args[0].upper()]
    assert any(("atpose", first.args[0].upper(), placed[first.args[0]]) in f for f in later)
    queried = {q.stream for q in result.result.queries}
    assert {"blocked", "test-reachable", "inverse-kinematics"} <= queried
    moves = [a for a in result.actions if a.name == "move"]
    assert result.result.bound is not None and result.result.bound.cost is not None
    assert result.result.bound.cost >= sum(
        abs(values[m.args[1]] - values[m.args[0]]) for m in moves
    )


@pytest.mark.parametrize("planner", ["baseline", "learned"])
def test_a_search_whose_streams_are_all_exhausted_ends_instead_of_asking_again(
    planner: str,
) -> None:
    """PDDLStream's lists, functions and tests say when they have nothing more: once every
    stream plan is exhausted the run ends as failed; with the rule off it asks them again and
    again until a budget is spent: a bound on its queries, so that a busy machine (which once
    gave the run's 3 s to anything but its queries) cannot change the outcome."""
    loaded = load_domain_folder(TINY)
    base = loaded.spec.bindings

    def finite(problem: Any, rng: Any) -> dict[str, Any]:
        out = dict(base(problem, rng))
        out["sample-pose"] = from_list_fn(lambda b, r, **fluents: [(6.0,), (6.5,)])
        out["test-reachable"] = from_test(lambda q: False)  # nothing is ever reachable
        return out

    exhaustible = dataclasses.replace(
        loaded, spec=dataclasses.replace(loaded.spec, bindings=finite)
    )
    result = plan("tiny-2", planner, domain=exhaustible, seed=0, budget_s=120)
    assert result.status == "failed", result.message
    queried = [q for q in result.result.queries if q.stream == "test-reachable"]
    assert queried and all(q.exhausted for q in queried)
    if planner == "learned":
        again = plan(
            "tiny-2",
            "learned:exhaustion=off",
            domain=exhaustible,
            seed=0,
            budget_s=120,  # a net only: the query bound ends the run (in about 0.5 s)
            max_queries=50,
        )
        # Off, it never ends: the lists and functions that gave their last are asked again
        # (their failures come back as known failures, TreeSearch.memo_exhausted, unasked).
        assert again.status == "timeout"
        assert again.message == "no plan (query budget of 50 reached)"
        assert any(q.exhausted and q.success for q in again.result.queries)

"""Bindings must match declarations; queries are timed and a raising sampler is a failure."""

from __future__ import annotations

import random
from collections.abc import Iterator

import pytest

from planner.domains import LoadedDomain
from planner.pddl import Problem
from planner.streams import (
    Failure,
    StreamBindingError,
    bind_streams,
    from_fn,
    from_gen_fn,
    from_test,
)


def test_missing_binding_names_stream_and_file(line: LoadedDomain) -> None:
    with pytest.raises(StreamBindingError) as info:
        bind_streams(line.streams, {"sample-pose": from_fn(lambda b, r: (0.0,))})
    assert info.value.stream == "test-reachable"
    assert "stream.pddl" in str(info.value) and "'test-reachable'" in str(info.value)


def test_binding_for_undeclared_stream_is_left_out_or_refused_when_strict(
    line: LoadedDomain, caplog: pytest.LogCaptureFixture
) -> None:
    bindings = {
        "sample-pose": from_fn(lambda b, r: (0.0,)),
        "test-reachable": from_test(lambda b, p: True),
        "sample-grasp": from_fn(lambda b: (1,)),
    }
    with caplog.at_level("WARNING"):
        runtime = bind_streams(line.streams, bindings)
    assert "sample-grasp" not in runtime.names
    assert "'sample-grasp' is left out" in caplog.text and "stream.pddl" in caplog.text
    with pytest.raises(StreamBindingError, match=r"'sample-grasp'.*declares no such stream"):
        bind_streams(line.streams, bindings, strict=True)


def test_test_adapter_on_stream_with_outputs_is_refused(line: LoadedDomain) -> None:
    bindings = {"sample-pose": from_test(lambda b, r: True), "test-reachable": from_test(bool)}
    with pytest.raises(StreamBindingError, match="has outputs"):
        bind_streams(line.streams, bindings)


def test_generator_is_one_per_input_binding_and_exhausts(line: LoadedDomain) -> None:
    def gen(width: float, region: tuple[float, float]) -> Iterator[tuple[float]]:
        yield (region[0],)
        yield (region[1],)

    rt = bind_streams(
        line.streams, {"sample-pose": from_gen_fn(gen), "test-reachable": from_test(bool)}
    )
    first = [rt.query("sample-pose", (1.0, (0.0, 5.0))) for _ in range(3)]
    assert [r.outputs for r in first] == [(0.0,), (5.0,), None]
    assert first[2].reason == "the generator is exhausted" and first[2].error is None
    other = rt.query("sample-pose", (1.0, (2.0, 3.0)))
    assert other.outputs == (2.0,)


def test_raising_sampler_is_a_recorded_failure(line: LoadedDomain) -> None:
    def broken(width: float, region: tuple[float, float]) -> tuple[float]:
        raise RuntimeError("IK diverged")

    rt = bind_streams(
        line.streams, {"sample-pose": from_fn(broken), "test-reachable": from_test(bool)}
    )
    result = rt.query("sample-pose", (1.0, (0.0, 5.0)))
    assert not result.success
    assert result.error == "RuntimeError: IK diverged"
    assert result.wall_s >= 0 and result.cpu_s >= 0


def test_wrong_number_of_outputs_is_a_failure_not_a_crash(line: LoadedDomain) -> None:
    rt = bind_streams(
        line.streams,
        {"sample-pose": from_fn(lambda w, r: (1.0, 2.0)), "test-reachable": from_test(bool)},
    )
    result = rt.query("sample-pose", (1.0, (0.0, 5.0)))
    assert result.outputs is None and result.error is not None and "2 outputs" in result.error


def test_line_samplers_respect_the_scene(line: LoadedDomain, line_problem: Problem) -> None:
    rt = line.runtime(line_problem, seed=3)
    values = line_problem.values
    for _ in range(50):
        result = rt.query("sample-pose", (values["a"], values["goal"]))
        assert result.outputs is not None
        (x,) = result.outputs
        assert 1.25 <= x <= 3.75  # inside goal [1, 4], half a 0.5 block from each end
        assert rt.query("test-reachable", (values["a"], x)).success
    assert not rt.query("test-reachable", (values["a"], 12.0)).success
    same = line.runtime(line_problem, seed=3).query("sample-pose", (0.5, (1.0, 4.0)))
    again = line.runtime(line_problem, seed=3).query("sample-pose", (0.5, (1.0, 4.0)))
    assert same.outputs == again.outputs  # seeded


def test_a_sampler_may_say_why_it_found_nothing(line: LoadedDomain) -> None:
    def picky(width: float, region: tuple[float, float]) -> tuple[float] | Failure:
        lo, hi = region
        return (lo,) if hi - lo >= width else Failure(f"region {hi - lo:g} wide, needs {width:g}")

    rt = bind_streams(
        line.streams, {"sample-pose": from_fn(picky), "test-reachable": from_test(bool)}
    )
    failed = rt.query("sample-pose", (2.0, (0.0, 1.5)))
    assert not failed.success and failed.outputs is None
    assert failed.reason == "region 1.5 wide, needs 2" and failed.error is None
    fine = rt.query("sample-pose", (1.0, (0.0, 1.5)))
    assert fine.outputs == (0.0,) and fine.reason is None
    # A reason that is not text is stored as its text, not refused later by the event.
    odd = bind_streams(
        line.streams,
        {"sample-pose": from_fn(lambda w, r: Failure(42)), "test-reachable": from_test(bool)},  # type: ignore[arg-type]
    ).query("sample-pose", (1.0, (0.0, 1.5)))
    assert odd.reason == "42" and not odd.success


# --- the stream file's other declarations -----------------------------------------------------


def test_a_lazy_predicate_succeeds_when_its_test_says_false() -> None:
    from tests.pddl.domains import Block, load

    case = load("predicate")
    rt = case.runtime(0)
    a, b = Block("a"), Block("b")
    apart = rt.query("collide", (a, 20.5, b, 22.0))
    assert apart.success and apart.outputs == ()
    overlapping = rt.query("collide", (a, 20.5, b, 21.0))
    assert not overlapping.success
    assert overlapping.reason == "(collide ?b ?p ?b2 ?p2) holds" and overlapping.error is None


def test_a_rule_needs_no_binding_and_always_holds() -> None:
    from tests.pddl.domains import load

    case = load("rule")
    rt = case.runtime(0)
    assert "rule-1" in rt.names
    assert rt.query("rule-1", ("a", 21.0, (20.0, 24.0))).success
    with pytest.raises(StreamBindingError, match="'rule-1' is a rule; rules need no Python"):
        bind_streams(
            case.streams,
            {**case.make_bindings(random.Random(0), []), "rule-1": from_test(bool)},
        )


def test_functions_bind_with_from_function_and_check_their_values() -> None:
    from planner.streams import FunctionValueError, from_function
    from tests.pddl.domains import load

    case = load("functions")
    bindings = dict(case.make_bindings(random.Random(0), []))
    rt = bind_streams(case.streams, bindings)
    assert rt.evaluate("dist", (1.0, 3.5)) == 2.5
    assert rt.lower_bound("dist") == 0.5
    with pytest.raises(StreamBindingError, match="bind it with from_function"):
        bind_streams(case.streams, {**bindings, "dist": from_fn(lambda a, b: (1.0,))})
    with pytest.raises(StreamBindingError, match="from_function is for those"):
        bind_streams(case.streams, {**bindings, "sample-view": from_function(abs)})
    negative = bind_streams(case.streams, {**bindings, "dist": from_function(lambda a, b: -1.0)})
    with pytest.raises(FunctionValueError, match="costs are non-negative"):
        negative.evaluate("dist", (0.0, 1.0))
    with pytest.raises(ValueError, match="must not be negative"):
        from_function(abs, lower_bound=-1.0)


def test_a_stream_with_fluents_receives_the_facts_of_its_context() -> None:
    from planner.pddl import Atom
    from planner.streams import StreamContext
    from tests.pddl.domains import Block, load

    case = load("fluents")
    log: list[tuple[str, tuple[object, ...], object]] = []
    rt = case.runtime(0, log)
    a, b = Block("a"), Block("b")
    state = frozenset({Atom("at", ("a", "opt-p1")), Atom("at", ("c", "x0-c")), Atom("hand-empty")})
    context = StreamContext(state, {"a": a, "c": Block("c"), "opt-p1": 21.0, "x0-c": 5.0})
    result = rt.query("sample-free-pose", (b, (20.0, 23.5)), context=context)
    assert result.success
    (seen,) = [entry[2] for entry in log]
    assert seen == [("at", a, 21.0), ("at", Block("c"), 5.0)]  # only (at ...), with values
    assert abs(result.outputs[0] - 21.0) >= 1.0  # the sampler kept clear of a
    rt.query("sample-free-pose", (b, (20.0, 23.5)))  # no context: no facts
    assert log[-1][2] == []

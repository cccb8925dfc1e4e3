"""The parser reads the shipped domains and says file, line and column for bad input."""

from __future__ import annotations

import pytest

from planner.domains import LoadedDomain
from planner.pddl import (
    Atom,
    Domain,
    Literal,
    PDDLError,
    UnsupportedPDDLError,
    parse_domain,
    parse_problem,
    parse_streams,
    write_domain,
    write_problem,
)

MINI = """
(define (domain mini)
  (:requirements :strips :typing :negative-preconditions :equality :action-costs)
  (:types block pose - object)
  (:constants home - pose)
  (:predicates (at ?b - block ?p - pose) (free ?p - pose) (ok ?p))
  (:functions (total-cost) - number)
  (:action move
    :parameters (?b - block ?from ?to - pose)
    :precondition (and (at ?b ?from) (free ?to) (not (= ?from ?to)) (not (ok ?to)))
    :effect (and (at ?b ?to) (not (at ?b ?from)) (increase (total-cost) 3))))
"""


def mini() -> Domain:
    return parse_domain(MINI, file="mini.pddl")


def error_of(text: str, *, stream: bool = False, strict: bool = True) -> PDDLError:
    """The error of a strict parse (a lenient one declares undeclared names by their use:
    tests/pddl/test_leniency.py)."""
    with pytest.raises(PDDLError) as info:
        if stream:
            parse_streams(text, mini(), file="stream.pddl", strict=strict)
        else:
            parse_domain(text, file="bad.pddl", strict=strict)
    return info.value


def test_typed_domain_with_costs_and_equality() -> None:
    d = mini()
    move = d.action("move")
    assert [(p.name, p.type) for p in move.params] == [
        ("?b", "block"),
        ("?from", "pose"),
        ("?to", "pose"),
    ]
    assert Literal(Atom("=", ("?from", "?to")), positive=False) in move.preconditions
    assert Literal(Atom("ok", ("?to",)), positive=False) in move.preconditions
    assert move.cost == 3 and d.uses_action_costs
    assert d.constants[0].name == "home"
    assert d.supertypes("block") == ("block", "object")


def test_written_domain_and_problem_parse_back_the_same() -> None:
    d = mini()
    again = parse_domain(write_domain(d), file="again.pddl")
    assert again.actions == d.actions
    assert again.predicates == d.predicates
    problem = parse_problem(
        "(define (problem p) (:domain mini) (:objects a - block x - pose)"
        " (:init (at a x) (free home)) (:goal (at a home)))",
        d,
    )
    back = parse_problem(write_problem(problem, d), d)
    assert back.init == problem.init and back.goal == problem.goal


def test_shipped_domains_parse(kitchen: LoadedDomain, line: LoadedDomain) -> None:
    assert {a.name for a in kitchen.domain.actions} == {"move", "pick", "place", "clean", "cook"}
    assert set(kitchen.streams.names) == {
        "sample-grasp",
        "sample-placement",
        "inverse-kinematics",
        "plan-motion",
    }
    assert line.streams.stream("test-reachable").is_test
    assert line.streams.stream("sample-pose").outputs[0].type == "pose"


def test_unclosed_list_points_at_the_end_and_the_opening() -> None:
    err = error_of("(define (domain d)\n  (:predicates (p ?x)\n")
    assert err.file == "bad.pddl" and err.line == 3
    assert "expected ')'" in str(err) and "opened at line 2, column 3" in str(err)


def test_unknown_predicate_in_action_is_located() -> None:
    text = MINI.replace("(free ?to) (not", "(fre ?to) (not")
    err = error_of(text)
    assert err.line == 10 and "undeclared predicate 'fre'" in str(err)
    assert str(err).startswith("bad.pddl:10:")


def test_wrong_arity_and_undeclared_variable() -> None:
    assert "takes 2 arguments but 1" in str(error_of(MINI.replace("(at ?b ?to)", "(at ?b)")))
    err = error_of(MINI.replace("(free ?to)", "(free ?elsewhere)"))
    assert "variable ?elsewhere is not declared in action move" in str(err)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ((":action-costs", ":durative-actions"), "requirement :durative-actions is not supported"),
        (("(not (ok ?to))", "(< (total-cost) 3)"), "numeric conditions (< ...) are not supported"),
        (("(increase (total-cost) 3)", "(assign (total-cost) 3)"), "numeric effect 'assign'"),
        (("(increase (total-cost) 3)", "(increase (total-cost) (+ 1 2))"), "arithmetic (+ ...)"),
        (("(:functions (total-cost) - number)", "(:durative-action go)"), ":durative-action"),
        (("(:functions (total-cost) - number)", "(:functions (f) - pose)"), "object fluents"),
    ],
)
def test_unsupported_constructs_say_so(change: tuple[str, str], message: str) -> None:
    err = error_of(MINI.replace(*change))
    assert isinstance(err, UnsupportedPDDLError)
    assert message in str(err)


def test_trailing_garbage_and_empty_file() -> None:
    err = error_of(MINI + "\n(extra)")
    assert "closes the definition, but more follows" in str(err)
    assert (err.line, err.column) == (11, 77)  # the ")" that closed (define ...)
    assert "empty" in str(error_of("; nothing but a comment\n"))


STREAM = """
(define (stream mini)
  (:stream sample-free
    :inputs (?b)
    :domain (at ?b home)
    :outputs (?p)
    :certified (free ?p)))
"""


def test_stream_file_parses() -> None:
    streams = parse_streams(STREAM, mini(), file="stream.pddl")
    s = streams.stream("sample-free")
    assert s.inputs == ("?b",) and s.output_names == ("?p",)
    assert s.domain == (Atom("at", ("?b", "home")),) and s.line == 3


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("(at ?b home)", "(free home)"), "input ?b must appear in a :domain fact"),
        (("(free ?p)", "(free ?q)"), "variable ?q is not declared in stream sample-free"),
        (("(free ?p)", "(cooked ?p)"), "undeclared predicate 'cooked'"),
        ((":outputs (?p)", ":outputs (?p) :fluents (free)"), "'free', which no action changes"),
        ((":outputs (?p)", ":outputs (?p) :fluents (atx)"), "'atx', which is not declared"),
        ((":outputs (?p)", ":ouputs (?p)"), "unknown keyword :ouputs"),
        (("(:stream sample-free", "(:optimizer sample-free"), "(:optimizer ...) blocks are not"),
    ],
)
def test_stream_errors(change: tuple[str, str], message: str) -> None:
    err = error_of(STREAM.replace(*change), stream=True)
    assert err.file == "stream.pddl"
    assert message in str(err)


def test_problem_errors_name_the_object() -> None:
    d = mini()
    with pytest.raises(PDDLError, match="unknown object or constant 'b'"):
        parse_problem(
            "(define (problem p) (:domain mini) (:objects a - block)\n"
            "  (:init (at b home)) (:goal (at a home)))",
            d,
            file="p.pddl",
        )
    with pytest.raises(PDDLError, match="problem is for domain 'other'"):
        parse_problem("(define (problem p) (:domain other) (:goal (ok home)))", d)
    with pytest.raises(PDDLError, match=r"expected a \(:goal"):
        parse_problem("(define (problem p) (:domain mini) (:init))", d)


def test_costs_without_declaring_total_cost_as_pddlstream_writes_them() -> None:
    text = MINI.replace("(:functions (total-cost) - number)", "(:functions (dist ?a ?b))")
    text = text.replace("(increase (total-cost) 3)", "(increase (total-cost) (dist ?from ?to))")
    d = parse_domain(text, file="pddlstream.pddl")
    assert d.uses_action_costs and d.action("move").cost_terms[0].name == "dist"
    assert "(:functions (total-cost) - number (dist ?a - object ?b - object) - number)" in (
        write_domain(d)
    )


def test_function_terms_are_checked_in_costs_and_values() -> None:
    text = MINI.replace("(:functions (total-cost) - number)", "(:functions (dist ?a ?b))")
    err = error_of(text.replace("(increase (total-cost) 3)", "(increase (total-cost) (dst ?to))"))
    assert "undeclared function 'dst' in action move" in str(err)
    err = error_of(text.replace("(increase (total-cost) 3)", "(increase (total-cost) (dist ?to))"))
    assert "function 'dist' takes 2 arguments but 1 are given" in str(err)
    d = parse_domain(text)

    def problem(init: str) -> PDDLError:
        with pytest.raises(PDDLError) as info:
            parse_problem(
                f"(define (problem p) (:domain mini) (:objects a - block x - pose)\n"
                f"  (:init {init}) (:goal (at a home)))",
                d,
                file="p.pddl",
            )
        return info.value

    assert "function 'dist' takes 2 arguments" in str(problem("(= (dist x) 1)"))
    assert "expected a non-negative number, not '-1'" in str(problem("(= (dist x home) -1)"))
    assert "given a value twice" in str(problem("(= (dist x home) 1) (= (dist x home) 2)"))
    assert "unknown object or constant 'y'" in str(problem("(= (dist x y) 1)"))

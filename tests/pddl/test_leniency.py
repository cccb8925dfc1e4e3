"""PDDLStream's leniency: names declared by their use, repeated declarations that agree, derived
predicates that declare themselves; each one listed, each clash an error naming both places,
and all of it refused under ``strict``."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pytest

from planner.cli import main
from planner.domains import load_domain_folder
from planner.pddl import (
    Domain,
    PDDLError,
    UnsupportedPDDLError,
    parse_domain,
    parse_problem,
    parse_streams,
)
from planner.pddl.parser import load_pddlstream, with_stream_declarations

# As PDDLStream users write them: static facts (graspable, region) appear in init and in stream
# declarations only, the stream file declares the cost function, and on is declared twice.
DOMAIN = """(define (domain lenient)
  (:requirements :strips :equality)
  (:predicates (at ?b ?p) (holding ?b) (handempty) (on ?b ?p)
               (on ?b ?p))
  (:derived (placed ?b) (exists (?p) (at ?b ?p)))
  (:action pick
    :parameters (?b ?p)
    :precondition (and (graspable ?b) (at ?b ?p) (handempty))
    :effect (and (holding ?b) (not (at ?b ?p)) (not (handempty))
                 (increase (total-cost) (cost ?b))))
  (:action place
    :parameters (?b ?p)
    :precondition (and (holding ?b) (pose ?b ?p))
    :effect (and (at ?b ?p) (handempty) (not (holding ?b)))))
"""

STREAMS = """(define (stream lenient)
  (:stream sample-pose
    :inputs (?b ?r)
    :domain (and (graspable ?b) (region ?r))
    :outputs (?p)
    :certified (and (pose ?b ?p) (contained ?b ?p ?r)))
  (:function (cost ?b) (graspable ?b))
  (:function (duration ?b ?r) (and (graspable ?b) (region ?r))))
"""

PROBLEM = """(define (problem one) (:domain lenient)
  (:objects a p0 table)
  (:init (graspable a) (region table) (at a p0) (handempty) (colour a))
  (:goal (and (placed a) (not (stacked a)))))
"""


def test_undeclared_predicates_and_functions_are_declared_by_their_first_use() -> None:
    domain = parse_domain(DOMAIN, file="domain.pddl")
    by_name = {i.name: i for i in domain.inferred}
    graspable = by_name["graspable"]
    assert (graspable.kind, graspable.arity, graspable.use) == ("predicate", 1, "action pick")
    assert (graspable.file, graspable.line, graspable.column) == ("domain.pddl", 8, 24)
    assert str(graspable).startswith("domain.pddl:8:24: predicate 'graspable' (1 argument)")
    assert by_name["pose"].use == "action place" and by_name["pose"].arity == 2
    assert (by_name["cost"].kind, by_name["cost"].arity) == ("function", 1)
    assert domain.predicate("graspable").arity == 1 and domain.function("cost").arity == 1


def test_a_derived_predicate_declares_itself_and_an_agreeing_repeat_is_accepted() -> None:
    domain = parse_domain(DOMAIN, file="domain.pddl")
    kinds = {(i.kind, i.name) for i in domain.inferred}
    assert ("derived", "placed") in kinds and ("repeat", "on") in kinds
    repeat = next(i for i in domain.inferred if i.kind == "repeat")
    assert repeat.line == 4 and "declared twice, alike (declared at domain.pddl:3:52)" in str(
        repeat
    )
    assert [p.name for p in domain.predicates].count("on") == 1
    assert domain.derived[0].name == "placed"


def test_a_repeat_that_disagrees_is_an_error_naming_both_places() -> None:
    text = DOMAIN.replace("(on ?b ?p))\n  (:derived", "(on ?b))\n  (:derived")
    with pytest.raises(PDDLError) as info:
        parse_domain(text, file="domain.pddl")
    assert (info.value.line, info.value.column) == (4, 16)
    assert "predicate 'on' is declared twice and the two disagree: 2 argument(s)" in str(info.value)
    assert "declared at domain.pddl:3:52" in str(info.value)


def test_a_use_with_another_arity_is_an_error_naming_the_first_use() -> None:
    text = DOMAIN.replace("(holding ?b) (pose ?b ?p)", "(holding ?b) (graspable ?b ?p)")
    with pytest.raises(PDDLError) as info:
        parse_domain(text, file="domain.pddl")
    message = str(info.value)
    assert message.startswith("domain.pddl:13:37: predicate 'graspable' takes 1 arguments")
    assert "declared by its use in action pick at domain.pddl:8:24" in message


def test_a_stream_file_declares_static_facts_and_functions_for_the_domain() -> None:
    domain = parse_domain(DOMAIN, file="domain.pddl")
    streams = parse_streams(STREAMS, domain, file="stream.pddl")
    assert {p.name for p in streams.declared} == {"region", "contained"}
    assert [f.name for f in streams.declared_functions] == ["duration"]
    region = next(i for i in streams.inferred if i.name == "region")
    assert (region.file, region.line, region.use) == (
        "stream.pddl",
        4,
        "stream sample-pose :domain",
    )
    duration = next(i for i in streams.inferred if i.name == "duration")
    assert duration.kind == "function" and duration.use == "(:function duration ...)"
    full = with_stream_declarations(domain, streams)
    assert full.predicate("contained").arity == 3 and full.function("duration").arity == 2
    # the stream's cost function is the one the domain's action uses (declared by that use)
    assert streams.function("cost").inputs == ("?b",)


def test_a_clash_between_the_domain_and_the_stream_file_names_both() -> None:
    domain = parse_domain(DOMAIN, file="domain.pddl")
    text = STREAMS.replace("(and (graspable ?b) (region ?r))", "(and (graspable ?b ?r))")
    with pytest.raises(PDDLError) as info:
        parse_streams(text, domain, file="stream.pddl")
    assert str(info.value).startswith("stream.pddl:4:18: predicate 'graspable' takes 1")
    assert "declared by its use in action pick at domain.pddl:8:24" in str(info.value)


def test_a_problem_declares_its_own_facts_and_goal_predicates() -> None:
    problem = parse_problem(PROBLEM, _files_domain(), file="problem.pddl")
    assert {(i.name, i.arity) for i in problem.inferred} == {("colour", 1), ("stacked", 1)}
    assert all(i.file == "problem.pddl" and i.use == "problem one" for i in problem.inferred)


def _files_domain() -> Domain:
    domain = parse_domain(DOMAIN, file="domain.pddl")
    return with_stream_declarations(domain, parse_streams(STREAMS, domain, file="stream.pddl"))


@pytest.mark.parametrize(
    ("which", "message"),
    [
        ("domain", "domain.pddl:4:16: predicate 'on' is declared twice (declared at"),
        ("action", "undeclared predicate 'graspable' in action pick (declare it in the domain"),
        ("derived", "derived predicate 'placed' is not declared in :predicates"),
        ("stream", "stream.pddl:4:33: undeclared predicate 'region' in stream sample-pose :domain"),
        (
            "function",
            "stream.pddl:8:14: function duration is not declared in the domain's :functions",
        ),
        ("problem", "undeclared predicate 'colour' in problem one"),
    ],
)
def test_strict_refuses_each_inference_where_it_is(which: str, message: str) -> None:
    once = DOMAIN.replace("(on ?b ?p)\n               (on ?b ?p))", "(on ?b ?p))")
    declared = once.replace(
        "(on ?b ?p))",
        "(on ?b ?p) (graspable ?b) (pose ?b ?p) (placed ?b) (region ?r) (contained ?b ?p ?r)"
        " (stacked ?b) (colour ?b))\n  (:functions (cost ?b))",
    )
    with pytest.raises(PDDLError) as info:
        if which == "domain":
            parse_domain(DOMAIN, file="domain.pddl", strict=True)
        elif which == "action":
            parse_domain(
                declared.replace(" (graspable ?b) ", " ", 1), file="domain.pddl", strict=True
            )
        elif which == "derived":
            parse_domain(declared.replace(" (placed ?b) ", " ", 1), file="domain.pddl", strict=True)
        elif which == "stream":
            domain = parse_domain(declared.replace(" (region ?r)", ""), strict=True)
            parse_streams(STREAMS, domain, file="stream.pddl", strict=True)
        elif which == "function":
            domain = parse_domain(declared, strict=True)
            parse_streams(STREAMS, domain, file="stream.pddl", strict=True)
        else:
            domain = parse_domain(declared.replace(" (colour ?b)", ""), strict=True)
            parse_problem(PROBLEM, domain, file="problem.pddl", strict=True)
    assert message in str(info.value)
    assert "without --strict" in str(info.value)


def test_a_likely_typo_in_an_action_is_pointed_out() -> None:
    text = DOMAIN.replace("(holding ?b) (pose ?b ?p)", "(holdin ?b) (pose ?b ?p)")
    domain = parse_domain(text, file="domain.pddl")
    typo = next(i for i in domain.inferred if i.name == "holdin")
    assert typo.near == "holding" and "(did you mean 'holding'?)" in typo.message
    # static facts named alike in a stream file are PDDLStream's idiom, not typos
    streams = parse_streams(STREAMS.replace("(region ?r)", "(regions ?r)"), domain)
    assert all(not i.near for i in streams.inferred)


def test_optimizer_and_temporal_blocks_say_what_to_write_instead() -> None:
    domain = parse_domain(DOMAIN)
    text = STREAMS.replace(
        "(:function (duration", "(:optimizer gurobi (:variables (?p) :inputs (?b)))\n (:x (duration"
    )
    with pytest.raises(UnsupportedPDDLError) as info:
        parse_streams(text, domain, file="stream.pddl")
    assert str(info.value).startswith("stream.pddl:8:3: (:optimizer ...) blocks are not supported")
    assert "(:variables ...) as a (:stream ...) whose :outputs" in str(info.value)
    with pytest.raises(UnsupportedPDDLError, match="write each durative action as an :action"):
        parse_domain(DOMAIN.replace(":equality", ":durative-actions"))


def _write(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "domain.pddl").write_text(DOMAIN)
    (folder / "stream.pddl").write_text(STREAMS)
    (folder / "problems").mkdir(exist_ok=True)
    (folder / "problems" / "one.pddl").write_text(PROBLEM)
    return folder


def test_tamp_check_lists_every_inference(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = _write(tmp_path / "lenient")
    assert main(["check", str(folder)]) == 0
    out = capsys.readouterr().out
    assert f"{folder}/domain.pddl: domain lenient: 2 actions" in out
    assert f"  {folder}/domain.pddl:8:24: warning: predicate 'graspable' (1 argument)" in out
    assert f"{folder}/stream.pddl:4:33: warning: predicate 'region'" in out
    assert f"{folder}/problems/one.pddl:3:61: warning: predicate 'colour'" in out
    assert "3 of 3 files load; 10 declarations inferred (declare them" in out
    assert main(["check", str(folder), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["kind"] for r in rows] == ["domain", "stream", "problem"]
    assert sum(len(r["inferred"]) for r in rows) == 10
    assert main(["check", "--strict", str(folder)]) == 1
    out = capsys.readouterr().out
    assert "domain.pddl: does not load:" in out and "is declared twice" in out
    assert "stream.pddl: does not load: its domain" in out


def test_a_lenient_domain_folder_loads_with_one_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    folder = _write(tmp_path / "lenient")
    (folder / "domain.py").write_text(
        "from planner.domains import DomainSpec\n"
        "DOMAIN = DomainSpec(name='lenient', problem_from_scene=lambda s, d, seed: None,"
        " bindings=None)\n"
    )
    with caplog.at_level(logging.WARNING, logger="planner.domains.registry"):
        loaded = load_domain_folder(folder)
    assert loaded.domain.predicate("contained").arity == 3
    warned = [r.getMessage() for r in caplog.records]
    assert len(warned) == 1 and "domain lenient: 8 declarations inferred from use" in warned[0]
    assert f"`tamp check {folder.resolve()}` lists them" in warned[0]
    domain, streams = load_pddlstream(folder / "domain.pddl", folder / "stream.pddl")
    assert domain.predicate("region").arity == 1 and len(streams.inferred) == 3


@pytest.mark.parametrize("folder", ["planner/domains/kitchen", "planner/domains/line"])
def test_the_shipped_domains_need_no_leniency(folder: str) -> None:
    root = Path(__file__).resolve().parents[2]
    domain, streams = load_pddlstream(
        root / folder / "domain.pddl", root / folder / "stream.pddl", strict=True
    )
    assert not domain.inferred and not streams.inferred and not streams.declared

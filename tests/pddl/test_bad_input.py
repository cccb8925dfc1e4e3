"""Bad input found on published PDDLStream domains: each error names file, line, column and
what was expected."""

from __future__ import annotations

from pathlib import Path

import pytest

from planner.pddl import PDDLError, load_domain, load_streams, parse_domain, parse_streams
from planner.pddl.structs import StreamSet

DOMAIN = """(define (domain d)
  (:requirements :strips :typing)
  (:types block pose)
  (:constants home - pose)
  (:predicates (at ?b - block ?p - pose) (grasp ?b - block ?g) (free ?p - pose))
  (:action move
    :parameters (?b - block ?from ?to - pose)
    :precondition (and (at ?b ?from) (free ?to))
    :effect (and (at ?b ?to) (not (at ?b ?from))))
)
"""

STREAM = """(define (stream s)
  (:stream sample-grasp
    :inputs (?b)
    :domain (at ?b home)
    :outputs (?g)
    :certified (grasp ?b ?g))
)
"""


def domain_error(text: str, file: str = "bad.pddl") -> PDDLError:
    with pytest.raises(PDDLError) as info:
        parse_domain(text, file=file)
    return info.value


def stream_error(text: str) -> PDDLError:
    with pytest.raises(PDDLError) as info:
        parse_streams(text, parse_domain(DOMAIN), file="stream.pddl")
    return info.value


def at(err: PDDLError) -> tuple[str, int, int]:
    return err.file, err.line, err.column


def test_a_non_utf8_byte_is_located(tmp_path: Path) -> None:
    path = tmp_path / "domain.pddl"
    lines = DOMAIN.encode().split(b"\n")
    lines[4] = lines[4].replace(b"(free", b"(fr\xe9e")  # latin-1 e-acute
    path.write_bytes(b"\n".join(lines))
    with pytest.raises(PDDLError) as info:
        load_domain(path)
    assert at(info.value) == (str(path), 5, 67)
    assert "byte 0xe9 is not UTF-8" in str(info.value)


def test_a_non_utf8_byte_in_a_stream_file_is_located(tmp_path: Path) -> None:
    path = tmp_path / "stream.pddl"
    path.write_bytes(STREAM.encode().replace(b"sample-grasp", b"sample-\xffgrasp"))
    with pytest.raises(PDDLError) as info:
        load_streams(path, parse_domain(DOMAIN))
    assert at(info.value) == (str(path), 2, 19)


def test_nul_bytes_inside_a_name_are_refused() -> None:
    err = stream_error(STREAM.replace("sample-grasp", "sampl\x00\x00\x00e-grasp"))
    assert at(err) == ("stream.pddl", 2, 17)
    assert "unexpected NUL" in str(err)


def test_other_control_characters_are_refused_but_not_in_comments() -> None:
    err = domain_error(DOMAIN.replace("(free ?p - pose)", "(free\x1b ?p - pose)"))
    assert at(err) == ("bad.pddl", 5, 69) and "U+001B" in str(err)
    commented = DOMAIN.replace("(:types", "; a comment with \x07 in it\n  (:types")
    assert parse_domain(commented).name == "d"


def test_a_byte_order_mark_is_accepted(tmp_path: Path) -> None:
    path = tmp_path / "domain.pddl"
    path.write_bytes(b"\xef\xbb\xbf" + DOMAIN.encode())
    assert load_domain(path).name == "d"
    # ... at the start only: one inside the file is a stray character
    err = domain_error(DOMAIN.replace("(:types", "\ufeff(:types"))
    assert at(err) == ("bad.pddl", 3, 3) and "byte-order mark" in str(err)


def test_a_stream_without_outputs_says_so() -> None:
    err = stream_error(STREAM.replace("    :outputs (?g)\n", ""))
    assert at(err) == ("stream.pddl", 5, 26)
    assert "the stream has no :outputs" in str(err) and "':outputs (?g)'" in str(err)


def test_a_missing_paren_points_near_where_it_is_missing() -> None:
    stay = "  (:action stay\n    :parameters (?b - block)\n    :effect (and))\n"
    text = DOMAIN.replace("(free ?to))", "(free ?to)").removesuffix(")\n") + stay + ")\n"
    err = domain_error(text)
    # The precondition's (and ...) swallowed :effect; the next action starts as far left as
    # the unclosed (:action move ...): that is where a ')' is missing, not at (define.
    assert at(err) == ("bad.pddl", 10, 3)
    assert "close the list opened at line 6, column 3" in str(err)


def test_a_missing_paren_at_the_end_points_at_the_open_list() -> None:
    err = domain_error(DOMAIN.rstrip().removesuffix(")"))
    assert err.line == 10 and "opened at line 1, column 1, but the file ended" in str(err)


def test_an_extra_paren_points_at_itself() -> None:
    text = DOMAIN.replace("(free ?to))", "(free ?to)))")
    err = domain_error(text)
    assert at(err) == ("bad.pddl", 8, 49)
    assert "one ')' too many" in str(err) and "opened at line 6, column 3" in str(err)


def test_an_extra_paren_closing_the_definition_points_at_itself() -> None:
    text = DOMAIN.replace("(free ?p - pose))", "(free ?p - pose)))")
    err = domain_error(text)
    assert at(err) == ("bad.pddl", 5, 81)
    assert "one ')' too many" in str(err)


def test_a_negated_certified_fact_says_certified_facts_are_positive() -> None:
    err = stream_error(STREAM.replace(":certified (grasp ?b ?g)", ":certified (not (grasp ?b ?g))"))
    assert at(err) == ("stream.pddl", 6, 16)
    assert ":certified facts must be positive atoms" in str(err)
    err = stream_error(STREAM.replace(":domain (at ?b home)", ":domain (not (at ?b home))"))
    assert ":domain facts must be positive atoms" in str(err)


def test_an_undeclared_output_type_is_refused() -> None:
    err = stream_error(STREAM.replace(":outputs (?g)", ":outputs (?g - grip)"))
    assert at(err) == ("stream.pddl", 5, 15)
    assert "type 'grip' of output ?g is not a type of the domain" in str(err)
    err = stream_error(STREAM.replace(":inputs (?b)", ":inputs (?b - blok)"))
    assert "type 'blok' of input ?b" in str(err)


def test_duplicate_types_and_constants_are_refused() -> None:
    err = domain_error(DOMAIN.replace("(:types block pose)", "(:types block pose block)"))
    assert at(err) == ("bad.pddl", 3, 22)
    assert "type 'block' is declared twice (first at line 3, column 11)" in str(err)
    err = domain_error(DOMAIN.replace("(:constants home - pose)", "(:constants home away home)"))
    assert at(err) == ("bad.pddl", 4, 25) and "constant 'home' is declared twice" in str(err)
    err = domain_error(DOMAIN.replace("(:constants", "(:types tool)\n  (:constants"))
    assert at(err) == ("bad.pddl", 4, 3)
    assert "a second (:types ...) section; the first is at line 3, column 3" in str(err)


def test_duplicate_names_are_found_in_large_files() -> None:
    """The checks are linear (docs/BENCHMARKS.md times 5 MB files); here: they still find the
    one repeat among many."""
    decls = "".join(
        f"  (:stream s{i} :inputs (?b) :domain (at ?b home) :outputs (?g) "
        f":certified (grasp ?b ?g))\n"
        for i in range(3000)
    )
    text = f"(define (stream big)\n{decls}  (:stream s17 :inputs (?b) :domain (at ?b home)"
    text += " :outputs (?g) :certified (grasp ?b ?g))\n)\n"
    err = stream_error(text)
    assert at(err) == ("stream.pddl", 3002, 3)
    assert "stream 's17' is declared twice (first at line 19, column 3)" in str(err)
    last = text.rindex("(:stream s17")
    good = parse_streams(text[:last] + "(:stream s-last" + text[last + 12 :], parse_domain(DOMAIN))
    assert isinstance(good, StreamSet) and len(good.streams) == 3001

"""The problem language: PDDL domains and problems, and PDDLStream stream declarations."""

from planner.pddl.errors import PDDLError, UnsupportedPDDLError
from planner.pddl.parser import (
    load_domain,
    load_problem,
    load_streams,
    parse_domain,
    parse_problem,
    parse_streams,
)
from planner.pddl.structs import (
    Action,
    Atom,
    Domain,
    Literal,
    Predicate,
    Problem,
    Stream,
    StreamSet,
    TypedName,
    is_variable,
)
from planner.pddl.writer import write_domain, write_problem

__all__ = [
    "Action",
    "Atom",
    "Domain",
    "Literal",
    "PDDLError",
    "Predicate",
    "Problem",
    "Stream",
    "StreamSet",
    "TypedName",
    "UnsupportedPDDLError",
    "is_variable",
    "load_domain",
    "load_problem",
    "load_streams",
    "parse_domain",
    "parse_problem",
    "parse_streams",
    "write_domain",
    "write_problem",
]

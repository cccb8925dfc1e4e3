"""Shared fixtures: the two shipped domains, parsed once."""

from __future__ import annotations

import pytest

from planner.domains import LoadedDomain, get_domain, problem_for_scene
from planner.pddl import Problem


@pytest.fixture(scope="session")
def line() -> LoadedDomain:
    return get_domain("line")


@pytest.fixture(scope="session")
def kitchen() -> LoadedDomain:
    return get_domain("kitchen")


@pytest.fixture(scope="session")
def line_problem() -> Problem:
    return problem_for_scene("line-2")[1]

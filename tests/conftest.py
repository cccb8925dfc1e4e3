"""Shared fixtures: the two shipped domains, parsed once; generated meshes cached in a folder of
the test session's own (subprocesses such as ``tamp serve`` inherit it), not the user's."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

from planner.domains import LoadedDomain, get_domain, problem_for_scene
from planner.pddl import Problem
from planner.sim.meshes import CACHE_ENV


@pytest.fixture(scope="session", autouse=True)
def mesh_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    before = os.environ.get(CACHE_ENV)
    os.environ[CACHE_ENV] = str(tmp_path_factory.mktemp("meshes"))
    yield
    if before is None:
        os.environ.pop(CACHE_ENV, None)
    else:
        os.environ[CACHE_ENV] = before


@pytest.fixture(scope="session")
def line() -> LoadedDomain:
    return get_domain("line")


@pytest.fixture(scope="session")
def kitchen() -> LoadedDomain:
    return get_domain("kitchen")


@pytest.fixture(scope="session")
def line_problem() -> Problem:
    return problem_for_scene("line-2")[1]

"""Shared fixtures: the two shipped domains, parsed once; generated meshes cached in a folder of
the test session's own (subprocesses such as ``tamp serve`` inherit it), not the user's; a
PostgreSQL server of the session's own, and a new store on each backend (``store_url``)."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from planner.domains import LoadedDomain, get_domain, problem_for_scene
from planner.pddl import Problem
from planner.sim.meshes import CACHE_ENV
from tests.postgres import PostgresMissingError, PostgresServer, postgres_server

BACKENDS = ("sqlite", "postgresql")  # every store test runs on both


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Schemathesis makes an item per API operation (``test[GET /api/runs]``) but, under pytest
    9.2, they all get the test's node id (``test``); pytest -n tells items apart by node id and
    ran one of them. Each gets its own name as its node id, as pytest gives any other item."""
    for item in items:
        if item.parent is not None and item.nodeid.rpartition("::")[2] != item.name:
            item._id = item.parent.id.child(item.name)  # type: ignore[attr-defined]


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


@pytest.fixture(scope="session")
def postgres() -> Iterator[PostgresServer]:
    """A PostgreSQL server of the session's own (tests/postgres.py); never skipped: without
    PostgreSQL installed the tests that need it fail and say how to install it."""
    try:
        with postgres_server() as server:
            yield server
    except PostgresMissingError as exc:
        pytest.fail(str(exc), pytrace=False)


@pytest.fixture(params=BACKENDS)
def store_url(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    """A new, empty store on each backend: a SQLite file, then a PostgreSQL database."""
    if request.param == "sqlite":
        return str(tmp_path / "data" / "runs.db")
    server: PostgresServer = request.getfixturevalue("postgres")
    return server.new_database()

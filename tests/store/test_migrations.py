"""Stores written by earlier versions open, are upgraded in place and keep their runs; a new
store's schema is exactly what the code reads, on SQLite and on PostgreSQL.

``data/`` holds stores the code of those versions wrote (``tests/store/data/README.md``).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import psycopg
import pytest
from alembic.autogenerate import compare_metadata
from alembic.runtime.migration import MigrationContext
from sqlalchemy import inspect, make_url

from planner.events import NodeAdded, RunFailed, RunStarted
from planner.store import RunStore
from planner.store.db import Base
from planner.store.schema import HEAD, head, revision_of
from tests.postgres import PostgresServer

DATA = Path(__file__).with_name("data")


def _load_dump(server: PostgresServer, dump: Path) -> str:
    """A new database holding what ``pg_dump`` wrote of an old store."""
    url = server.new_database("old")
    conninfo = make_url(url).set(drivername="postgresql").render_as_string(hide_password=False)
    with psycopg.connect(conninfo, autocommit=True) as conn:
        conn.execute(dump.read_text())  # type: ignore[arg-type]  # a trusted file of ours
    return url


def _old_store(name: str, tmp_path: Path, request: pytest.FixtureRequest) -> str:
    if name.endswith(".sql"):
        return _load_dump(request.getfixturevalue("postgres"), DATA / name)
    copy = tmp_path / name  # upgraded in place: never the committed file itself
    shutil.copy(DATA / name, copy)
    return str(copy)


@pytest.mark.parametrize(
    "name",
    [
        "store-42795af.db",  # before failure reasons and run owners (2026-11)
        "store-e0af99b.db",  # before benchmark owners
        "store-e0af99b.pg.sql",  # the same code's store on PostgreSQL
        "store-f9a0383.db",  # benchmark owners: the last schema before schema versions
    ],
)
def test_a_store_from_an_earlier_version_opens_upgraded_with_its_runs(
    name: str, tmp_path: Path, request: pytest.FixtureRequest
) -> None:
    url = _old_store(name, tmp_path, request)
    with RunStore(url) as store:
        with store.engine.connect() as conn:
            assert revision_of(conn) == head()
        runs = store.list_runs()
        assert sorted(r.seed for r in runs) == [1, 2]
        by_seed = {r.seed: r for r in runs}
        solved = by_seed[1]
        assert solved.status == "solved" and solved.planning_s == 1.5 and solved.queries == 3
        events = store.events(solved.id)
        assert isinstance(events[0], RunStarted) and events[0].scene == "line-2"
        assert [e.seq for e in events] == list(range(11))
        assert sum(isinstance(e, NodeAdded) for e in events) == 3
        queries = store.stream_queries(run_ids=[solved.id])
        assert [q.success for q in queries] == [True, False, True]
        assert all(q.reason is None for q in queries)  # not recorded then
        (bench,) = store.list_benches()
        assert bench.status == "done" and bench.config["seeds"] == [1, 2]
        (trial,) = store.bench_trials(bench.id)
        assert trial.seed == 1 and trial.status == "solved"

        # Its live run's process is long gone: settled, with a closing event after its last.
        assert store.mark_interrupted() == 1
        dead = store.get_run(by_seed[2].id)
        assert dead.status == "interrupted"
        closing = store.events(dead.id)[-1]
        assert isinstance(closing, RunFailed) and closing.seq == 10

        # The upgraded store records what the new columns hold.
        run_id = store.create_run("line-2", 2**40, "baseline", {})
        assert store.get_run(run_id).seed == 2**40  # 64-bit on PostgreSQL too
        assert store.mark_interrupted() == 0  # its owner, this process, lives
        assert store.get_bench(store.create_bench({"scene": "line-2"})).owner
    with RunStore(url) as again:  # opening it again changes nothing
        assert len(again.list_runs()) == 3


def test_a_new_store_has_the_schema_the_code_reads(store_url: str) -> None:
    with RunStore(store_url) as store, store.engine.connect() as conn:
        differences = compare_metadata(MigrationContext.configure(conn), Base.metadata)
        assert differences == []
        assert set(inspect(conn).get_table_names()) == {
            "alembic_version",
            "runs",
            "events",
            "stream_queries",
            "benchmarks",
            "bench_trials",
        }


def test_a_store_newer_than_the_code_is_refused_by_name(store_url: str) -> None:
    with RunStore(store_url) as store, store.engine.begin() as conn:
        conn.exec_driver_sql("UPDATE alembic_version SET version_num = '9999'")
    with pytest.raises(RuntimeError, match=r"schema revision '9999'.*newer version"):
        RunStore(store_url)


def test_without_postgresql_the_suite_says_how_to_install_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The PostgreSQL tests fail, never skip, on a machine without it, and say what to run."""
    from tests import postgres as server

    monkeypatch.setattr(server.glob, "glob", lambda _pattern: [])
    with (
        pytest.raises(
            server.PostgresMissingError, match=r"`make test`.*apt-get install postgresql"
        ),
        server.postgres_server(),
    ):
        pass


def test_the_revision_a_store_is_checked_against_is_the_newest_script() -> None:
    """Opening a current store compares with HEAD without loading Alembic: it must not lag."""
    assert head() == HEAD

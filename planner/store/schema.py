"""The store's schema is its Alembic history (``planner/store/migrations``): opening a store
brings it to the newest revision, on SQLite and on PostgreSQL alike.

Many processes open one store at once (a benchmark's trials, a dashboard's workers): the check
is one read when the store is current, and an upgrade runs under a lock, so one process upgrades
and the others find it done. SQLite: ``BEGIN IMMEDIATE`` (the database's write lock, waited for
up to 30 s) around the whole upgrade; PostgreSQL: a transaction-scoped advisory lock, and the
upgrade is one transaction (DDL is transactional there), so it happens whole or not at all.
"""

from __future__ import annotations

import functools
import logging
import sqlite3
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sqlalchemy import Connection, Engine, create_engine, event, inspect, text

if TYPE_CHECKING:
    from alembic.config import Config

log = logging.getLogger(__name__)

MIGRATIONS = Path(__file__).resolve().with_name("migrations")
VERSION_TABLE = "alembic_version"  # Alembic's: one row, the store's revision
_PG_LOCK = 0x7461_6D70_0031  # pg_advisory_xact_lock key: any constant all openers share


# The newest revision, so that opening a current store imports nothing of Alembic (0.3 s in
# every trial process); tests/store/test_migrations.py checks it is the scripts' head.
HEAD = "0005"


def _config() -> Config:
    from alembic.config import Config

    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS))
    return config


@functools.cache
def head() -> str:
    """The newest revision of the migration scripts (Alembic's view; :data:`HEAD` is what
    opening a store checks against)."""
    from alembic.script import ScriptDirectory

    revision = ScriptDirectory.from_config(_config()).get_current_head()
    if revision is None:
        raise RuntimeError(f"no schema revisions in {MIGRATIONS}: the package is broken")
    return revision


def revision_of(conn: Connection) -> str | None:
    """The store's schema revision; None for a new store or one from before versions."""
    if not inspect(conn).has_table(VERSION_TABLE):
        return None
    return conn.execute(text(f"SELECT version_num FROM {VERSION_TABLE}")).scalar()


class SchemaError(RuntimeError):
    """A store this code cannot upgrade: the message says why."""


def _upgrade_locked(conn: Connection, where: str) -> None:
    """Upgrade to the head on ``conn``, which holds the lock inside its transaction."""
    from alembic import command
    from alembic.script import ScriptDirectory

    current = revision_of(conn)
    if current == head():
        return  # another process upgraded it while this one waited for the lock
    known = {s.revision for s in ScriptDirectory.from_config(_config()).walk_revisions()}
    if current is not None and current not in known:
        raise SchemaError(
            f"run store {where}: schema revision {current!r} is unknown to this code (known: "
            f"{', '.join(sorted(known))}); a newer version of guided-tamp wrote it: upgrade "
            "guided-tamp to open it"
        )
    if current is None and inspect(conn).has_table("runs"):
        log.info("run store %s: from before schema versions; upgrading it to %s", where, head())
    elif current is None:
        log.info("run store %s: new; creating its tables (schema %s)", where, head())
    else:
        log.info("run store %s: schema %s, upgrading it to %s", where, current, head())
    config = _config()
    config.attributes["connection"] = conn
    command.upgrade(config, "head")


WAL_WAIT_S = 30.0  # as long as a writer waits for the lock


def enable_wal(dbapi_connection: Any) -> None:
    """Put a SQLite file in WAL mode. A new file's first openers race for the switch, and
    SQLite answers "database is locked" to the losers at once (the switch needs the file to
    itself and does not call the busy handler), so the switch is tried again until it is made
    or :data:`WAL_WAIT_S` has passed."""
    deadline = time.monotonic() + WAL_WAIT_S
    delay = 0.005
    while True:
        cursor = dbapi_connection.cursor()
        try:
            cursor.execute("PRAGMA journal_mode=WAL")
            return
        except sqlite3.OperationalError as exc:
            if "locked" not in str(exc) or time.monotonic() > deadline:
                raise
        finally:
            cursor.close()
        time.sleep(delay)
        delay = min(delay * 2, 0.2)


def _immediate_sqlite(engine: Engine) -> Engine:
    """An engine on the same SQLite file whose transactions take the write lock at BEGIN
    (pysqlite alone would begin none before DDL, so two openers could both add a column)."""
    locking = create_engine(engine.url, connect_args={"timeout": 30.0, "isolation_level": None})

    @event.listens_for(locking, "connect")
    def _pragmas(dbapi_connection: Any, _record: Any) -> None:
        enable_wal(dbapi_connection)
        cursor = dbapi_connection.cursor()
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.close()

    @event.listens_for(locking, "begin")
    def _begin(conn: Connection) -> None:
        conn.exec_driver_sql("BEGIN IMMEDIATE")

    return locking


def upgrade(engine: Engine) -> None:
    """Bring the store behind ``engine`` to the newest schema (creating it when new)."""
    with engine.connect() as conn:
        if revision_of(conn) == HEAD:
            return
    where = engine.url.render_as_string(hide_password=True)
    backend = engine.url.get_backend_name()
    if backend == "sqlite" and engine.url.database not in (None, "", ":memory:"):
        locking = _immediate_sqlite(engine)
        try:
            with locking.begin() as conn:
                _upgrade_locked(conn, where)
        finally:
            locking.dispose()
        return
    with engine.begin() as conn:
        if backend == "postgresql":
            conn.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": _PG_LOCK})
        _upgrade_locked(conn, where)

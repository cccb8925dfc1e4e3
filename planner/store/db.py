"""Runs, their events and every stream query, in SQLite (default) or any SQLAlchemy database.

Three tables: ``runs`` (one row per run: what was asked, how it ended), ``events`` (every event
of every run, keyed by ``(run_id, seq)``, the payload as JSON) and ``stream_queries`` (one row per
:class:`~planner.events.StreamQueried` event, flattened for training and statistics).
:class:`StoreSink` is the :class:`~planner.events.EventSink` that fills the last two in batches.
"""

from __future__ import annotations

import json
import logging
import os
import re
import sqlite3
import threading
import typing
import uuid
from collections.abc import Callable, Collection
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, ClassVar

from sqlalchemy import (
    JSON,
    URL,
    BigInteger,
    Connection,
    DateTime,
    Double,
    Engine,
    ForeignKey,
    Index,
    Integer,
    String,
    Text,
    case,
    cast,
    create_engine,
    delete,
    event,
    func,
    insert,
    make_url,
    select,
    type_coerce,
    update,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, Session, mapped_column
from sqlalchemy.pool import StaticPool

from planner.events import (
    TERMINAL_TYPES,
    BatchingSink,
    Event,
    RunCancelled,
    RunFailed,
    RunFinished,
    StreamQueried,
    event_from_dict,
    event_from_stored,
    event_payload,
)
from planner.status import (
    BENCH_STATUSES,
    FINAL_STATUSES,
    LIVE_STATUSES,
    RUN_STATUSES,
    BenchStatus,
    RunStatus,
)
from planner.store import schema
from planner.store.owner import is_alive, process_token

log = logging.getLogger(__name__)

MAX_INT = 2**63 - 1  # SQLite's largest integer: bigger numbers never reach a query
INTERRUPTED = "the process running it stopped before it finished"
_RUN_ID = re.compile(r"[0-9a-f]{32}")  # uuid4().hex

WriteListener = Callable[[str, list[Event]], None]


_dumps = json.JSONEncoder(separators=(",", ":"), allow_nan=False).encode


def _utc(value: datetime) -> datetime:
    """SQLite hands datetimes back naive; they were written in UTC."""
    return value if value.tzinfo is not None else value.replace(tzinfo=UTC)


# --- schema ----------------------------------------------------------------------------------


# 64 bits everywhere: SQLite's INTEGER is, PostgreSQL's BIGINT (migration 0005).
Int64 = BigInteger().with_variant(Integer(), "sqlite")


class Base(DeclarativeBase):
    """The tables as the code reads them; their history is planner/store/migrations."""

    # floats as SQLAlchemy 2.1 maps them (2.0 mapped them to Float), whichever is installed
    type_annotation_map: ClassVar[dict[Any, Any]] = {float: Double}


class RunRow(Base):
    __tablename__ = "runs"
    __table_args__ = (Index("ix_runs_created_at", "created_at"),)  # runs listed newest first

    id: Mapped[str] = mapped_column(String(32), primary_key=True)  # uuid4 hex
    scene: Mapped[str] = mapped_column(Text)  # a scene name or a path to a scene file
    seed: Mapped[int] = mapped_column(Int64)
    planner: Mapped[str] = mapped_column(String(100))
    config: Mapped[str] = mapped_column(Text)  # JSON
    status: Mapped[str] = mapped_column(String(16))  # one of RUN_STATUSES
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    finished_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    planning_s: Mapped[float | None]
    execution_s: Mapped[float | None]
    oracle_s: Mapped[float | None]
    queries: Mapped[int] = mapped_column(Int64, default=0)
    message: Mapped[str] = mapped_column(Text, default="")
    plan: Mapped[str | None] = mapped_column(Text)  # JSON of the bound plan file when solved
    owner: Mapped[str | None] = mapped_column(Text)  # host:pid:start of the process running it


class EventRow(Base):
    """The primary key (run_id, seq) is the index that replay and pagination read through."""

    __tablename__ = "events"

    run_id: Mapped[str] = mapped_column(ForeignKey("runs.id", ondelete="CASCADE"), primary_key=True)
    seq: Mapped[int] = mapped_column(Int64, primary_key=True)
    t: Mapped[float]
    type: Mapped[str] = mapped_column(String(32))
    payload: Mapped[str] = mapped_column(Text)  # JSON of the fields other than run_id, seq, t


class QueryRow(Base):
    __tablename__ = "stream_queries"
    __table_args__ = (
        Index("ix_stream_queries_stream", "stream"),
        Index("ix_stream_queries_run_id", "run_id"),
    )

    id: Mapped[int] = mapped_column(primary_key=True, autoincrement=True)
    run_id: Mapped[str] = mapped_column(ForeignKey("runs.id", ondelete="CASCADE"))
    node_id: Mapped[int] = mapped_column(Int64)
    seq: Mapped[int] = mapped_column(Int64)  # the StreamQueried event's seq
    stream: Mapped[str] = mapped_column(String(200))
    input_names: Mapped[str] = mapped_column(Text)  # JSON list
    inputs: Mapped[str] = mapped_column(Text)  # JSON list of encoded values
    success: Mapped[bool]
    wall_s: Mapped[float]
    cpu_s: Mapped[float]
    execution_s: Mapped[float]
    error: Mapped[str | None] = mapped_column(Text)
    context: Mapped[str] = mapped_column(Text, default="{}")  # JSON: facts and values seen
    reason: Mapped[str | None] = mapped_column(Text)  # why a clean failure found nothing


class BenchRow(Base):
    """A benchmark: paired trials of several planners on the same seeds (``tamp bench``)."""

    __tablename__ = "benchmarks"

    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    finished_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    status: Mapped[str] = mapped_column(String(16))  # one of BENCH_STATUSES
    config: Mapped[str] = mapped_column(Text)  # JSON: scene, planners, seeds, budget, model ...
    owner: Mapped[str | None] = mapped_column(Text)  # host:pid:start of the process running it


class BenchTrialRow(Base):
    """One (seed, planner) trial of a benchmark and how it ended."""

    __tablename__ = "bench_trials"

    bench_id: Mapped[str] = mapped_column(
        ForeignKey("benchmarks.id", ondelete="CASCADE"), primary_key=True
    )
    seed: Mapped[int] = mapped_column(Int64, primary_key=True)
    planner: Mapped[str] = mapped_column(String(100), primary_key=True)
    run_id: Mapped[str | None] = mapped_column(String(32))
    status: Mapped[str] = mapped_column(String(16))  # solved, timeout, failed
    valid: Mapped[bool | None]
    planning_s: Mapped[float | None]
    execution_s: Mapped[float | None]
    oracle_s: Mapped[float | None]
    queries: Mapped[int] = mapped_column(Int64, default=0)
    error: Mapped[str | None] = mapped_column(Text)
    finished_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))


# --- records ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class RunRecord:
    id: str
    scene: str
    seed: int
    planner: str
    config: dict[str, Any]
    status: RunStatus
    created_at: datetime  # UTC
    finished_at: datetime | None
    planning_s: float | None
    execution_s: float | None
    oracle_s: float | None
    queries: int
    message: str
    plan: dict[str, Any] | None  # the bound plan file when solved

    @classmethod
    def from_row(cls, row: RunRow) -> RunRecord:
        return cls(
            id=row.id,
            scene=row.scene,
            seed=row.seed,
            planner=row.planner,
            config=json.loads(row.config),
            status=typing.cast(RunStatus, row.status),
            created_at=_utc(row.created_at),
            finished_at=_utc(row.finished_at) if row.finished_at is not None else None,
            planning_s=row.planning_s,
            execution_s=row.execution_s,
            oracle_s=row.oracle_s,
            queries=row.queries,
            message=row.message,
            plan=json.loads(row.plan) if row.plan is not None else None,
        )


@dataclass(frozen=True)
class QueryRecord:
    """One stream query, as training and statistics read it."""

    id: int
    run_id: str
    node_id: int
    seq: int
    stream: str
    input_names: list[str]
    inputs: list[Any]
    success: bool
    wall_s: float
    cpu_s: float
    execution_s: float
    error: str | None
    context: dict[str, Any]
    reason: str | None = None

    @classmethod
    def from_row(cls, row: QueryRow) -> QueryRecord:
        return cls(
            id=row.id,
            run_id=row.run_id,
            node_id=row.node_id,
            seq=row.seq,
            stream=row.stream,
            input_names=json.loads(row.input_names),
            inputs=json.loads(row.inputs),
            success=row.success,
            wall_s=row.wall_s,
            cpu_s=row.cpu_s,
            execution_s=row.execution_s,
            error=row.error,
            context=json.loads(row.context or "{}"),
            reason=row.reason,
        )


@dataclass(frozen=True)
class QueryOutcome:
    """How one stream query ended (``RunStore.query_outcomes``)."""

    run_id: str
    stream: str
    success: bool
    wall_s: float
    reason: str | None
    error: str | None
    execution_s: float = 0.0


@dataclass(frozen=True)
class OutcomeSums:
    """Stream queries of one stream and outcome, summed (``RunStore.outcome_sums``)."""

    stream: str
    success: bool
    n: int
    wall_s: float  # summed
    execution_s: float  # summed over those that move
    moved: int  # how many moved (execution seconds > 0)


@dataclass(frozen=True)
class BenchRecord:
    id: str
    created_at: datetime
    finished_at: datetime | None
    status: BenchStatus
    config: dict[str, Any]
    owner: str | None = None  # the process running it (host:pid:start), while it runs

    @classmethod
    def from_row(cls, row: BenchRow) -> BenchRecord:
        return cls(
            row.id,
            _utc(row.created_at),
            _utc(row.finished_at) if row.finished_at is not None else None,
            typing.cast(BenchStatus, row.status),
            json.loads(row.config),
            row.owner,
        )


@dataclass(frozen=True)
class BenchTrialRecord:
    bench_id: str
    seed: int
    planner: str
    run_id: str | None
    status: str
    valid: bool | None
    planning_s: float | None
    execution_s: float | None
    oracle_s: float | None
    queries: int
    error: str | None


# --- the store -------------------------------------------------------------------------------


def default_db_path() -> Path:
    """``$XDG_DATA_HOME/guided-tamp/runs.db``, else ``~/.local/share/guided-tamp/runs.db``."""
    xdg = os.environ.get("XDG_DATA_HOME", "")
    base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".local" / "share"
    return base / "guided-tamp" / "runs.db"


def _engine_for(url_or_path: str | Path | URL) -> Engine:
    if isinstance(url_or_path, URL) or (isinstance(url_or_path, str) and "://" in url_or_path):
        url = make_url(url_or_path)
    else:
        path = Path(url_or_path).expanduser().resolve()
        path.parent.mkdir(parents=True, exist_ok=True)
        url = URL.create("sqlite", database=str(path))
    if url.get_backend_name() != "sqlite":
        return create_engine(url, pool_pre_ping=True)
    in_memory = url.database in (None, "", ":memory:")
    if in_memory:  # one shared connection, or each thread would see its own empty database
        engine = create_engine(url, poolclass=StaticPool, connect_args={"check_same_thread": False})
    else:
        engine = create_engine(url, connect_args={"timeout": 30.0})  # wait out other writers

    @event.listens_for(engine, "connect")
    def _sqlite_pragmas(dbapi_connection: Any, _record: Any) -> None:
        if not in_memory:
            schema.enable_wal(dbapi_connection)  # readers never block the writer
        cursor = dbapi_connection.cursor()
        if not in_memory:
            cursor.execute("PRAGMA synchronous=NORMAL")  # safe with WAL, no fsync per commit
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.close()

    return engine


def _bounded(name: str, value: int, low: int = 0) -> int:
    """``value`` if it is an integer SQLite can hold and at least ``low``; else ValueError."""
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= MAX_INT:
        raise ValueError(f"{name} must be an integer from {low} to {MAX_INT}, got {value!r}")
    return value


class RunStore:
    """The record of every run. ``RunStore(path)`` opens (creating if needed) a SQLite file;
    a URL (``postgresql+psycopg://...``) opens any database SQLAlchemy speaks.

    Thread-safe: each call takes its own connection from the engine's pool.
    """

    def __init__(self, url_or_path: str | Path | URL) -> None:
        self.engine = _engine_for(url_or_path)
        schema.upgrade(self.engine)
        self._write_listeners: list[WriteListener] = []
        self._version_lock = threading.Lock()
        self._version_conn: sqlite3.Connection | None = None
        log.debug("run store at %s", self.engine.url.render_as_string(hide_password=True))

    def __enter__(self) -> RunStore:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def close(self) -> None:
        with self._version_lock:
            if self._version_conn is not None:
                self._version_conn.close()
                self._version_conn = None
        self.engine.dispose()

    @property
    def backend(self) -> str:
        """The kind of database (``sqlite``, ``postgresql``, ...), without where it is."""
        return self.engine.url.get_backend_name()

    def add_write_listener(self, listener: WriteListener) -> None:
        """``listener(run_id, events)`` is called after each :meth:`write_events` has committed,
        in the writing thread, so whoever it tells can rely on the events being stored. Its
        errors are logged, never raised: the events are stored either way."""
        self._write_listeners.append(listener)

    def data_version(self) -> int | None:
        """A number that changes whenever anyone commits to the database, for caching what
        was read from it; None when the database cannot say (not a SQLite file)."""
        database = self.engine.url.database
        if self.backend != "sqlite" or database in (None, "", ":memory:"):
            return None
        with self._version_lock:
            if self._version_conn is None:  # never writes, so every commit is another's
                self._version_conn = sqlite3.connect(database, check_same_thread=False)
            row = self._version_conn.execute("PRAGMA data_version").fetchone()
        return int(row[0])

    # runs

    def create_run(
        self,
        scene: str,
        seed: int,
        planner: str,
        config: dict[str, Any],
        *,
        status: str = "running",
        owner: str | None = None,
        run_id: str | None = None,
    ) -> str:
        """Record a new run as ``running`` (or ``queued``, to be started later); returns its id,
        ``run_id`` if given (32 hex digits: a benchmark names its trials' runs before they
        start, to finish one whose process dies). ``owner`` (default: this process,
        :func:`~planner.store.owner.process_token`) is the process that will finish it;
        :meth:`claim_run` hands it to another."""
        if status not in LIVE_STATUSES:
            raise ValueError(f"a new run is queued or running, not {status!r}")
        if run_id is not None and not _RUN_ID.fullmatch(run_id):
            raise ValueError(f"a run id is 32 lowercase hex digits, got {run_id!r}")
        try:
            config_json = _dumps(config)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"run config is not JSON-friendly: {exc}") from exc
        run_id = run_id or uuid.uuid4().hex
        with self.engine.begin() as conn:
            conn.execute(
                insert(RunRow).values(
                    id=run_id,
                    scene=scene,
                    seed=seed,
                    planner=planner,
                    config=config_json,
                    status=status,
                    created_at=datetime.now(UTC),
                    queries=0,
                    message="",
                    owner=owner or process_token(),
                )
            )
        log.debug("created run %s (%s, seed %d, %s)", run_id, scene, seed, planner)
        return run_id

    def start_run(self, run_id: str) -> None:
        """A queued run starts running."""
        with self.engine.begin() as conn:
            current = conn.execute(select(RunRow.status).where(RunRow.id == run_id)).scalar()
            if current is None:
                raise _unknown(run_id)
            if current != "queued":
                raise ValueError(f"run {run_id} is {current!r}, not queued")
            conn.execute(update(RunRow).where(RunRow.id == run_id).values(status="running"))

    def claim_run(self, run_id: str) -> bool:
        """This process now runs ``run_id`` (a worker takes over the run its server started);
        False, and nothing changes, when the run is no longer ``running``."""
        with self.engine.begin() as conn:
            result = conn.execute(
                update(RunRow)
                .where(RunRow.id == run_id, RunRow.status == "running")
                .values(owner=process_token())
            )
        return bool(result.rowcount)

    def count_runs(
        self, *, status: str | None = None, scene: str | None = None, planner: str | None = None
    ) -> int:
        """How many runs :meth:`list_runs` would page through with these filters."""
        query = select(func.count()).select_from(RunRow)
        for column, value in (
            (RunRow.status, status),
            (RunRow.scene, scene),
            (RunRow.planner, planner),
        ):
            if value is not None:
                query = query.where(column == value)
        with self.engine.connect() as conn:
            return int(conn.execute(query).scalar() or 0)

    def finish_run(
        self,
        run_id: str,
        status: str,
        *,
        planning_s: float | None = None,
        execution_s: float | None = None,
        oracle_s: float | None = None,
        queries: int = 0,
        message: str = "",
        plan: dict[str, Any] | None = None,
    ) -> RunRecord:
        """Record how a queued or running run ended; a run is finished once."""
        if status not in FINAL_STATUSES:
            raise ValueError(
                f"unknown final status {status!r} (known: {', '.join(FINAL_STATUSES)})"
            )
        if queries < 0:
            raise ValueError(f"queries must be >= 0, got {queries}")
        with self.engine.begin() as conn:
            current = conn.execute(select(RunRow.status).where(RunRow.id == run_id)).scalar()
            if current is None:
                raise _unknown(run_id)
            if current not in LIVE_STATUSES:
                raise ValueError(f"run {run_id} already finished with status {current!r}")
            conn.execute(
                update(RunRow)
                .where(RunRow.id == run_id)
                .values(
                    status=status,
                    finished_at=datetime.now(UTC),
                    planning_s=planning_s,
                    execution_s=execution_s,
                    oracle_s=oracle_s,
                    queries=queries,
                    message=message,
                    plan=_dumps(plan) if plan is not None else None,
                )
            )
        return self.get_run(run_id)

    def get_run(self, run_id: str) -> RunRecord:
        with Session(self.engine) as session:
            row = session.get(RunRow, run_id)
            if row is None:
                raise _unknown(run_id)
            return RunRecord.from_row(row)

    def list_runs(
        self,
        *,
        status: str | None = None,
        scene: str | None = None,
        planner: str | None = None,
        limit: int = 50,
        offset: int = 0,
    ) -> list[RunRecord]:
        """Runs newest first, optionally filtered."""
        if status is not None and status not in RUN_STATUSES:
            raise ValueError(f"unknown status {status!r} (known: {', '.join(RUN_STATUSES)})")
        _bounded("limit", limit)
        _bounded("offset", offset)
        query = select(RunRow)
        if status is not None:
            query = query.where(RunRow.status == status)
        if scene is not None:
            query = query.where(RunRow.scene == scene)
        if planner is not None:
            query = query.where(RunRow.planner == planner)
        query = query.order_by(RunRow.created_at.desc(), RunRow.id).limit(limit).offset(offset)
        with Session(self.engine) as session:
            return [RunRecord.from_row(r) for r in session.scalars(query)]

    def runs_tagged(self, scene: str, key: str, value: str) -> list[RunRecord]:
        """The runs of ``scene`` whose stored configuration has ``key`` equal to ``value`` (a
        benchmark's trials carry its id), oldest first."""
        query = (
            select(RunRow)
            .where(RunRow.scene == scene, RunRow.config.contains(value))
            .order_by(RunRow.created_at, RunRow.id)
        )
        with Session(self.engine) as session:
            records = [RunRecord.from_row(r) for r in session.scalars(query)]
        return [r for r in records if r.config.get(key) == value]

    def mark_interrupted(self, message: str = INTERRUPTED, *, skip: Collection[str] = ()) -> int:
        """Finish the live runs whose process is gone (:meth:`settle_run`: a closing event
        the process stored decides how it ended, else it is ``interrupted`` with a closing
        event added); returns how many. Runs of processes still running (a ``tamp plan`` on
        the same database, another server's workers) are left alone. A server calls it when
        it starts, and now and then while it runs (``skip``: the runs it is finishing itself)."""
        with self.engine.connect() as conn:
            live = conn.execute(
                select(RunRow.id, RunRow.owner).where(RunRow.status.in_(LIVE_STATUSES))
            ).all()
        settled = 0
        for run_id, owner in live:
            if run_id in skip or is_alive(owner):
                continue
            record = self.settle_run(run_id, "interrupted", message)
            if record is not None:
                settled += 1
                log.info("run %s: its process is gone; now %s", run_id, record.status)
        return settled

    def settle_run(self, run_id: str, status: str, message: str) -> RunRecord | None:
        """Finish a live run that its own process will not finish (cancelled while queued,
        its process died or was stopped): in one transaction, the run's stored closing event
        decides how it ended (a ``run_finished`` the process wrote before it died wins, with
        its figures), else ``status`` and ``message`` are recorded with a closing event after
        the last stored one (``run_cancelled`` for ``cancelled``, ``run_failed`` otherwise).
        None when the run had already finished; KeyError for an unknown run."""
        if status not in FINAL_STATUSES:
            raise ValueError(
                f"unknown final status {status!r} (known: {', '.join(FINAL_STATUSES)})"
            )
        now = datetime.now(UTC)
        with self.engine.begin() as conn:
            claimed = conn.execute(  # takes the write lock first: nobody settles it twice
                update(RunRow)
                .where(RunRow.id == run_id, RunRow.status.in_(LIVE_STATUSES))
                .values(finished_at=now)
            )
            if not claimed.rowcount:
                self._require(conn, run_id)
                return None
            last = conn.execute(
                select(EventRow.seq, EventRow.t, EventRow.type, EventRow.payload)
                .where(EventRow.run_id == run_id)
                .order_by(EventRow.seq.desc())
                .limit(1)
            ).first()
            values: dict[str, Any] = {"status": status, "message": message}
            last_seq, last_t, last_type, last_payload = last or (-1, 0.0, "", "{}")
            if last_type in TERMINAL_TYPES:
                data = json.loads(last_payload)
                data.update(type=last_type, run_id=run_id, seq=last_seq, t=last_t)
                values = _ending(event_from_dict(data))
            else:
                seq, t = last_seq + 1, last_t
                closing: Event = (
                    RunCancelled(run_id=run_id, seq=seq, t=t, reason=message)
                    if status == "cancelled"
                    else RunFailed(run_id=run_id, seq=seq, t=t, error=message)
                )
                conn.execute(insert(EventRow), [_event_row(closing)])
            conn.execute(update(RunRow).where(RunRow.id == run_id).values(**values))
        return self.get_run(run_id)

    # events and queries

    def _event_rows(self, run_id: str, after: int, limit: int | None) -> list[Any]:
        """The stored rows ``(seq, t, type, payload)`` of the run's events with ``seq > after``,
        in order, at most ``limit``; an unknown run raises as :meth:`_require` does."""
        _bounded("after", after, low=-1)
        query = (
            select(EventRow.seq, EventRow.t, EventRow.type, EventRow.payload)
            .where(EventRow.run_id == run_id, EventRow.seq > after)
            .order_by(EventRow.seq)
        )
        if limit is not None:
            query = query.limit(_bounded("limit", limit))
        with self.engine.connect() as conn:
            self._require(conn, run_id)
            return list(conn.execute(query).all())

    def events(self, run_id: str, *, after: int = -1, limit: int | None = None) -> list[Event]:
        """The run's events with ``seq > after`` in order, at most ``limit`` of them."""
        rows = self._event_rows(run_id, after, limit)
        out: list[Event] = []
        for seq, t, type_, payload in rows:
            data = json.loads(payload)
            data.update(type=type_, run_id=run_id, seq=seq, t=t)
            out.append(event_from_dict(data))
        return out

    def event_json(
        self, run_id: str, *, after: int = -1, limit: int | None = None
    ) -> list[tuple[int, str]]:
        """The run's events with ``seq > after`` in order, at most ``limit``, each as ``(seq,
        its JSON)``: the text :func:`~planner.events.event_to_json` makes of it, put together
        from the stored payload without parsing it (every stored event was checked when it was
        written). What the dashboard serves: tens of times cheaper than :meth:`events`."""
        rows = self._event_rows(run_id, after, limit)
        head = f',"run_id":{_dumps(run_id)},"seq":'
        out: list[tuple[int, str]] = []
        for seq, t, type_, payload in rows:
            rest = "," + payload[1:] if len(payload) > 2 else "}"
            out.append((seq, f'{{"type":"{type_}"{head}{seq},"t":{float(t)!r}{rest}'))
        return out

    def events_of(self, run_id: str, types: Collection[str]) -> list[Event]:
        """The run's events of some types, in order, built without checking their fields again
        (:func:`~planner.events.event_from_stored`: fast for a whole tree, what compare
        folds)."""
        query = (
            select(EventRow.seq, EventRow.t, EventRow.type, EventRow.payload)
            .where(EventRow.run_id == run_id, EventRow.type.in_(list(types)))
            .order_by(EventRow.seq)
        )
        out: list[Event] = []
        with self.engine.connect() as conn:
            self._require(conn, run_id)
            for seq, t, type_, payload in conn.execute(query):
                data = json.loads(payload)
                data.update(type=type_, run_id=run_id, seq=seq, t=float(t))
                out.append(event_from_stored(data))
        return out

    def query_times(self, run_id: str) -> list[float]:
        """The time ``t`` of each of the run's stream queries a sampler answered (reused
        results left out), in order: read from the queries' rows, without their events'
        payloads (half a tree's stored bytes)."""
        query = (
            select(EventRow.t)
            .join(QueryRow, (QueryRow.run_id == EventRow.run_id) & (QueryRow.seq == EventRow.seq))
            .where(EventRow.run_id == run_id)
            .order_by(EventRow.seq)
        )
        with self.engine.connect() as conn:
            self._require(conn, run_id)
            return [float(t) for (t,) in conn.execute(query)]

    def last_seq(self, run_id: str) -> int:
        """The highest stored seq of the run, -1 if it has no events."""
        with self.engine.connect() as conn:
            self._require(conn, run_id)
            last = conn.execute(
                select(func.max(EventRow.seq)).where(EventRow.run_id == run_id)
            ).scalar()
        return -1 if last is None else int(last)

    def stream_queries(
        self, *, stream: str | None = None, run_ids: list[str] | None = None
    ) -> list[QueryRecord]:
        """Stream queries in the order they were stored, optionally of one stream / some runs."""
        query = select(QueryRow).order_by(QueryRow.id)
        if stream is not None:
            query = query.where(QueryRow.stream == stream)
        if run_ids is not None:
            query = query.where(QueryRow.run_id.in_(run_ids))
        with Session(self.engine) as session:
            return [QueryRecord.from_row(r) for r in session.scalars(query)]

    def query_counts(self, run_id: str) -> dict[str, dict[str, int]]:
        """The run's queries a sampler answered, per stream: ``{stream: {"ok", "failed"}}``,
        counted by the database (a run of 50,000 queries is not read row by row)."""
        query = (
            select(QueryRow.stream, QueryRow.success, func.count())
            .where(QueryRow.run_id == run_id)
            .group_by(QueryRow.stream, QueryRow.success)
        )
        out: dict[str, dict[str, int]] = {}
        with self.engine.connect() as conn:
            for stream, success, n in conn.execute(query):
                entry = out.setdefault(str(stream), {"ok": 0, "failed": 0})
                entry["ok" if success else "failed"] += int(n)
        return dict(sorted(out.items()))

    def query_outcomes(self, run_ids: list[str]) -> list[QueryOutcome]:
        """How each stream query of some runs ended, without its inputs and context (cheap to
        read for a whole benchmark), in the order stored."""
        columns = (
            QueryRow.run_id,
            QueryRow.stream,
            QueryRow.success,
            QueryRow.wall_s,
            QueryRow.reason,
            QueryRow.error,
            QueryRow.execution_s,
        )
        out: list[QueryOutcome] = []
        with self.engine.connect() as conn:
            for i in range(0, len(run_ids), 500):  # SQLite caps a statement's parameters
                chunk = run_ids[i : i + 500]
                query = select(*columns).where(QueryRow.run_id.in_(chunk)).order_by(QueryRow.id)
                out.extend(QueryOutcome(*row) for row in conn.execute(query))
        return out

    def outcome_sums(
        self, run_ids: list[str], *, leave_out: Collection[str] = ()
    ) -> list[OutcomeSums]:
        """Per stream and outcome, over the stream queries of some runs: how many, their wall
        seconds, and the execution seconds of those that move (and how many did), summed in
        the database (a store of a benchmark holds tens of thousands). Failures whose reason
        is in ``leave_out`` are left out."""
        moving = case((QueryRow.execution_s > 0, 1), else_=0)
        columns = (
            QueryRow.stream,
            QueryRow.success,
            func.count(),
            func.sum(QueryRow.wall_s),
            func.sum(case((QueryRow.execution_s > 0, QueryRow.execution_s), else_=0.0)),
            func.sum(moving),
        )
        sums: dict[tuple[str, bool], list[float]] = {}
        with self.engine.connect() as conn:
            for i in range(0, len(run_ids), 500):  # SQLite caps a statement's parameters
                query = select(*columns).where(QueryRow.run_id.in_(run_ids[i : i + 500]))
                if leave_out:
                    kept = QueryRow.success | QueryRow.reason.is_(None)
                    query = query.where(kept | QueryRow.reason.not_in(list(leave_out)))
                query = query.group_by(QueryRow.stream, QueryRow.success)
                for stream, success, n, wall, moved, n_moved in conn.execute(query):
                    acc = sums.setdefault((stream, bool(success)), [0, 0.0, 0.0, 0])
                    acc[0] += int(n)
                    acc[1] += float(wall or 0.0)
                    acc[2] += float(moved or 0.0)
                    acc[3] += int(n_moved or 0)
        return [
            OutcomeSums(stream, success, int(n), wall, moved, int(n_moved))
            for (stream, success), (n, wall, moved, n_moved) in sorted(sums.items())
        ]

    def query_runs(self) -> dict[str, tuple[str, str | None]]:
        """Per run that has stream queries: its scene and the domain its config names (None:
        its scene file says), for telling the runs of one domain apart without reading their
        queries."""
        has_queries = select(QueryRow.run_id).distinct()
        query = select(RunRow.id, RunRow.scene, RunRow.config).where(RunRow.id.in_(has_queries))
        out: dict[str, tuple[str, str | None]] = {}
        with self.engine.connect() as conn:
            for run_id, scene, config in conn.execute(query):
                domain = json.loads(config).get("domain")
                out[run_id] = (scene, domain if isinstance(domain, str) else None)
        return out

    def event_times(self, run_ids: list[str], type_: str) -> dict[str, float]:
        """Per run: the time ``t`` of its first event of type ``type_`` (runs without one are
        left out)."""
        out: dict[str, float] = {}
        with self.engine.connect() as conn:
            for i in range(0, len(run_ids), 500):  # SQLite caps a statement's parameters
                chunk = run_ids[i : i + 500]
                query = (
                    select(EventRow.run_id, func.min(EventRow.t))
                    .where(EventRow.run_id.in_(chunk), EventRow.type == type_)
                    .group_by(EventRow.run_id)
                )
                out.update({run_id: float(t) for run_id, t in conn.execute(query)})
        return out

    def event_numbers(self, run_ids: list[str], type_: str, field: str) -> dict[str, float]:
        """Per run: the number ``field`` of its first event of type ``type_``, read in the
        database (a ``run_finished`` payload holds the whole plan file); runs without one, or
        whose event has no such number, are left out."""
        # SQLite reads JSON from text as it is; PostgreSQL needs the text cast to json.
        coerce = type_coerce if self.engine.dialect.name == "sqlite" else cast
        value = coerce(EventRow.payload, JSON)[field].as_float()
        out: dict[str, float] = {}
        with self.engine.connect() as conn:
            for i in range(0, len(run_ids), 500):  # SQLite caps a statement's parameters
                chunk = run_ids[i : i + 500]
                query = (
                    select(EventRow.run_id, value)
                    .where(EventRow.run_id.in_(chunk), EventRow.type == type_)
                    .order_by(EventRow.seq)
                )
                for run_id, number in conn.execute(query):
                    if number is not None and run_id not in out:
                        out[run_id] = float(number)
        return out

    # benchmarks

    def create_bench(self, config: dict[str, Any], *, owner: str | None = None) -> str:
        """Record a new benchmark as ``running``, owned by ``owner`` (default: this process)."""
        bench_id = uuid.uuid4().hex[:12]
        with self.engine.begin() as conn:
            conn.execute(
                insert(BenchRow).values(
                    id=bench_id,
                    created_at=datetime.now(UTC),
                    status="running",
                    config=_dumps(config),
                    owner=owner or process_token(),
                )
            )
        return bench_id

    def get_bench(self, bench_id: str) -> BenchRecord:
        with Session(self.engine) as session:
            row = session.get(BenchRow, bench_id)
            if row is None:
                known = [b.id for b in self.list_benches()]
                raise KeyError(
                    f"unknown benchmark {bench_id!r} (known: {', '.join(known[:10]) or 'none'})"
                )
            return BenchRecord.from_row(row)

    def list_benches(self) -> list[BenchRecord]:
        with Session(self.engine) as session:
            rows = session.scalars(select(BenchRow).order_by(BenchRow.created_at.desc()))
            return [BenchRecord.from_row(r) for r in rows]

    def set_bench_status(self, bench_id: str, status: str, *, owner: str | None = None) -> None:
        """A benchmark's new status; ``running`` records who runs it now (``owner``, default
        this process: the one resuming it)."""
        if status not in BENCH_STATUSES:
            raise ValueError(
                f"unknown benchmark status {status!r} (known: {', '.join(BENCH_STATUSES)})"
            )
        values: dict[str, Any] = {
            "status": status,
            "finished_at": datetime.now(UTC) if status != "running" else None,
        }
        if status == "running":
            values["owner"] = owner or process_token()
        with self.engine.begin() as conn:
            conn.execute(update(BenchRow).where(BenchRow.id == bench_id).values(**values))

    def settle_benches(self, *, skip: Collection[str] = ()) -> int:
        """Benchmarks still ``running`` whose process is gone (killed, a crashed machine) are
        ``interrupted``, resumable; returns how many. Those of live processes are left alone."""
        with self.engine.connect() as conn:
            running = conn.execute(
                select(BenchRow.id, BenchRow.owner).where(BenchRow.status == "running")
            ).all()
        settled = 0
        for bench_id, owner in running:
            if bench_id in skip or is_alive(owner):
                continue
            with self.engine.begin() as conn:
                done = conn.execute(
                    update(BenchRow)
                    .where(BenchRow.id == bench_id, BenchRow.status == "running")
                    .values(status="interrupted", finished_at=datetime.now(UTC))
                )
            if done.rowcount:
                settled += 1
                log.info("benchmark %s: its process is gone; now interrupted", bench_id)
        return settled

    def bench_progress(self) -> dict[str, dict[str, dict[str, int]]]:
        """Per benchmark, per planner: how many trials ended with each status (one query)."""
        query = select(
            BenchTrialRow.bench_id, BenchTrialRow.planner, BenchTrialRow.status, func.count()
        ).group_by(BenchTrialRow.bench_id, BenchTrialRow.planner, BenchTrialRow.status)
        out: dict[str, dict[str, dict[str, int]]] = {}
        with self.engine.connect() as conn:
            for bench_id, planner, status, count in conn.execute(query):
                out.setdefault(bench_id, {}).setdefault(planner, {})[status] = int(count)
        return out

    def record_trial(self, trial: BenchTrialRecord) -> None:
        """Store how one trial ended (a re-run of the same seed and planner replaces it)."""
        with self.engine.begin() as conn:
            conn.execute(
                delete(BenchTrialRow).where(
                    BenchTrialRow.bench_id == trial.bench_id,
                    BenchTrialRow.seed == trial.seed,
                    BenchTrialRow.planner == trial.planner,
                )
            )
            conn.execute(
                insert(BenchTrialRow).values(
                    **{k: getattr(trial, k) for k in BenchTrialRecord.__dataclass_fields__},
                    finished_at=datetime.now(UTC),
                )
            )

    def bench_trials(self, bench_id: str) -> list[BenchTrialRecord]:
        query = (
            select(BenchTrialRow)
            .where(BenchTrialRow.bench_id == bench_id)
            .order_by(BenchTrialRow.seed, BenchTrialRow.planner)
        )
        with Session(self.engine) as session:
            return [
                BenchTrialRecord(
                    **{k: getattr(r, k) for k in BenchTrialRecord.__dataclass_fields__}
                )
                for r in session.scalars(query)
            ]

    def write_events(self, run_id: str, events: list[Event]) -> None:
        """Insert events of one run (and their stream-query rows) in one transaction."""
        if not events:
            return
        event_rows: list[dict[str, Any]] = []
        query_rows: list[dict[str, Any]] = []
        for e in events:
            if e.run_id != run_id:
                raise ValueError(f"event {e.type} #{e.seq} belongs to run {e.run_id}, not {run_id}")
            event_rows.append(_event_row(e))
            if isinstance(e, StreamQueried) and e.reused_from is None:
                query_rows.append(
                    {
                        "run_id": run_id,
                        "node_id": e.node_id,
                        "seq": e.seq,
                        "stream": e.stream,
                        "input_names": _dumps(e.input_names),
                        "inputs": _dumps(e.inputs),
                        "success": e.success,
                        "wall_s": e.wall_s,
                        "cpu_s": e.cpu_s,
                        "execution_s": e.execution_s,
                        "error": e.error,
                        "context": _dumps(e.context),
                        "reason": e.reason,
                    }
                )
        with self.engine.begin() as conn:
            conn.execute(insert(EventRow), event_rows)
            if query_rows:
                conn.execute(insert(QueryRow), query_rows)
        for listener in self._write_listeners:
            try:
                listener(run_id, events)
            except Exception:
                log.exception("run store: write listener %r failed", listener)

    @staticmethod
    def _require(conn: Connection, run_id: str) -> None:
        if conn.execute(select(RunRow.id).where(RunRow.id == run_id)).first() is None:
            raise _unknown(run_id)


def _unknown(run_id: str) -> KeyError:
    return KeyError(f"unknown run id {run_id!r}")


def _event_row(event: Event) -> dict[str, Any]:
    return {
        "run_id": event.run_id,
        "seq": event.seq,
        "t": event.t,
        "type": event.type,
        "payload": _dumps(event_payload(event)),
    }


def _ending(event: Event) -> dict[str, Any]:
    """The run row's fields as a stored closing event tells how the run ended."""
    if isinstance(event, RunFinished):
        return {
            "status": event.status,
            "planning_s": event.planning_s,
            "execution_s": event.execution_s,
            "oracle_s": event.oracle_s,
            "queries": event.queries,
            "message": event.message,
            "plan": None if event.plan is None else _dumps(event.plan),
        }
    if isinstance(event, RunCancelled):
        return {"status": "cancelled", "message": event.reason}
    assert isinstance(event, RunFailed), event
    return {"status": "failed", "message": event.error}


# --- the sink --------------------------------------------------------------------------------


class StoreSink(BatchingSink):
    """Writes one run's events to a :class:`RunStore` in batches, one transaction per batch
    (batching rules in :class:`~planner.events.BatchingSink`)."""

    def __init__(
        self,
        store: RunStore,
        run_id: str,
        *,
        batch_size: int = 200,
        flush_interval_s: float | None = 0.5,
    ) -> None:
        self.store = store
        self.run_id = run_id
        self._last_seq = store.last_seq(run_id)  # raises KeyError for an unknown run
        super().__init__(
            self._write_batch,
            name=f"store-sink-{run_id[:8]}",
            batch_size=batch_size,
            flush_interval_s=flush_interval_s,
        )

    def __repr__(self) -> str:
        return f"StoreSink(run_id={self.run_id!r}, batch_size={self.batch_size})"

    def _accept(self, event: Event) -> None:
        if event.run_id != self.run_id:
            raise ValueError(
                f"event {event.type} #{event.seq} belongs to run {event.run_id!r}, "
                f"this sink writes run {self.run_id!r}"
            )
        if event.seq <= self._last_seq:
            raise ValueError(
                f"event {event.type} #{event.seq} of run {self.run_id} comes after "
                f"#{self._last_seq}: seq must increase"
            )
        self._last_seq = event.seq

    def _write_batch(self, batch: list[Event]) -> None:
        self.store.write_events(self.run_id, batch)
        log.debug("run %s: wrote %d events up to #%d", self.run_id, len(batch), batch[-1].seq)

"""The run store keeps every run, event and stream query, written in batches and read back."""

from __future__ import annotations

import sqlite3
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import inspect

from planner.events import (
    Emitter,
    Event,
    NodeAdded,
    NodeVisited,
    RunCancelled,
    RunFailed,
    RunFinished,
    RunStarted,
    StreamQueried,
)
from planner.store import RunStore, StoreSink, default_db_path, is_alive, process_token
from tests.conftest import BACKENDS

CONFIG: dict[str, Any] = {"k": 10, "budget_s": 60.0, "policy": {"c": 1.4}}


@pytest.fixture
def db(store_url: str) -> str:
    """A new store, on SQLite and on PostgreSQL (tests/conftest.py)."""
    return store_url


@pytest.fixture
def sqlite_db(tmp_path: Path) -> Path:
    """For what only SQLite has: its file, its journal, its data_version."""
    return tmp_path / "data" / "runs.db"


@pytest.fixture
def store(db: str) -> Iterator[RunStore]:
    with RunStore(db) as store:
        yield store


def _emit_search(emitter: Emitter, n: int) -> None:
    """A run's worth of events: per step a node, a stream query and a back-up."""
    emitter.emit(RunStarted, scene="line-2", seed=3, planner="learned", config=CONFIG)
    for i in range(n):
        emitter.emit(
            NodeAdded,
            node_id=i + 1,
            parent_id=i,
            plan_index=0,
            depth=i + 1,
            stream="sample-pose",
            success=i % 3 != 0,
            outputs=[f"#p{i}"],
            label=f"node {i + 1}",
        )
        emitter.emit(
            StreamQueried,
            node_id=i + 1,
            stream="sample-pose" if i % 2 else "test-reachable",
            input_names=["?b", "?r"],
            inputs=[f"b{i}", [0.0, 1.5 * i]],
            success=i % 3 != 0,
            wall_s=0.01 * i,
            cpu_s=0.005 * i,
            execution_s=0.0,
            error=None if i % 3 else "no sample",
        )
        emitter.emit(NodeVisited, node_id=i + 1, visits=i + 1, value=-0.5 * i)


class _Recording:
    """Keeps what the planner emitted, then passes it on to the sink under test."""

    def __init__(self, sink: StoreSink) -> None:
        self.sink = sink
        self.events: list[Event] = []

    def emit(self, event: Event) -> None:
        self.events.append(event)
        self.sink.emit(event)

    def close(self) -> None:
        self.sink.close()


def test_events_written_in_batches_read_back_equal_and_in_order(store: RunStore) -> None:
    run_id = store.create_run("line-2", 3, "learned", CONFIG)
    recording = _Recording(StoreSink(store, run_id, batch_size=7, flush_interval_s=None))
    _emit_search(Emitter(run_id, recording), 40)  # 121 events: 17 batches written, 2 buffered
    assert store.events(run_id) == recording.events[:119]
    recording.close()
    stored = store.events(run_id)
    assert [e.seq for e in stored] == list(range(121))
    assert stored == recording.events  # equal field by field, t included


def test_events_after_paginates(store: RunStore) -> None:
    run_id = store.create_run("line-2", 3, "learned", CONFIG)
    sink = StoreSink(store, run_id, flush_interval_s=None)
    _emit_search(Emitter(run_id, sink), 10)  # 31 events
    sink.close()
    pages: list[list[int]] = []
    after = -1
    while page := store.events(run_id, after=after, limit=8):
        pages.append([e.seq for e in page])
        after = page[-1].seq
    assert pages == [list(range(i, min(i + 8, 31))) for i in range(0, 31, 8)]
    assert [e.seq for e in store.events(run_id, after=28)] == [29, 30]
    assert store.events(run_id, after=30) == []


def test_stream_queries_rows_come_from_stream_queried_events(store: RunStore) -> None:
    run_id = store.create_run("line-2", 3, "learned", CONFIG)
    other = store.create_run("line-2", 4, "baseline", CONFIG)
    for rid, n in ((run_id, 6), (other, 2)):
        sink = StoreSink(store, rid, batch_size=4, flush_interval_s=None)
        _emit_search(Emitter(rid, sink), n)
        sink.close()
    rows = store.stream_queries(run_ids=[run_id])
    events = [e for e in store.events(run_id) if isinstance(e, StreamQueried)]
    assert len(rows) == len(events) == 6
    for row, e in zip(rows, events, strict=True):
        assert (row.run_id, row.seq, row.node_id, row.stream) == (
            run_id,
            e.seq,
            e.node_id,
            e.stream,
        )
        assert (row.input_names, row.inputs) == (e.input_names, e.inputs)
        assert (row.success, row.error) == (e.success, e.error)
        assert (row.wall_s, row.cpu_s, row.execution_s) == (e.wall_s, e.cpu_s, e.execution_s)
    assert rows[0].inputs == ["b0", [0.0, 0.0]] and rows[0].error == "no sample"
    assert not rows[0].success
    assert {r.stream for r in store.stream_queries(stream="sample-pose")} == {"sample-pose"}
    assert len(store.stream_queries(stream="sample-pose")) == 3 + 1
    assert len(store.stream_queries()) == 8
    assert store.stream_queries(run_ids=[]) == []


def test_finish_run_updates_the_record(store: RunStore) -> None:
    run_id = store.create_run("kitchen-2", 1, "baseline", CONFIG)
    record = store.get_run(run_id)
    assert (record.status, record.finished_at, record.plan) == ("running", None, None)
    assert record.config == CONFIG and record.created_at.tzinfo is not None
    plan = {"actions": [{"name": "pick", "args": ["b1", "#g0"]}], "values": {"#g0": [0.1, 0.2]}}
    done = store.finish_run(
        run_id,
        "solved",
        planning_s=12.5,
        execution_s=40.0,
        oracle_s=0.25,
        queries=93,
        message="solved",
        plan=plan,
    )
    assert done == store.get_run(run_id)
    assert (done.status, done.planning_s, done.execution_s, done.oracle_s) == (
        "solved",
        12.5,
        40.0,
        0.25,
    )
    assert (done.queries, done.message, done.plan) == (93, "solved", plan)
    assert done.finished_at is not None and done.finished_at >= done.created_at
    with pytest.raises(ValueError, match="already finished with status 'solved'"):
        store.finish_run(run_id, "failed")
    with pytest.raises(ValueError, match="unknown final status 'running'"):
        store.finish_run(store.create_run("kitchen-2", 1, "baseline", {}), "running")


def test_list_runs_filters_newest_first(store: RunStore) -> None:
    a = store.create_run("kitchen-1", 0, "baseline", {})
    b = store.create_run("kitchen-1", 1, "learned", {})
    c = store.create_run("kitchen-2", 0, "learned", {})
    store.finish_run(a, "solved")
    store.finish_run(b, "timeout")
    assert [r.id for r in store.list_runs()] == [c, b, a]
    assert [r.id for r in store.list_runs(status="running")] == [c]
    assert [r.id for r in store.list_runs(scene="kitchen-1")] == [b, a]
    assert [r.id for r in store.list_runs(planner="learned", scene="kitchen-1")] == [b]
    assert [r.id for r in store.list_runs(limit=1, offset=1)] == [b]
    assert store.list_runs(status="cancelled") == []
    with pytest.raises(ValueError, match="unknown status 'done'"):
        store.list_runs(status="done")


@pytest.fixture
def gone() -> str:
    """The owner token of a process that has exited (killed, as kill -9 would)."""
    process = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    token = process_token(process.pid)
    process.kill()
    process.wait()
    return token


@pytest.fixture
def alive() -> Iterator[str]:
    """The owner token of another process that is still running (a ``tamp plan``)."""
    process = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    yield process_token(process.pid)
    process.kill()
    process.wait()


def _started(store: RunStore, owner: str, seed: int = 0) -> tuple[str, Emitter, StoreSink]:
    run_id = store.create_run("line-2", seed, "baseline", CONFIG, owner=owner)
    sink = StoreSink(store, run_id, flush_interval_s=None)
    emitter = Emitter(run_id, sink)
    _emit_search(emitter, 2)
    return run_id, emitter, sink


def test_mark_interrupted_finishes_runs_whose_process_is_gone(
    store: RunStore, gone: str, alive: str
) -> None:
    dead, _, sink = _started(store, gone)
    sink.close()
    running, _, sink = _started(store, alive, seed=1)
    sink.close()
    queued = store.create_run("line-2", 2, "baseline", {}, status="queued", owner=gone)
    finished = store.create_run("line-2", 3, "baseline", {}, owner=gone)
    store.finish_run(finished, "failed", message="no plan")

    assert store.mark_interrupted() == 2
    record = store.get_run(dead)
    assert record.status == "interrupted" and "stopped" in record.message
    assert record.finished_at is not None
    events = store.events(dead)
    assert [e.seq for e in events] == list(range(8))  # 7 stored + one closing event
    assert isinstance(events[-1], RunFailed) and "stopped" in events[-1].error
    assert events[-1].t == events[-2].t
    (closing,) = store.events(queued)  # a run that never started closes too
    assert closing.seq == 0 and isinstance(closing, RunFailed)
    assert store.get_run(running).status == "running"  # its process still runs
    assert store.get_run(finished).message == "no plan"
    assert store.mark_interrupted() == 0


def test_a_stored_closing_event_decides_how_a_dead_run_ended(store: RunStore, gone: str) -> None:
    solved, emitter, sink = _started(store, gone)
    plan = {"format": "guided-tamp/plan-v1", "domain": "line", "actions": ["(pick a p r)"]}
    emitter.emit(
        RunFinished,
        status="solved",
        planning_s=1.5,
        execution_s=2.25,
        oracle_s=0.5,
        queries=2,
        message="solved",
        valid=True,
        plan=plan,
    )
    sink.close()  # its process died before it could call finish_run
    cancelled, emitter, sink = _started(store, gone, seed=1)
    emitter.emit(RunCancelled, reason="cancelled by the user")
    sink.close()
    failed, emitter, sink = _started(store, gone, seed=2)
    emitter.emit(RunFailed, error="RuntimeError: boom")
    sink.close()

    assert store.mark_interrupted() == 3
    record = store.get_run(solved)
    assert (record.status, record.planning_s, record.execution_s, record.oracle_s) == (
        "solved",
        1.5,
        2.25,
        0.5,
    )
    assert (record.queries, record.message) == (2, "solved")
    assert record.plan == plan  # the plan file travels in the closing event
    assert store.events(solved)[-1].type == "run_finished"  # no second closing event
    assert (store.get_run(cancelled).status, store.get_run(cancelled).message) == (
        "cancelled",
        "cancelled by the user",
    )
    assert (store.get_run(failed).status, store.get_run(failed).message) == (
        "failed",
        "RuntimeError: boom",
    )
    assert all(store.events(r)[-1].seq == 7 for r in (solved, cancelled, failed))


def test_settle_run_adds_one_closing_event_once(store: RunStore) -> None:
    queued = store.create_run("line-2", 0, "baseline", {}, status="queued")
    record = store.settle_run(queued, "cancelled", "cancelled before it started")
    assert record is not None and record.status == "cancelled"
    (closing,) = store.events(queued)
    assert isinstance(closing, RunCancelled) and closing.reason == "cancelled before it started"
    assert store.settle_run(queued, "failed", "again") is None  # already over: unchanged
    assert store.get_run(queued).status == "cancelled" and len(store.events(queued)) == 1
    with pytest.raises(KeyError, match="unknown run id 'nope'"):
        store.settle_run("nope", "failed", "x")
    with pytest.raises(ValueError, match="unknown final status 'running'"):
        store.settle_run(queued, "running", "x")


def test_claim_run_takes_over_a_running_run_only(store: RunStore, gone: str) -> None:
    run_id = store.create_run("line-2", 0, "baseline", {}, status="queued", owner=gone)
    assert not store.claim_run(run_id)  # not started yet
    store.start_run(run_id)
    assert store.claim_run(run_id)
    assert store.mark_interrupted() == 0  # this test's process owns it now
    store.finish_run(run_id, "solved")
    assert not store.claim_run(run_id)


def test_integers_sqlite_cannot_hold_are_refused(store: RunStore) -> None:
    run_id = store.create_run("line-2", 0, "baseline", {})
    for call, name in (
        (lambda: store.events(run_id, after=2**63), "after"),
        (lambda: store.events(run_id, after=-2), "after"),
        (lambda: store.events(run_id, limit=2**64), "limit"),
        (lambda: store.list_runs(limit=-1), "limit"),
        (lambda: store.list_runs(offset=2**63), "offset"),
    ):
        with pytest.raises(ValueError, match=f"{name} must be an integer"):
            call()
    assert store.events(run_id, after=2**63 - 1) == []


def test_write_listeners_hear_of_events_once_they_are_stored(db: str, store: RunStore) -> None:
    run_id = store.create_run("line-2", 0, "baseline", {})
    heard: list[tuple[str, list[int], int]] = []

    def listener(rid: str, events: list[Event]) -> None:
        with RunStore(db) as other:  # another connection already sees them
            heard.append((rid, [e.seq for e in events], len(other.events(rid))))

    def broken(rid: str, events: list[Event]) -> None:
        raise BrokenPipeError("the server is gone")

    store.add_write_listener(broken)
    store.add_write_listener(listener)
    sink = StoreSink(store, run_id, batch_size=3, flush_interval_s=None)
    _emit_search(Emitter(run_id, sink), 2)
    sink.close()
    assert heard == [(run_id, [0, 1, 2], 3), (run_id, [3, 4, 5], 6), (run_id, [6], 7)]
    assert [e.seq for e in store.events(run_id)] == list(range(7))  # none written twice


def test_data_version_changes_when_anyone_commits(sqlite_db: Path) -> None:
    db = sqlite_db
    store = RunStore(db)
    first = store.data_version()
    assert first is not None and store.data_version() == first
    run_id = store.create_run("line-2", 0, "baseline", {})
    second = store.data_version()
    assert second != first
    with RunStore(db) as other:
        other.finish_run(run_id, "solved")
    assert store.data_version() != second
    store.close()
    with RunStore("sqlite://") as memory:
        assert memory.data_version() is None


def test_close_flushes_everything_buffered(db: str) -> None:
    store = RunStore(db)
    run_id = store.create_run("line-2", 3, "learned", CONFIG)
    sink = StoreSink(store, run_id, batch_size=10_000, flush_interval_s=60.0)
    _emit_search(Emitter(run_id, sink), 30)  # 91 events, none written yet
    assert store.events(run_id) == []
    sink.close()
    store.close()
    with RunStore(db) as again:
        assert [e.seq for e in again.events(run_id)] == list(range(91))
        assert len(again.stream_queries(run_ids=[run_id])) == 30


def test_terminal_event_flushes_at_once(store: RunStore) -> None:
    run_id = store.create_run("line-2", 3, "learned", CONFIG)
    sink = StoreSink(store, run_id, batch_size=10_000, flush_interval_s=None)
    emitter = Emitter(run_id, sink)
    _emit_search(emitter, 3)
    emitter.emit(
        RunFinished,
        status="failed",
        planning_s=1.0,
        execution_s=None,
        oracle_s=None,
        queries=3,
        message="budget spent",
    )
    assert len(store.events(run_id)) == 11  # before close
    sink.close()


def test_a_closing_events_number_is_read_per_run(store: RunStore) -> None:
    """What tamp report reads of each run's run_finished (its search CPU seconds), on either
    backend; a run without the number is left out, not read as zero."""
    runs = [store.create_run("line-2", 3, "learned", CONFIG) for _ in range(3)]
    for run_id, cpu in zip(runs, (0.25, None, 1.5), strict=True):
        sink = StoreSink(store, run_id, flush_interval_s=None)
        emitter = Emitter(run_id, sink)
        _emit_search(emitter, 2)
        emitter.emit(
            RunFinished,
            status="solved",
            planning_s=2.0,
            execution_s=1.0,
            oracle_s=1.0,
            queries=2,
            message="",
            search_cpu_s=cpu,
        )
        sink.close()
    found = store.event_numbers([*runs, "no-such-run"], "run_finished", "search_cpu_s")
    assert found == {runs[0]: 0.25, runs[2]: 1.5}
    assert store.event_numbers(runs, "run_finished", "queries") == dict.fromkeys(runs, 2.0)


def test_timer_flushes_a_quiet_buffer(store: RunStore) -> None:
    run_id = store.create_run("line-2", 3, "learned", CONFIG)
    sink = StoreSink(store, run_id, batch_size=10_000, flush_interval_s=0.05)
    Emitter(run_id, sink).emit(RunStarted, scene="line-2", seed=3, planner="x", config={})
    deadline = time.monotonic() + 5.0
    while not store.events(run_id) and time.monotonic() < deadline:
        time.sleep(0.01)
    assert len(store.events(run_id)) == 1  # written while the planner was busy elsewhere
    sink.close()


def test_failed_write_keeps_the_batch(store: RunStore, monkeypatch: pytest.MonkeyPatch) -> None:
    run_id = store.create_run("line-2", 3, "learned", CONFIG)
    sink = StoreSink(store, run_id, batch_size=5, flush_interval_s=None)
    emitter = Emitter(run_id, sink)
    real = store.write_events
    calls = {"n": 0}

    def flaky(rid: str, events: list[Event]) -> None:
        calls["n"] += 1
        if calls["n"] == 1:
            raise OSError("database is locked")
        real(rid, events)

    monkeypatch.setattr(store, "write_events", flaky)
    with pytest.raises(OSError, match="locked"):
        _emit_search(emitter, 2)  # the 5th event triggers the failing write
    _emit_search_rest(emitter)
    sink.close()
    assert [e.seq for e in store.events(run_id)] == list(range(emitter.next_seq))


def _emit_search_rest(emitter: Emitter) -> None:
    for i in range(3):
        emitter.emit(NodeVisited, node_id=1, visits=i + 2, value=0.0)


def test_second_store_on_the_same_database_sees_the_data(db: str, store: RunStore) -> None:
    run_id = store.create_run("line-2", 3, "learned", CONFIG)
    sink = StoreSink(store, run_id, batch_size=4, flush_interval_s=None)
    _emit_search(Emitter(run_id, sink), 4)
    sink.close()
    with RunStore(db) as reader:
        assert reader.get_run(run_id) == store.get_run(run_id)
        assert reader.events(run_id) == store.events(run_id)
        assert len(reader.stream_queries()) == 4
    indices = {
        i["name"]
        for table in ("runs", "stream_queries")
        for i in inspect(store.engine).get_indexes(table)
    }
    assert {"ix_stream_queries_stream", "ix_stream_queries_run_id", "ix_runs_created_at"} <= indices


def test_a_sqlite_store_reads_while_it_is_written(sqlite_db: Path) -> None:
    RunStore(sqlite_db).close()
    with sqlite3.connect(sqlite_db) as conn:
        assert conn.execute("PRAGMA journal_mode").fetchone() == ("wal",)


def test_unknown_run_ids_are_key_errors_naming_the_id(store: RunStore) -> None:
    for call in (
        lambda: store.get_run("nope"),
        lambda: store.events("nope"),
        lambda: store.finish_run("nope", "failed"),
        lambda: StoreSink(store, "nope"),
    ):
        with pytest.raises(KeyError, match="unknown run id 'nope'"):
            call()


def test_sink_refuses_other_runs_and_repeated_seqs(store: RunStore) -> None:
    run_id = store.create_run("line-2", 3, "learned", CONFIG)
    sink = StoreSink(store, run_id, flush_interval_s=None)
    event = NodeVisited(run_id, 0, 0.0, node_id=1, visits=1, value=0.0)
    sink.emit(event)
    with pytest.raises(ValueError, match="seq must increase"):
        sink.emit(event)
    with pytest.raises(ValueError, match="belongs to run 'other'"):
        sink.emit(NodeVisited("other", 1, 0.0, node_id=1, visits=1, value=0.0))
    sink.close()
    with pytest.raises(RuntimeError, match="closed"):
        sink.emit(NodeVisited(run_id, 1, 0.0, node_id=1, visits=1, value=0.0))
    resumed = StoreSink(store, run_id, flush_interval_s=None)  # continues after the stored seq
    with pytest.raises(ValueError, match="seq must increase"):
        resumed.emit(event)
    resumed.close()


def test_default_db_path_follows_xdg(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    assert default_db_path() == tmp_path / "guided-tamp" / "runs.db"
    monkeypatch.delenv("XDG_DATA_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert default_db_path() == tmp_path / "home" / ".local" / "share" / "guided-tamp" / "runs.db"


def test_in_memory_url_is_one_database_across_threads() -> None:
    with RunStore("sqlite://") as store:
        run_id = store.create_run("line-2", 0, "x", {})
        sink = StoreSink(store, run_id, batch_size=1000, flush_interval_s=0.01)
        _emit_search(Emitter(run_id, sink), 2)
        sink.close()
        assert len(store.events(run_id)) == 7


def _open_at_once(url: str, n: int) -> list[Exception]:
    """``n`` threads open the store at ``url`` at the same moment and record a run each."""
    import threading

    barrier = threading.Barrier(n)
    errors: list[Exception] = []

    def open_and_record(seed: int) -> None:
        barrier.wait()
        try:
            with RunStore(url) as store:
                store.create_run("line-2", seed, "baseline", {})
        except Exception as exc:
            errors.append(exc)

    threads = [threading.Thread(target=open_and_record, args=(s,)) for s in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return errors


@pytest.mark.parametrize("backend", BACKENDS)
def test_many_openers_of_a_new_store_at_once_all_get_it(
    backend: str, tmp_path: Path, request: pytest.FixtureRequest
) -> None:
    """Trials started together on a fresh store race to create its tables; before, the
    loser died with "table runs already exists" (or "database is locked") and its trial was
    never recorded."""
    for attempt in range(5):
        if backend == "sqlite":
            url = str(tmp_path / f"fresh-{attempt}.db")
        else:
            url = request.getfixturevalue("postgres").new_database()
        assert not _open_at_once(url, 4)
        with RunStore(url) as store:
            assert store.count_runs() == 4


def _record_runs(url: str, seeds: list[int], steps: int) -> None:
    """A benchmark's trial process: runs recorded one after the other, each in batches."""
    with RunStore(url) as store:
        for seed in seeds:
            run_id = store.create_run("line-2", seed, "learned", CONFIG)
            sink = StoreSink(store, run_id, batch_size=50)
            emitter = Emitter(run_id, sink)
            _emit_search(emitter, steps)
            emitter.emit(
                RunFinished,
                status="solved",
                planning_s=1.0,
                execution_s=2.0,
                oracle_s=0.5,
                queries=steps,
                message="",
            )
            sink.close()
            store.finish_run(run_id, "solved", planning_s=1.0, queries=steps)


def test_four_writers_and_a_reader_at_once_lose_nothing(db: str) -> None:
    """Four processes record runs into one store while a dashboard reads it: every event and
    query arrives, and a reader only ever sees a run's events from 0 without a gap."""
    import multiprocessing

    RunStore(db).close()
    steps, per_process = 100, 3
    ctx = multiprocessing.get_context("spawn")
    writers = [
        ctx.Process(target=_record_runs, args=(db, [10 * w + i for i in range(per_process)], steps))
        for w in range(4)
    ]
    for w in writers:
        w.start()
    reads = 0
    with RunStore(db) as reader:
        while any(w.is_alive() for w in writers) or reads == 0:
            for run in reader.list_runs(limit=100):
                seqs = [e.seq for e in reader.events(run.id)]
                assert seqs == list(range(len(seqs)))  # a prefix, in order, never a gap
                reads += 1
        for w in writers:
            w.join(timeout=120)
            assert w.exitcode == 0
        runs = reader.list_runs(limit=100)
        assert sorted(r.seed for r in runs) == sorted(
            10 * w + i for w in range(4) for i in range(per_process)
        )
        for run in runs:
            assert run.status == "solved"
            assert [e.seq for e in reader.events(run.id)] == list(range(3 * steps + 2))
        assert len(reader.stream_queries()) == 4 * per_process * steps
    assert reads > 0


def test_an_exited_owner_not_yet_reaped_counts_as_gone(store: RunStore) -> None:
    """A worker whose server was killed is adopted by a process that may not reap it soon:
    its zombie must not keep its run looking alive."""
    process = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(0.5)"])
    token = process_token(process.pid)
    assert is_alive(token)
    deadline = time.monotonic() + 30
    stat = Path(f"/proc/{process.pid}/stat")
    while stat.read_text().rpartition(")")[2].split()[0] != "Z":  # exited, not reaped
        assert time.monotonic() < deadline
        time.sleep(0.05)
    assert not is_alive(token)
    run_id = store.create_run("line-2", 0, "baseline", {}, owner=token)
    assert store.mark_interrupted() == 1 and store.get_run(run_id).status == "interrupted"
    process.wait()
    recycled = process_token().rsplit(":", 1)[0] + ":999"  # a live pid, another start time
    assert is_alive(process_token()) and not is_alive(recycled)

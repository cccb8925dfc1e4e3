"""Reads of runs' events (app/reads.py): every page is the store's events exactly, in chunks
read one at a time through the read gate, so that many readers at once neither take every
thread of the server nor lock out the other routes; and the shared definitions' module."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from app import reads
from app.main import create_app
from app.settings import Settings
from planner import figures
from planner.events import (
    Event,
    ModelPrediction,
    NodeAdded,
    RunFinished,
    RunStarted,
    StreamQueried,
    event_to_dict,
)
from planner.store import RunStore

LOCAL = "http://127.0.0.1:8000"


def _events(run_id: str, n: int) -> list[Event]:
    """A run of ``n`` events: its start, a node and its query per pair, predictions, its end."""
    out: list[Event] = [
        RunStarted(run_id=run_id, seq=0, t=0.0, scene="line-2", seed=0, planner="x", config={})
    ]
    node = 0
    while len(out) < n - 1:
        seq = len(out)
        if seq % 3 == 1:
            node += 1
            out.append(
                StreamQueried(
                    run_id=run_id,
                    seq=seq,
                    t=seq * 0.001,
                    node_id=node,
                    stream="move",
                    input_names=["?a"],
                    inputs=[{"x": 1.5, "s": 'quote " and ,'}],
                    success=node % 4 != 0,
                    wall_s=0.01,
                    cpu_s=0.01,
                    execution_s=0.0,
                    error=None,
                    context={"facts": [["at", "a"]], "values": {}},
                )
            )
        elif seq % 3 == 2:
            out.append(
                NodeAdded(
                    run_id=run_id,
                    seq=seq,
                    t=seq * 0.001,
                    node_id=node,
                    parent_id=0,
                    plan_index=0,
                    depth=1,
                    stream="move",
                    success=node % 4 != 0,
                    outputs=[],
                    label=f"node {node}",
                )
            )
        else:
            out.append(
                ModelPrediction(
                    run_id=run_id,
                    seq=seq,
                    t=seq * 0.001,
                    node_id=node,
                    p_s=0.5,
                    r_s=1.0,
                    r_f=2.0,
                    r_m=0.0,
                    q=float(seq),
                )
            )
    out.append(
        RunFinished(
            run_id=run_id,
            seq=len(out),
            t=1.0,
            status="timeout",
            planning_s=1.0,
            execution_s=None,
            oracle_s=None,
            queries=node,
            message="no plan",
        )
    )
    return out


@pytest.fixture()
def stored(tmp_path: Path) -> tuple[str, str, list[Event]]:
    db = str(tmp_path / "runs.db")
    with RunStore(db) as store:
        run_id = store.create_run("line-2", 0, "baseline", {})
        events = _events(run_id, 2 * reads.CHUNK + 37)
        store.write_events(run_id, events)
        store.finish_run(run_id, "timeout", planning_s=1.0, queries=0, message="no plan")
    return db, run_id, events


@pytest.fixture()
def client(tmp_path: Path, stored: tuple[str, str, list[Event]]) -> Iterator[TestClient]:
    settings = Settings(
        database_url=stored[0],
        viewer=False,
        reports_dir=tmp_path / "reports",
        model_dir=tmp_path / "models",
    )
    with TestClient(create_app(settings), base_url=LOCAL) as c:
        yield c


def test_the_store_serves_each_event_as_event_to_json_makes_it(
    stored: tuple[str, str, list[Event]],
) -> None:
    db, run_id, events = stored
    with RunStore(db) as store:
        served = store.event_json(run_id, after=4, limit=20)
    assert [seq for seq, _ in served] == list(range(5, 25))
    assert [json.loads(text) for _, text in served] == [event_to_dict(e) for e in events[5:25]]


def test_pages_are_the_stored_events_across_chunks(
    client: TestClient, stored: tuple[str, str, list[Event]]
) -> None:
    _, run_id, events = stored
    want = [event_to_dict(e) for e in events]
    got: list[dict[str, Any]] = []
    after = -1
    pages = 0
    while True:
        page = client.get(f"/api/runs/{run_id}/events?after={after}&limit=700").json()
        pages += 1
        got += page["events"]
        assert page["next_after"] == (got[-1]["seq"] if got else -1)
        after = page["next_after"]
        if page["done"]:
            break
    assert len(events) % 700 != 0
    assert got == want and pages == -(-len(events) // 700)  # the last page short: done
    empty = client.get(f"/api/runs/{run_id}/events?after={len(events) - 1}").json()
    last = len(events) - 1
    assert empty == {"events": [], "next_after": last, "done": True, "last_seq": last}
    full = client.get(f"/api/runs/{run_id}/events?after=-1&limit={len(events)}").json()
    assert full["events"] == want and not full["done"]  # exactly a page: there may be more
    assert client.get("/api/runs/nope/events").status_code == 404
    assert client.get(f"/api/runs/{run_id}/events?limit=5001").status_code == 422


def test_many_readers_take_their_turns_and_the_other_routes_keep_answering(
    client: TestClient, stored: tuple[str, str, list[Event]]
) -> None:
    """60 readers of whole pages at once: never more than READERS chunks read at once, every
    reader gets the whole page, and the runs list and the health check are answered while they
    wait (counted in chunks read, not in seconds)."""
    _, run_id, events = stored
    dash = client.app.state.dashboard  # type: ignore[attr-defined]
    lock = threading.Lock()
    active, most, finished = 0, 0, 0
    reading = dash.store.event_json
    release = threading.Event()

    def counted(*args: Any, **kwargs: Any) -> Any:
        nonlocal active, most, finished
        with lock:
            active += 1
            most = max(most, active)
        try:
            release.wait(60)  # held until the other routes have been asked
            return reading(*args, **kwargs)
        finally:
            with lock:
                active -= 1
                finished += 1

    dash.store.event_json = counted
    readers = 60
    url = f"/api/runs/{run_id}/events?after=-1&limit=5000"
    with ThreadPoolExecutor(readers) as pool:
        pages = [pool.submit(lambda: client.get(url)) for _ in range(readers)]
        while dash.reads.waiting < readers - reads.READERS:  # all in, most of them waiting
            threading.Event().wait(0.01)
        assert client.get("/api/health").status_code == 200
        assert client.get("/api/runs").json()["total"] == 1
        assert finished == 0  # answered while every reader still waited
        release.set()
        answers = [p.result() for p in pages]
    assert most == reads.READERS
    want = [event_to_dict(e) for e in events]
    for answer in answers:
        assert answer.status_code == 200
        assert answer.json()["events"] == want


def test_the_page_reads_the_definitions_of_planner_figures(client: TestClient) -> None:
    answer = client.get("/generated/definitions.js")
    assert answer.status_code == 200
    assert answer.headers["content-type"].startswith("text/javascript")
    line = next(x for x in answer.text.splitlines() if x.startswith("export const DEFINITIONS"))
    data = json.loads(line.removeprefix("export const DEFINITIONS = ").removesuffix(";"))
    assert data == figures.definitions()
    assert data["run_statuses"] == list(figures.STATUS_TEXT)
    assert "export const Q_STOPS = DEFINITIONS.q_stops;" in answer.text


def test_one_q_scale_and_one_way_to_count_queries() -> None:
    qs = [float(q) for q in range(1, 101)]
    assert figures.q_scale(qs) == (2.0, 99.0)  # nearest rank: floor(0.02 * 99), ceil(0.98 * 99)
    assert figures.q_scale([]) is None
    assert figures.q_rgb_at(0.0) == figures.Q_STOPS[0]
    assert figures.q_rgb_at(1.0) == figures.Q_STOPS[-1]
    parents = {0: None, 1: 0, 2: 1, 3: 2, 4: 0}
    assert figures.effective_q(parents, {1: 5.0}) == {0: None, 1: 5.0, 2: 5.0, 3: 5.0, 4: None}
    events = [
        {"type": "stream_queried", "stream": "ik", "success": True, "reused_from": None},
        {"type": "stream_queried", "stream": "ik", "success": False, "reused_from": None},
        {"type": "stream_queried", "stream": "ik", "success": True, "reused_from": 3},
        {"type": "node_added", "stream": "ik"},
    ]
    count = figures.count_queries(events)["ik"]
    assert (count.ok, count.failed, count.reused, count.queries) == (1, 1, 1, 2)
    assert figures.interval_note(10) is None
    assert "only 2 seeds" in (figures.interval_note(2) or "")

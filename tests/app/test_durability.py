"""kill -9 of a real ``tamp serve`` and its workers: nothing a client was served is lost, every
run's status follows its stored events, a worker never outlives its server, and a ``tamp plan``
on the same database is left alone.

Runs use the line domain (pure Python, milliseconds a query): ``line-2`` solves at once and
``line-far``, a copy whose goal lies out of reach, searches until its budget, thousands of
events a second, so a kill lands before, during or after a run's search.
"""

from __future__ import annotations

import contextlib
import http.client
import json
import os
import random
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from websockets.exceptions import WebSocketException
from websockets.sync.client import connect

from app.main import create_app
from app.settings import Settings
from planner.events import TERMINAL_TYPES, event_to_dict
from planner.store import LIVE_STATUSES, RunStore

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
TAMP = str(Path(sys.executable).with_name("tamp"))
EventDict = dict[str, Any]


@pytest.fixture(scope="module")
def scenes(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("scenes")
    shutil.copy(ROOT / "scenes" / "line-2.json", folder)
    far = json.loads((ROOT / "scenes" / "line-2.json").read_text())
    far["name"] = "line-far"
    far["description"] = "line-2 with its goal out of reach: searches until the budget"
    far["regions"][1] = {"name": "goal", "lo": 11.0, "hi": 14.0}
    (folder / "line-far.json").write_text(json.dumps(far))
    return folder


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _request(url: str, body: dict[str, Any] | None = None) -> Any:
    data = None if body is None else json.dumps(body).encode()
    headers = {"content-type": "application/json"} if body is not None else {}
    request = urllib.request.Request(url, data=data, headers=headers)
    with urllib.request.urlopen(request, timeout=10) as response:
        return json.load(response)


# How long a killed server's workers may take to go before the test fails: they go within
# moments (0.1 s measured, docs/experiments.md), but a busy machine may delay any process; far
# less than the budgets of the runs they would otherwise plan on.
ORPHAN_WAIT_S = 30.0


def _stopped(pid: int) -> bool:
    """Gone, or exited and waiting to be reaped by whoever adopted it."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0]
    except FileNotFoundError:
        return True
    return state in ("Z", "X")


class Server:
    """``tamp serve`` on a free port; ``kill()`` is kill -9."""

    def __init__(self, db: Path, scenes: Path, log: Path, max_running: int = 2) -> None:
        self.port = _free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        command = [TAMP, "serve", "--no-viewer", "--port", str(self.port), "--db", str(db)]
        command += ["--max-running", str(max_running), "--max-queued", "20"]
        env = {**os.environ, "TAMP_SCENES_DIR": str(scenes)}
        self.log = log
        with log.open("ab") as out:
            self.process = subprocess.Popen(command, stdout=out, stderr=out, env=env, cwd=ROOT)
        deadline = time.monotonic() + 60
        while True:
            assert self.process.poll() is None, log.read_text()
            try:
                _request(self.url + "/api/health")
                return
            except OSError:
                assert time.monotonic() < deadline, log.read_text()
                time.sleep(0.1)

    def api(self, path: str, body: dict[str, Any] | None = None) -> Any:
        return _request(self.url + path, body)

    def workers(self) -> list[int]:
        """The worker processes (spawned children, not multiprocessing's resource tracker)."""
        pids = []
        for task in Path(f"/proc/{self.process.pid}/task").glob("*"):
            try:
                pids += [int(p) for p in (task / "children").read_text().split()]
            except FileNotFoundError:
                continue
        out = []
        for pid in pids:
            try:
                cmdline = Path(f"/proc/{pid}/cmdline").read_bytes()
            except FileNotFoundError:
                continue
            if b"spawn_main" in cmdline and b"resource_tracker" not in cmdline:
                out.append(pid)
        return out

    def kill(self) -> None:
        self.process.send_signal(signal.SIGKILL)
        self.process.wait()

    def stop(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.kill()


class Served:
    """Every event a client of the server received, by run and seq (REST and websockets)."""

    def __init__(self) -> None:
        self.events: dict[str, dict[int, EventDict]] = {}
        self.lock = threading.Lock()
        self.threads: list[threading.Thread] = []

    def add(self, run_id: str, events: list[EventDict]) -> None:
        with self.lock:
            for event in events:
                seen = self.events.setdefault(run_id, {}).setdefault(event["seq"], event)
                assert seen == event, (run_id, seen, event)  # served twice, the same

    def wait_any(self, run_ids: list[str], timeout: float) -> None:
        """Until a client was served an event of one of ``run_ids``."""
        deadline = time.monotonic() + timeout
        while not any(self.events.get(run_id) for run_id in run_ids):
            assert time.monotonic() < deadline, f"no event of {run_ids} in {timeout} s"
            time.sleep(0.02)

    def follow(self, server: Server, run_id: str) -> None:
        for target in (self._websocket, self._rest):
            thread = threading.Thread(target=target, args=(server, run_id), daemon=True)
            thread.start()
            self.threads.append(thread)

    def _websocket(self, server: Server, run_id: str) -> None:
        url = f"ws://127.0.0.1:{server.port}/api/runs/{run_id}/stream"
        try:
            with connect(url, max_size=None, open_timeout=10) as ws:
                for message in ws:
                    data = json.loads(message)
                    if data["type"] != "control":
                        self.add(run_id, [data])
                    elif data["kind"] == "end":
                        return
        except (OSError, TimeoutError, WebSocketException):
            return  # the server died under it

    def _rest(self, server: Server, run_id: str) -> None:
        after = -1
        try:
            while True:
                page = server.api(f"/api/runs/{run_id}/events?after={after}&limit=2000")
                self.add(run_id, page["events"])
                after = page["next_after"]
                if page["done"]:
                    return
                if not page["events"]:
                    time.sleep(0.05)
        except (OSError, urllib.error.URLError, http.client.HTTPException, ValueError):
            return  # the server died under it (mid-answer: an incomplete read)

    def join(self) -> None:
        for thread in self.threads:
            thread.join(timeout=30)
            assert not thread.is_alive()
        self.threads.clear()


def _wait_settled(server: Server, timeout: float = 30) -> list[dict[str, Any]]:
    deadline = time.monotonic() + timeout
    while True:
        runs = server.api("/api/runs?limit=500")["runs"]
        live = [r for r in runs if r["status"] in LIVE_STATUSES]
        if not live:
            return list(runs)
        assert time.monotonic() < deadline, f"runs still live: {live}"
        time.sleep(0.2)


def _check_store(db: Path, served: Served) -> dict[str, int]:
    """Every run: events 0..n without gaps, one closing event and last, the status it says,
    and every event any client was served stored exactly as served."""
    statuses: dict[str, int] = {}
    with RunStore(db) as store:
        runs = store.list_runs(limit=1000)
        for run in runs:
            events = [event_to_dict(e) for e in store.events(run.id)]
            assert [e["seq"] for e in events] == list(range(len(events))), run.id
            closing = [e for e in events if e["type"] in TERMINAL_TYPES]
            assert len(closing) == 1 and closing[0] is events[-1], (run.id, run.status, closing)
            end = closing[0]
            expected = {
                "run_finished": {end.get("status")},
                "run_cancelled": {"cancelled"},
                "run_failed": {"failed", "interrupted"},
            }[end["type"]]
            assert run.status in expected, (run.id, run.status, end)
            assert run.finished_at is not None
            if end["type"] == "run_finished":
                assert (run.planning_s, run.queries) == (end["planning_s"], end["queries"])
            stored = {e["seq"]: e for e in events}
            for seq, event in served.events.get(run.id, {}).items():
                assert stored.get(seq) == event, f"run {run.id}: served #{seq} not stored as is"
            statuses[run.status] = statuses.get(run.status, 0) + 1
    return statuses


def test_kill_9_of_server_and_workers_loses_nothing_served(scenes: Path, tmp_path: Path) -> None:
    db, log = tmp_path / "runs.db", tmp_path / "serve.log"
    rng = random.Random(28)
    served = Served()
    launched = 0
    kinds: dict[str, int] = {}
    for life in range(8):
        server = Server(db, scenes, log)
        ids: list[str] = []
        for _ in range(3):
            far = rng.random() < 0.75
            body = {
                "scene": "line-far" if far else "line-2",
                "seed": life,
                "k": 2,
                "budget_s": round(rng.uniform(0.3, 2.5), 2),
            }
            run = server.api("/api/runs", body)
            launched += 1
            served.follow(server, run["id"])
            ids.append(run["id"])
        # The kill's moment counts from the first event of this life's runs, not from the
        # launch: on a busy machine a worker's start (imports) can outlast a fixed delay, and
        # every kill would land before any run began.
        served.wait_any(ids, timeout=60)
        time.sleep(rng.uniform(0.0, 4.0))
        kind = rng.choice(["server", "both", "workers first"])
        kinds[kind] = kinds.get(kind, 0) + 1
        workers = server.workers()
        if kind == "workers first":
            for pid in workers:
                os.kill(pid, signal.SIGKILL)
        server.kill()
        if kind == "both":
            for pid in workers:
                with contextlib.suppress(ProcessLookupError):  # it may have stopped already
                    os.kill(pid, signal.SIGKILL)
        deadline = time.monotonic() + ORPHAN_WAIT_S
        while not all(_stopped(pid) for pid in workers):
            assert time.monotonic() < deadline, f"workers {workers} outlived their server"
            time.sleep(0.02)
        served.join()
    server = Server(db, scenes, log)
    try:
        runs = _wait_settled(server)
    finally:
        server.stop()
    assert len(runs) == launched >= 20
    statuses = _check_store(db, served)
    assert sum(statuses.values()) == launched
    assert sum(len(v) for v in served.events.values()) > 1000, "clients saw little"
    print(f"kill -9 over {launched} runs ({kinds}): {statuses}")


def test_a_killed_servers_worker_stops_at_once(scenes: Path, tmp_path: Path) -> None:
    db, log = tmp_path / "runs.db", tmp_path / "serve.log"
    server = Server(db, scenes, log, max_running=1)
    run = server.api("/api/runs", {"scene": "line-far", "k": 2, "budget_s": 120})
    served = Served()
    served.follow(server, run["id"])
    # Searching, and its clients served 500 events (on a busy machine they can lag the store).
    deadline = time.monotonic() + 60
    while len(served.events.get(run["id"], {})) <= 500:
        assert time.monotonic() < deadline, server.api(f"/api/runs/{run['id']}")["last_seq"]
        time.sleep(0.1)
    (worker,) = server.workers()
    server.kill()
    killed = time.monotonic()
    while not _stopped(worker):
        # Its run's budget is 120 s: a worker that did not watch its server would plan on.
        assert time.monotonic() - killed < ORPHAN_WAIT_S, "the worker outlived its server"
        time.sleep(0.01)
    served.join()
    with RunStore(db) as store:
        stored = store.last_seq(run["id"])
    time.sleep(1.0)
    with RunStore(db) as store:
        assert store.last_seq(run["id"]) == stored  # nothing written after it stopped

    again = Server(db, scenes, log, max_running=1)
    try:
        (settled,) = _wait_settled(again)
        assert settled["status"] == "interrupted"
        assert again.api("/api/health")["running"] == 0
        fresh = again.api("/api/runs", {"scene": "line-2", "k": 2})  # the slot is free
        finished = _wait_settled(again)
        assert {r["id"]: r["status"] for r in finished}[fresh["id"]] == "solved"
    finally:
        again.stop()
    statuses = _check_store(db, served)
    assert statuses == {"interrupted": 1, "solved": 1}
    assert len(served.events[run["id"]]) > 500


def test_a_tamp_plan_on_the_same_database_is_left_alone(scenes: Path, tmp_path: Path) -> None:
    db = tmp_path / "runs.db"
    env = {**os.environ, "TAMP_SCENES_DIR": str(scenes)}
    command = [TAMP, "plan", "--scene", "line-far", "--k", "2", "--budget", "120", "--db", str(db)]
    plan = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while True:
            assert plan.poll() is None
            assert time.monotonic() < deadline
            if db.exists():
                with RunStore(db) as store:
                    runs = store.list_runs()
                    if runs and store.last_seq(runs[0].id) > 100:
                        run_id = runs[0].id
                        break
            time.sleep(0.2)
        settings = Settings(database_url=str(db), viewer=False, reports_dir=tmp_path)
        with TestClient(create_app(settings), base_url="http://127.0.0.1:8000") as client:
            time.sleep(2.5)  # past the server's first sweeps
            assert client.get(f"/api/runs/{run_id}").json()["status"] == "running"
            plan.send_signal(signal.SIGKILL)
            plan.wait()
            deadline = time.monotonic() + 10
            while (run := client.get(f"/api/runs/{run_id}").json())["status"] == "running":
                assert time.monotonic() < deadline, "the dead tamp plan's run stayed running"
                time.sleep(0.2)
            assert run["status"] == "interrupted"
            events = client.get(
                f"/api/runs/{run_id}/events", params={"after": run["last_seq"] - 1}
            ).json()
            assert events["events"][-1]["type"] == "run_failed"
    finally:
        if plan.poll() is None:
            plan.kill()
            plan.wait()


def test_a_sigterm_of_the_server_records_its_runs_as_stopped_by_the_shutdown(
    scenes: Path, tmp_path: Path
) -> None:
    """SIGTERM (how a service manager stops `tamp serve`) stops the live run as a cancel
    does, but nobody cancelled it: it is recorded as stopped by the shutdown, in its message
    and its closing event, and the queued run as never started."""
    from app.worker import SERVER_SHUT_DOWN

    db, log = tmp_path / "runs.db", tmp_path / "serve.log"
    server = Server(db, scenes, log, max_running=1)
    live = server.api("/api/runs", {"scene": "line-far", "k": 2, "budget_s": 120})
    queued = server.api("/api/runs", {"scene": "line-2", "k": 2})
    deadline = time.monotonic() + 60
    while server.api(f"/api/runs/{live['id']}")["last_seq"] < 50:  # it is searching
        assert time.monotonic() < deadline, log.read_text()
        time.sleep(0.1)
    server.stop()  # SIGTERM, and its exit awaited
    # uvicorn shuts down, then raises the signal again: the exit says SIGTERM, not a crash
    assert server.process.returncode == -signal.SIGTERM, log.read_text()
    with RunStore(db) as store:
        stopped = store.get_run(live["id"])
        assert stopped.status == "cancelled", stopped
        assert stopped.message.startswith(SERVER_SHUT_DOWN) and "user" not in stopped.message
        closing = event_to_dict(store.events(live["id"])[-1])
        assert closing["type"] == "run_cancelled" and closing["reason"] == stopped.message
        never = store.get_run(queued["id"])
        assert never.status == "cancelled" and "before it started" in never.message

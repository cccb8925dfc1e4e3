"""The REST API and the websocket, in process (TestClient), with real worker processes, on a
SQLite store and on a PostgreSQL one (``store_url``, tests/conftest.py)."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings


def _settings(tmp_path: Path, store_url: str, **overrides: Any) -> Settings:
    values: dict[str, Any] = {
        "database_url": store_url,
        "viewer": False,
        "max_running": 1,
        "max_queued": 5,
        "cancel_grace_s": 3.0,
        "reports_dir": tmp_path / "reports",
    }
    values.update(overrides)
    return Settings(**values)


LOCAL = "http://127.0.0.1:8000"  # where a browser on this machine reaches the dashboard
WS = "ws://127.0.0.1:8000"


def _client(settings: Settings) -> TestClient:
    return TestClient(create_app(settings), base_url=LOCAL)


@pytest.fixture()
def client(tmp_path: Path, store_url: str) -> Iterator[TestClient]:
    with _client(_settings(tmp_path, store_url)) as c:
        yield c


def _wait_status(client: TestClient, run_id: str, wanted: set[str], timeout: float = 60) -> str:
    deadline = time.monotonic() + timeout
    status = ""
    while time.monotonic() < deadline:
        status = client.get(f"/api/runs/{run_id}").json()["status"]
        if status in wanted:
            return status
        time.sleep(0.1)
    raise AssertionError(f"run {run_id} still {status!r} after {timeout} s")


def _stream(client: TestClient, run_id: str, after: int = -1) -> list[dict[str, Any]]:
    messages = []
    with client.websocket_connect(f"{WS}/api/runs/{run_id}/stream?after={after}") as ws:
        while True:
            message = json.loads(ws.receive_text())
            messages.append(message)
            if message.get("type") == "control" and message["kind"] == "end":
                return messages


def test_catalogs_and_health(client: TestClient) -> None:
    health = client.get("/api/health").json()
    assert health["status"] == "ok" and health["running"] == 0 and health["viewer_url"] is None
    scenes = {s["name"]: s for s in client.get("/api/scenes").json()}
    assert scenes["kitchen-4"]["domain"] == "kitchen" and scenes["kitchen-4"]["blocks"] == 4
    assert scenes["line-2"]["domain"] == "line"
    models = client.get("/api/models").json()
    shipped = [m for m in models if m["default"]]
    assert shipped and shipped[0]["domain"] == "kitchen"
    assert "inverse-kinematics" in shipped[0]["streams"]
    assert client.get("/api/reports").json() == []
    assert "/api/runs" in client.get("/openapi.json").json()["paths"]


@pytest.mark.parametrize(
    ("body", "field", "says"),
    [
        ({"scene": "line-2", "colour": "red"}, "colour", "Extra inputs"),
        ({"scene": "kitchen-99"}, "scene", "kitchen-4"),  # lists the known scenes
        ({"scene": "../../etc/passwd"}, "scene", "should match pattern"),
        ({"scene": "/etc/passwd"}, "scene", "should match pattern"),
        ({"scene": "0"}, "scene", "unknown scene"),  # a name, just not one offered
        ({"scene": "line-2", "seed": -1}, "seed", "greater than or equal"),
        ({"scene": "line-2", "planner": "magic"}, "planner", "baseline"),
        ({"scene": "line-2", "budget_s": 0}, "budget_s", "greater than"),
        ({"scene": "line-2", "model": "kitchen"}, "model", "only used by the learned"),
        ({"scene": "line-2", "planner": "learned", "model": "kitchen"}, "model", "domain"),
        ({"scene": "kitchen-1", "planner": "learned", "model": "../kitchen"}, "model", "pattern"),
        ({"scene": "kitchen-1", "planner": "learned", "model": "kitchen-9"}, "model", "unknown"),
        ({"scene": "line-2", "seed": "0"}, "seed", "valid integer"),  # no coercion
        ({"scene": "line-2", "k": 2.5}, "k", "valid integer"),
        ({"scene": "line-2", "k": True}, "k", "valid integer"),
        ({"scene": "line-2", "budget_s": True}, "budget_s", "valid number"),
        ({"scene": "line-2", "budget_s": "30"}, "budget_s", "valid number"),
        ({"scene": 7}, "scene", "valid string"),
        ({"scene": "line-2", "max_queries": 0}, "max_queries", "greater than or equal"),
        ({"scene": "line-2", "max_queries": "500"}, "max_queries", "valid integer"),
        ({"scene": "line-2", "max_queries": 2**31}, "max_queries", "less than or equal"),
        ({"scene": "line-2", "max_iterations": -1}, "max_iterations", "greater than or equal"),
        ({"scene": "line-2", "max_iterations": 2.5}, "max_iterations", "valid integer"),
        ({"scene": "line-2", "max_iterations": True}, "max_iterations", "valid integer"),
    ],
)
def test_bad_launches_are_422_naming_the_field(
    client: TestClient, body: dict[str, Any], field: str, says: str
) -> None:
    response = client.post("/api/runs", json=body)
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert any(field in d["loc"] and says in d["msg"] for d in detail), detail
    assert client.get("/api/runs").json()["total"] == 0  # nothing was launched


def test_a_run_bounded_by_queries_stops_there_and_says_so(client: TestClient) -> None:
    """The bounds go into the run's stored config; the run ends on the query bound whatever
    its seconds (line-2 seed 3 needs 6 queries to solve)."""
    body = {"scene": "line-2", "seed": 3, "budget_s": 3600, "max_queries": 3}
    run = client.post("/api/runs", json=body).json()
    assert run["config"]["max_queries"] == 3 and run["config"]["max_iterations"] is None
    assert _wait_status(client, run["id"], {"solved", "timeout", "failed"}) == "timeout"
    detail = client.get(f"/api/runs/{run['id']}").json()
    assert detail["queries"] == 3 and detail["message"] == "no plan (query budget of 3 reached)"


def test_unknown_run_is_404(client: TestClient) -> None:
    assert client.get("/api/runs/nope").status_code == 404
    assert client.get("/api/runs/nope/events").status_code == 404
    assert client.delete("/api/runs/nope").status_code == 404
    assert client.put("/api/viewer", json={"run_id": "nope"}).status_code == 404
    with client.websocket_connect(f"{WS}/api/runs/nope/stream") as ws:
        assert json.loads(ws.receive_text())["kind"] == "error"


def test_launch_stream_and_read_a_run(client: TestClient) -> None:
    response = client.post("/api/runs", json={"scene": "line-2", "seed": 3, "budget_s": 30})
    assert response.status_code == 202
    run = response.json()
    assert run["status"] in {"queued", "running"} and run["scene"] == "line-2"

    messages = _stream(client, run["id"])  # from the start, while it runs
    events = [m for m in messages if m["type"] != "control"]
    assert [e["seq"] for e in events] == list(range(len(events)))  # every event, in order, once
    assert events[0]["type"] == "run_started" and events[-1]["type"] == "run_finished"
    assert any(e["type"] == "node_added" for e in events)
    assert messages[-1] == {"type": "control", "kind": "end", "status": "solved"}

    detail = client.get(f"/api/runs/{run['id']}").json()
    assert detail["status"] == "solved" and detail["last_seq"] == events[-1]["seq"]
    assert sum(c["ok"] + c["failed"] for c in detail["query_counts"].values()) == detail["queries"]

    page = client.get(f"/api/runs/{run['id']}/events", params={"after": 2, "limit": 3}).json()
    assert [e["seq"] for e in page["events"]] == [3, 4, 5] and page["next_after"] == 5
    rest = client.get(f"/api/runs/{run['id']}/events", params={"after": 5, "limit": 5000}).json()
    assert rest["done"] and rest["events"][-1]["type"] == "run_finished"

    later = _stream(client, run["id"], after=events[-3]["seq"])  # a finished run, resumed
    assert [m.get("seq") for m in later if m["type"] != "control"] == [
        e["seq"] for e in events[-2:]
    ]
    listed = client.get("/api/runs", params={"status": "solved", "scene": "line-2"}).json()
    assert listed["total"] == 1 and listed["runs"][0]["id"] == run["id"]
    assert client.get("/api/runs", params={"status": "failed"}).json()["total"] == 0
    assert client.delete(f"/api/runs/{run['id']}").status_code == 409  # already over


@pytest.mark.slow
def test_the_panda_plans_through_the_api_with_its_shipped_model(client: TestClient) -> None:
    scenes = {s["name"]: s for s in client.get("/api/scenes").json()}
    assert scenes["panda-6"]["domain"] == "panda" and scenes["panda-6"]["blocks"] == 6
    models = {m["domain"] for m in client.get("/api/models").json() if m["default"]}
    assert {"kitchen", "panda"} <= models
    body = {"scene": "panda-2", "seed": 1000, "planner": "learned", "budget_s": 120}
    run = client.post("/api/runs", json=body).json()
    assert _wait_status(client, run["id"], {"solved", "failed", "timeout"}) == "solved"
    events = client.get(f"/api/runs/{run['id']}/events", params={"limit": 5000}).json()
    finished = events["events"][-1]
    assert finished["type"] == "run_finished" and finished["valid"] is True
    assert any(e["type"] == "model_prediction" for e in events["events"])


@pytest.mark.slow
def test_queue_cancel_and_429(tmp_path: Path, store_url: str) -> None:
    settings = _settings(tmp_path, store_url, max_running=1, max_queued=1, cancel_grace_s=2.0)
    with _client(settings) as client:
        # kitchen-8 searches for minutes: the cancel lands while it searches, however fast
        body = {"scene": "kitchen-8", "budget_s": 120}
        first = client.post("/api/runs", json=body).json()
        second = client.post("/api/runs", json={**body, "seed": 1}).json()
        assert second["status"] == "queued"
        third = client.post("/api/runs", json={**body, "seed": 2})
        assert third.status_code == 429 and "queued" in third.json()["detail"]

        assert client.delete(f"/api/runs/{second['id']}").status_code == 202
        assert client.get(f"/api/runs/{second['id']}").json()["status"] == "cancelled"
        (closing,) = client.get(f"/api/runs/{second['id']}/events").json()["events"]
        assert closing["type"] == "run_cancelled" and "before it started" in closing["reason"]

        _wait_status(client, first["id"], {"running"})
        deadline = time.monotonic() + 60
        while client.get(f"/api/runs/{first['id']}").json()["last_seq"] < 3:  # it is searching
            assert time.monotonic() < deadline
            time.sleep(0.2)
        assert client.delete(f"/api/runs/{first['id']}").status_code == 202
        assert _wait_status(client, first["id"], {"cancelled"}, timeout=30) == "cancelled"
        events = client.get(f"/api/runs/{first['id']}/events", params={"limit": 5000}).json()
        seqs = [e["seq"] for e in events["events"]]
        assert seqs == list(range(len(seqs))) and len(seqs) > 3  # kept, no gaps
        assert events["events"][-1]["type"] == "run_cancelled"
        deadline = time.monotonic() + 30  # the manager lets go of the run's slot
        while client.get("/api/health").json()["running"] != 0:
            assert time.monotonic() < deadline
            time.sleep(0.2)


def test_runs_whose_process_died_are_marked_interrupted(tmp_path: Path, store_url: str) -> None:
    recorder = (  # a process that records the start of a run, then dies
        "import sys; from planner.store import RunStore; "
        "print(RunStore(sys.argv[1]).create_run('line-2', 0, 'baseline', {}))"
    )
    done = subprocess.run(
        [sys.executable, "-c", recorder, store_url],
        capture_output=True,
        text=True,
        check=True,
    )
    run_id = done.stdout.strip()
    with _client(_settings(tmp_path, store_url)) as client:
        run = client.get(f"/api/runs/{run_id}").json()
        assert run["status"] == "interrupted" and "stopped" in run["message"]
        (closing,) = client.get(f"/api/runs/{run_id}/events").json()["events"]
        assert closing["type"] == "run_failed" and closing["seq"] == 0


def test_page_and_plotly_are_served(client: TestClient) -> None:
    page = client.get("/")
    assert page.status_code == 200 and "<html" in page.text.lower()
    js = client.get("/vendor/plotly.min.js")
    assert js.status_code == 200 and len(js.content) > 1_000_000
    assert client.get("/reports/..%2F..%2Fetc%2Fpasswd").status_code == 404

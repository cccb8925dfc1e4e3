"""Benchmarks through the REST API: launched from the page and run by real worker processes
(each trial a process of its own), listed with their progress beside those of ``tamp bench``,
summarised exactly as ``tamp report`` does, cancelled with their finished trials kept, resumed.
"""

from __future__ import annotations

import socket
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from planner.bench import make_config, run_bench
from planner.report import summarize
from planner.store import RunStore

LOCAL = "http://127.0.0.1:8000"
TABLETOP = Path(__file__).resolve().parents[2] / "examples" / "tabletop2d"


def _settings(tmp_path: Path) -> Settings:
    return Settings(
        database_url=str(tmp_path / "runs.db"),
        viewer=False,
        reports_dir=tmp_path / "reports",
        model_dir=tmp_path / "models",
        extra_domains=[TABLETOP],
    )


@pytest.fixture()
def client(tmp_path: Path) -> Iterator[TestClient]:
    with TestClient(create_app(_settings(tmp_path)), base_url=LOCAL) as c:
        yield c


def _wait(client: TestClient, bench_id: str, done: int | None = None, timeout: float = 240) -> Any:
    """The benchmark once it stopped running (or has ``done`` trials); every progress seen
    on the way in ``seen``."""
    deadline = time.monotonic() + timeout
    seen = []
    while True:
        bench = client.get(f"/api/benchmarks/{bench_id}").json()
        seen.append(bench["done"])
        if (done is not None and bench["done"] >= done) or bench["status"] != "running":
            bench["seen"] = seen
            return bench
        assert time.monotonic() < deadline, bench
        time.sleep(0.3)


@pytest.mark.slow
def test_a_benchmark_from_the_page_runs_and_reports_as_tamp_report_does(
    client: TestClient, tmp_path: Path
) -> None:
    body = {"scene": "line-2", "planners": ["baseline", "learned"], "trials": 3, "budget_s": 30}
    response = client.post("/api/benchmarks", json=body)
    assert response.status_code == 202, response.text
    bench = response.json()
    assert bench["status"] == "running" and bench["runner"] == "dashboard"
    assert bench["total"] == 6 and bench["seeds"] == 3 and bench["seed_first"] == 1000
    # One at a time from the page.
    second = client.post("/api/benchmarks", json=body)
    assert second.status_code == 429 and "cancel it or wait" in second.json()["detail"]

    done = _wait(client, bench["id"])
    assert done["status"] == "done", done
    assert done["done"] == 6 and done["seen"] == sorted(done["seen"])  # progress only grows
    assert {p: v["done"] for p, v in done["progress"].items()} == {"baseline": 3, "learned": 3}
    # The page's figures are tamp report's, computed by the same function.
    summary = done["summary"]
    expected = summarize(tmp_path / "runs.db", bench["id"])
    assert summary["planners"] == expected["planners"]
    assert summary["paired"] == expected["paired"]
    assert summary["trials"] == expected["trials"]
    assert [row["seed"] for row in summary["trials"]] == [1000, 1001, 1002]
    for row in summary["trials"]:  # every trial is a stored run the compare view can open
        for planner in ("baseline", "learned"):
            run = client.get(f"/api/runs/{row[planner]['run_id']}").json()
            assert run["planner"] == planner and run["seed"] == row["seed"]
    listed = client.get("/api/benchmarks").json()
    assert [b["id"] for b in listed] == [bench["id"]]
    assert client.post("/api/benchmarks/" + bench["id"] + "/resume", json={}).status_code == 409
    assert client.delete("/api/benchmarks/" + bench["id"]).status_code == 409


@pytest.mark.slow
def test_tamp_bench_runs_show_up_and_a_dead_one_is_interrupted(
    client: TestClient, tmp_path: Path
) -> None:
    config = make_config("line-2", ["baseline"], trials=2, seed_start=5, budget_s=30, domain=None)
    bench_id, _ = run_bench(tmp_path / "runs.db", config, workers=1)
    with RunStore(tmp_path / "runs.db") as store:  # one that a killed process left running
        gone_process = f"{socket.gethostname()}:999999999:1"
        dead = store.create_bench({**config.to_dict(), "seeds": [7]}, owner=gone_process)
    listed = {b["id"]: b for b in client.get("/api/benchmarks").json()}
    assert listed[bench_id]["status"] == "done" and listed[bench_id]["done"] == 2
    assert listed[bench_id]["runner"] is None
    deadline = time.monotonic() + 20
    while client.get(f"/api/benchmarks/{dead}").json()["status"] == "running":
        assert time.monotonic() < deadline
        time.sleep(0.2)
    gone = client.get(f"/api/benchmarks/{dead}").json()
    assert gone["status"] == "interrupted" and gone["done"] == 0


@pytest.mark.slow
def test_cancel_keeps_the_finished_trials_and_resume_runs_the_rest(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    body = {
        "scene": "tabletop-3",
        "planners": ["baseline"],
        "trials": 12,
        "budget_s": 30,
        "workers": 1,
    }
    # The server records a cancel's ending slowly here, so a reader polls while the worker's
    # own "interrupted" is in the store: the benchmark must read "running" until "cancelled".
    store = client.app.state.dashboard.store  # type: ignore[attr-defined]
    record_status = store.set_bench_status

    def slow_record(bench_id: str, status: str, **kw: Any) -> None:
        time.sleep(1.5)
        record_status(bench_id, status, **kw)

    monkeypatch.setattr(store, "set_bench_status", slow_record)
    bench = client.post("/api/benchmarks", json=body).json()
    partway = _wait(client, bench["id"], done=2)
    assert partway["status"] == "running", partway
    cancelled = client.delete(f"/api/benchmarks/{bench['id']}")
    assert cancelled.status_code == 202
    deadline = time.monotonic() + 60
    while (info := client.get(f"/api/benchmarks/{bench['id']}").json())["status"] == "running":
        assert time.monotonic() < deadline
        time.sleep(0.05)
    assert info["status"] == "cancelled" and "kept" in info["message"]
    monkeypatch.undo()
    kept = info["done"]
    assert 2 <= kept < 12
    assert len(info["summary"]["trials"]) == kept  # nothing finished was lost
    # No run of the benchmark stays "running" once its trial process is gone.
    deadline = time.monotonic() + 20
    while client.get("/api/runs", params={"status": "running"}).json()["total"]:
        assert time.monotonic() < deadline
        time.sleep(0.3)

    resumed = client.post(f"/api/benchmarks/{bench['id']}/resume", json={"workers": 2})
    assert resumed.status_code == 202, resumed.text
    finished = _wait(client, bench["id"])
    assert finished["status"] == "done" and finished["done"] == 12
    seeds = [row["seed"] for row in finished["summary"]["trials"]]
    assert seeds == list(range(1000, 1012))


@pytest.mark.parametrize(
    ("body", "loc", "says"),
    [
        ({"scene": "nowhere-1"}, ["body", "scene"], "unknown scene"),
        ({"scene": "line-2", "planners": ["baseline", "magic"]}, ["body", "planners", 1], "magic"),
        (
            {"scene": "line-2", "planners": ["baseline", "learned:nonsense=on"]},
            ["body", "planners", 1],
            "nonsense",
        ),
        (
            {"scene": "line-2", "planners": ["baseline", "baseline"]},
            ["body", "planners", 1],
            "twice",
        ),
        ({"scene": "line-2", "planners": []}, ["body", "planners"], "at least 1"),
        ({"scene": "line-2", "trials": 0}, ["body", "trials"], "greater than or equal"),
        ({"scene": "line-2", "budget_s": -1}, ["body", "budget_s"], "greater than"),
        ({"scene": "line-2", "model": "kitchen"}, ["body", "model"], "domain"),
        (
            {"scene": "line-2", "planners": ["baseline"], "model": "kitchen"},
            ["body", "model"],
            "only used by the learned",
        ),
        ({"scene": "line-2", "workers": "2"}, ["body", "workers"], "valid integer"),
        ({"scene": "line-2", "max_queries": 0}, ["body", "max_queries"], "greater than or"),
        ({"scene": "line-2", "max_iterations": 1.5}, ["body", "max_iterations"], "valid integer"),
        ({"scene": "line-2", "colour": "red"}, ["body", "colour"], "Extra inputs"),
        (  # the shipped model saw kitchen-4 seeds 0-99: a benchmark must not test on them
            {"scene": "kitchen-4", "seed_start": 10, "trials": 2},
            ["body", "seed_start"],
            "trained on",
        ),
    ],
)
def test_bad_benchmarks_are_422_naming_the_field(
    client: TestClient, body: dict[str, Any], loc: list[Any], says: str
) -> None:
    response = client.post("/api/benchmarks", json=body)
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert any(d["loc"] == loc and says in d["msg"] for d in detail), detail
    assert client.get("/api/benchmarks").json() == []  # nothing was recorded


def test_unknown_benchmarks_are_404(client: TestClient) -> None:
    assert client.get("/api/benchmarks/nope").status_code == 404
    assert client.delete("/api/benchmarks/nope").status_code == 404
    assert client.post("/api/benchmarks/nope/resume", json={}).status_code == 404


def test_a_benchmark_names_its_model_as_the_models_page_does(
    client: TestClient, tmp_path: Path
) -> None:
    """Every domain ships its model as model.pt: the benchmark's header said "model model";
    it is the name the models page offers the file by (a shipped one's: its domain's)."""
    from planner.bench import create_bench

    config = make_config("kitchen-1", ["baseline", "learned"], trials=1, seed_start=0, budget_s=5)
    assert config.model is not None and Path(config.model).name == "model.pt"
    with RunStore(tmp_path / "runs.db") as store:
        bench_id = create_bench(store, config)
    [listed] = [b for b in client.get("/api/benchmarks").json() if b["id"] == bench_id]
    assert listed["model"] == "kitchen"
    assert "kitchen" in {m["name"] for m in client.get("/api/models").json()}

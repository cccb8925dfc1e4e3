"""Training a model from stored runs through the REST API (a real training process, the code of
``tamp train``), its figures and provenance, the refusals, and running the learned planner
with the model it made."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from planner.domains import load_domain
from planner.experiment import Trial, run_trial
from planner.learning.model import CostModel

LOCAL = "http://127.0.0.1:8000"
TABLETOP = Path(__file__).resolve().parents[2] / "examples" / "tabletop2d"


@pytest.fixture(scope="module")
def stored(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, list[str]]]:
    """A store with tabletop-3 baseline runs (about 130 queries each) and line-2 runs (6)."""
    db = tmp_path_factory.mktemp("training") / "runs.db"
    runs: dict[str, list[str]] = {"tabletop": [], "line": []}
    for seed in range(3):
        t = run_trial(Trial("tabletop-3", seed, "baseline", 60.0, domain=str(TABLETOP)), str(db))
        assert t.run_id is not None and t.status == "solved"
        runs["tabletop"].append(t.run_id)
    for seed in range(2):
        line = run_trial(Trial("line-2", seed, "baseline", 60.0), str(db))
        assert line.run_id is not None
        runs["line"].append(line.run_id)
    return db, runs


@pytest.fixture()
def client(stored: tuple[Path, dict[str, list[str]]], tmp_path: Path) -> Iterator[TestClient]:
    settings = Settings(
        database_url=str(stored[0]),
        viewer=False,
        reports_dir=tmp_path / "reports",
        model_dir=tmp_path / "models",
        extra_domains=[TABLETOP],
    )
    with TestClient(create_app(settings), base_url=LOCAL) as c:
        yield c


def _done(client: TestClient, job_id: str, timeout: float = 180) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    seen = []
    while True:
        job: dict[str, Any] = client.get(f"/api/training/{job_id}").json()
        seen.append(job["progress"])
        if job["status"] != "running":
            job["seen"] = seen
            return job
        assert time.monotonic() < deadline, job
        time.sleep(0.2)


@pytest.mark.slow
def test_train_from_stored_runs_then_plan_with_the_model(
    client: TestClient, stored: tuple[Path, dict[str, list[str]]], tmp_path: Path
) -> None:
    runs = stored[1]["tabletop"]
    response = client.post("/api/training", json={"name": "tt3", "runs": runs, "epochs": 60})
    assert response.status_code == 202, response.text
    job = response.json()
    assert job["domain"] == "tabletop2d" and job["queries"] > 300
    again = client.post("/api/training", json={"name": "other", "runs": runs})
    assert again.status_code == 429 and "one model at a time" in again.json()["detail"]

    job = _done(client, job["id"])
    assert job["status"] == "done", job
    assert job["progress"] == 1.0 and job["seen"] == sorted(job["seen"])
    streams = {s["stream"] for s in job["report"]["streams"]}
    assert streams == {"sample-grasp", "sample-pose", "test-cfree", "inverse-kinematics",
                       "plan-motion"}  # fmt: skip

    listed = {m["name"]: m for m in client.get("/api/models").json()}
    assert listed["tt3"]["domain"] == "tabletop2d" and listed["tt3"]["source"] == "dashboard"
    assert listed["tt3"]["validated"] and listed["tt3"]["runs"] == 3
    detail = client.get("/api/models/tt3").json()
    meta = detail["metadata"]
    assert meta["provenance"]["runs"] == runs and meta["provenance"]["trained_by"] == "dashboard"
    assert meta["training_seeds"] == {"tabletop-3": [0, 1, 2]}
    validation = meta["validation"]
    assert validation == job["report"]  # what the job said is what the file holds
    (val_run,) = validation["val_runs"]
    assert val_run in runs
    for s in validation["streams"]:
        bins = s["calibration"]
        assert sum(b["n"] for b in bins) == s["n_val"]
        assert all(b["low"] <= b["predicted"] <= b["high"] for b in bins)
    # The file is a model for its domain, and only for it.
    model = CostModel.load(tmp_path / "models" / "tt3.pt", domain=load_domain(str(TABLETOP)))
    assert model.metadata["provenance"]["job"] == job["id"]

    # A learned run with it plans the tutorial's scenes, and is refused for another domain's.
    run = client.post(
        "/api/runs",
        json={"scene": "tabletop-3", "planner": "learned", "model": "tt3", "seed": 7},
    )
    assert run.status_code == 202, run.text
    assert run.json()["config"]["model_name"] == "tt3"
    wrong = client.post("/api/runs", json={"scene": "line-2", "planner": "learned", "model": "tt3"})
    assert wrong.status_code == 422 and "tabletop2d" in wrong.text
    deadline = time.monotonic() + 120
    while (status := client.get(f"/api/runs/{run.json()['id']}").json()["status"]) in (
        "queued",
        "running",
    ):
        assert time.monotonic() < deadline
        time.sleep(0.3)
    assert status == "solved"
    taken = client.post("/api/training", json={"name": "tt3", "runs": runs})
    assert taken.status_code == 422 and taken.json()["detail"][0]["loc"] == ["body", "name"]


@pytest.mark.parametrize(
    ("make", "loc", "says"),
    [
        (lambda r: {"name": "m", "runs": [*r["tabletop"], "nope"]}, ["body", "runs", 3], "unknown"),
        (
            lambda r: {"name": "m", "runs": [*r["tabletop"], r["line"][0]]},
            ["body", "runs", 3],
            "several domains",
        ),
        (lambda r: {"name": "m", "runs": r["line"]}, ["body", "runs"], "too few stream queries"),
        (lambda r: {"name": "m", "runs": r["tabletop"][:1]}, ["body", "runs"], "at least 2"),
        (
            lambda r: {"name": "m", "runs": [r["tabletop"][0]] * 2},
            ["body", "runs", 1],
            "listed twice",
        ),
        (lambda r: {"name": "kitchen", "runs": r["tabletop"]}, ["body", "name"], "exists"),
        (lambda r: {"name": "../m", "runs": r["tabletop"]}, ["body", "name"], "pattern"),
        (lambda r: {"name": "m", "runs": []}, ["body", "runs"], "at least 1"),
        (
            lambda r: {"name": "m", "runs": r["tabletop"], "epochs": 0},
            ["body", "epochs"],
            "greater than",
        ),
        (
            lambda r: {"name": "m", "runs": r["tabletop"], "benchmark": "nope"},
            ["body", "benchmark"],
            "unknown benchmark",
        ),
    ],
)
def test_training_jobs_that_cannot_work_are_refused_with_the_reason(
    client: TestClient,
    stored: tuple[Path, dict[str, list[str]]],
    make: Any,
    loc: list[Any],
    says: str,
) -> None:
    response = client.post("/api/training", json=make(stored[1]))
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert any(d["loc"] == loc and says in d["msg"] for d in detail), detail
    assert client.get("/api/training").json() == []


def test_unknown_models_and_jobs_are_404(client: TestClient) -> None:
    assert client.get("/api/models/nope").status_code == 404
    assert client.get("/api/training/nope").status_code == 404
    shipped = client.get("/api/models/kitchen").json()
    assert shipped["default"] and shipped["source"] == "shipped"
    assert shipped["metadata"]["training_seeds"]["kitchen-4"][:3] == [0, 1, 2]

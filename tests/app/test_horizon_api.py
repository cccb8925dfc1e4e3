"""The horizon curves through the REST API (``GET /api/benchmarks/horizon``): real benchmarks of
two scenes of the tutorial domain with the same settings make one series, whose points are
``tamp horizon``'s; benchmarks that are alone in their settings, or cancelled, make none; a bad
parameter is a 422 naming it."""

from __future__ import annotations

import statistics
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from planner import horizon
from planner.bench import make_config, run_bench
from planner.report import summarize
from planner.store import RunStore

LOCAL = "http://127.0.0.1:8000"
TABLETOP = Path(__file__).resolve().parents[2] / "examples" / "tabletop2d"
PLANNERS = ["baseline", "sequential"]  # no model to load: the quickest trials
SETTINGS: dict[str, Any] = {"trials": 2, "seed_start": 100, "budget_s": 30.0}


def _settings(db: Path) -> Settings:
    return Settings(
        database_url=str(db),
        viewer=False,
        reports_dir=db.parent / "reports",
        model_dir=db.parent / "models",
        extra_domains=[TABLETOP],
    )


def _config(scene: str, **changes: Any) -> Any:
    return make_config(scene, PLANNERS, **{**SETTINGS, **changes}, domain=str(TABLETOP))


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """tabletop-1 and tabletop-2 with the same settings (a series), run for real; beside them a
    cancelled tabletop-3 of the same settings and a tabletop-1 of another budget (no series)."""
    db = tmp_path_factory.mktemp("horizon") / "runs.db"
    ids = {s: run_bench(db, _config(s), workers=4)[0] for s in ("tabletop-1", "tabletop-2")}
    with RunStore(db) as s:
        cancelled = s.create_bench(_config("tabletop-3").to_dict())
        s.set_bench_status(cancelled, "cancelled")
        other = s.create_bench(_config("tabletop-1", budget_s=20.0).to_dict())
        s.set_bench_status(other, "done")
    return {"db": db, "ids": ids}


@pytest.fixture()
def client(store: dict[str, Any]) -> Iterator[TestClient]:
    with TestClient(create_app(_settings(store["db"])), base_url=LOCAL) as c:
        yield c


@pytest.mark.slow
def test_two_scenes_with_the_same_settings_make_one_series(
    client: TestClient, store: dict[str, Any]
) -> None:
    response = client.get("/api/benchmarks/horizon")
    assert response.status_code == 200, response.text
    [series] = response.json()
    assert series["domain"] == "tabletop2d"
    assert series["planners"] == PLANNERS
    assert (series["trials"], series["seed_start"], series["budget_s"]) == (2, 100, 30.0)
    assert series["label"] == "tabletop2d: baseline, sequential — 2 seeds, 30 s"
    ids = store["ids"]
    assert [(b["scene"], b["objects"], b["id"]) for b in series["benchmarks"]] == [
        ("tabletop-1", 1, ids["tabletop-1"]),
        ("tabletop-2", 2, ids["tabletop-2"]),
    ]
    points = series["points"]
    assert [(p["objects"], p["planner"]) for p in points] == [
        (1, "baseline"),
        (1, "sequential"),
        (2, "baseline"),
        (2, "sequential"),
    ]
    for p in points:  # each point: the planner's mean over the benchmark's seeds
        rows = summarize(store["db"], p["bench_id"])["trials"]
        assert p["seeds"] == 2 and p["solved"] == sum(
            r[p["planner"]]["status"] == "solved" for r in rows
        )
        for measure in ("planning", "total"):
            mean, low, high = p[measure]
            assert mean == pytest.approx(statistics.fmean(r[p["planner"]][measure] for r in rows))
            assert low <= mean <= high
        assert (p["improvement"] is None) == (p["planner"] == "baseline")
    # tamp horizon's points of the same benchmarks, field for field.
    expected = horizon.points(store["db"], [ids["tabletop-1"], ids["tabletop-2"]])
    assert points == [p.to_dict() for p in expected]

    # Picked by its settings; other settings pick nothing.
    query = {"domain": "tabletop2d", "planners": "baseline,sequential", "trials": 2}
    assert client.get("/api/benchmarks/horizon", params=query).json() == [series]
    assert client.get("/api/benchmarks/horizon", params={"budget_s": 20}).json() == []
    assert client.get("/api/benchmarks/horizon", params={"planners": "sequential"}).json() == []


@pytest.mark.slow
def test_unchanged_benchmarks_are_not_summarised_again(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    first = client.get("/api/benchmarks/horizon").json()
    calls: list[str] = []
    monkeypatch.setattr(
        "app.benchmarks.summarize", lambda db, bench_id: calls.append(bench_id) or {}
    )
    assert client.get("/api/benchmarks/horizon").json() == first
    assert calls == []


@pytest.fixture(scope="module")
def empty(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    db = tmp_path_factory.mktemp("empty") / "runs.db"
    with TestClient(create_app(_settings(db)), base_url=LOCAL) as c:
        yield c


def test_an_empty_store_has_no_series(empty: TestClient) -> None:
    response = empty.get("/api/benchmarks/horizon")
    assert response.status_code == 200 and response.json() == []


@pytest.mark.parametrize(
    ("params", "name", "says"),
    [
        ({"planners": "baseline,magic"}, "planners", "unknown planner 'magic'"),
        ({"planners": "baseline,"}, "planners", "should match pattern"),
        ({"domain": "nowhere"}, "domain", "unknown domain 'nowhere'"),
        ({"model": "nothing"}, "model", "unknown model 'nothing'"),
        ({"trials": 0}, "trials", "greater than or equal to 1"),
        ({"budget_s": "soon"}, "budget_s", "valid number"),
    ],
)
def test_a_bad_parameter_is_422_naming_it(
    empty: TestClient, params: dict[str, Any], name: str, says: str
) -> None:
    response = empty.get("/api/benchmarks/horizon", params=params)
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert any(d["loc"] == ["query", name] and says in d["msg"] for d in detail), detail


def test_bounds_on_queries_keep_a_series_apart_and_leave_older_keys_alone() -> None:
    """Benchmarks bounded by queries or iterations are another series; one without bounds keeps
    the key it had before there were any (a page that picked it still finds it)."""
    import hashlib
    from dataclasses import astuple, replace

    from app.horizon import _Settings

    plain = _Settings("tabletop2d", ("baseline", "sequential"), 2, 100, 30.0, None, "auto")
    before = hashlib.sha1(repr(astuple(plain)[:7]).encode()).hexdigest()[:12]
    assert plain.key() == before
    bounded = replace(plain, max_queries=500)
    assert bounded.key() != plain.key() != replace(plain, max_iterations=500).key()
    assert bounded.label() == "tabletop2d: baseline, sequential — 2 seeds, 30 s, 500 queries"

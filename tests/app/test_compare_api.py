"""Two runs compared through the REST API, on runs recorded by the real planner (the line
domain and the tutorial's tabletop): trees, time splits, queries, curves, where the searches
parted."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from planner import figures
from planner.experiment import Trial, run_trial
from planner.report import run_time_split
from planner.store import RunStore

LOCAL = "http://127.0.0.1:8000"
TABLETOP = Path(__file__).resolve().parents[2] / "examples" / "tabletop2d"


@pytest.fixture(scope="module")
def db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("compare") / "runs.db"


@pytest.fixture(scope="module")
def runs(db: Path) -> dict[str, str]:
    """Recorded runs: line-2 baseline twice with one seed, line-2 learned, tabletop-3."""
    out = {}
    for key, scene, planner, seed, domain in (
        ("line", "line-2", "baseline", 0, None),
        ("line_again", "line-2", "baseline", 0, None),
        ("line_learned", "line-2", "learned", 0, None),
        ("line_seed", "line-2", "baseline", 1, None),
        ("tabletop", "tabletop-3", "baseline", 0, str(TABLETOP)),
        ("tabletop_learned", "tabletop-3", "learned", 0, str(TABLETOP)),
    ):
        result = run_trial(Trial(scene, seed, planner, 60.0, domain=domain), str(db))
        assert result.status == "solved" and result.run_id is not None, result
        out[key] = result.run_id
    return out


@pytest.fixture()
def client(db: Path, tmp_path: Path) -> Iterator[TestClient]:
    settings = Settings(
        database_url=str(db),
        viewer=False,
        reports_dir=tmp_path / "reports",
        model_dir=tmp_path / "models",
        extra_domains=[TABLETOP],
    )
    with TestClient(create_app(settings), base_url=LOCAL) as c:
        yield c


def test_the_same_search_twice_made_the_same_nodes(
    client: TestClient, runs: dict[str, str]
) -> None:
    data = client.get("/api/compare", params={"a": runs["line"], "b": runs["line_again"]}).json()
    assert data["same_scene"] and data["notes"] == []
    assert data["divergence"]["kind"] == "identical"
    assert data["divergence"]["same"] == data["a"]["nodes"] - 1 == data["b"]["nodes"] - 1
    assert data["a"]["queries"] == data["b"]["queries"]  # same queries, same outcomes


def test_two_planners_part_at_a_node_both_trees_name(
    client: TestClient, runs: dict[str, str]
) -> None:
    a, b = runs["tabletop"], runs["tabletop_learned"]
    data = client.get("/api/compare", params={"a": a, "b": b}).json()
    div = data["divergence"]
    assert div["kind"] == "choice", div
    trees = {r: client.get(f"/api/runs/{r}/tree").json() for r in (a, b)}
    for side, run_id in (("a", a), ("b", b)):
        tree = trees[run_id]
        node = div[side]
        assert node["node_id"] in tree["ids"]  # the page can ring it in that tree
        i = tree["ids"].index(node["node_id"])
        assert i == div["same"] + 1  # the first node made otherwise, after the same ones
        assert tree["parents"][i] == node["parent_id"]
        assert f"node {node['node_id']}" in div["text"]
        assert len(tree["ids"]) == data[side]["nodes"]
    # The learned planner predicts Q for its nodes: one colour scale spans them.
    q = [v for v in trees[b]["q"] if v is not None]
    assert q and data["q_scale"] is not None
    lo, hi = data["q_scale"]
    assert min(q) <= lo <= hi <= max(q)
    assert (lo, hi) == figures.q_scale(q)  # the page's own scale (planner/figures.py)
    assert all(v is None for v in trees[a]["q"])  # the baseline predicts nothing


def test_time_split_and_queries_are_the_reports(
    client: TestClient, runs: dict[str, str], db: Path
) -> None:
    run_id = runs["tabletop"]
    data = client.get("/api/compare", params={"a": run_id, "b": runs["line"]}).json()
    split = data["a"]["split"]
    with RunStore(db) as store:
        run = store.get_run(run_id)
        outcomes = store.query_outcomes([run_id])
        plans_at = store.event_times([run_id], "abstract_plans_found")[run_id]
        cpu = store.event_numbers([run_id], "run_finished", "search_cpu_s").get(run_id)
    assert run.planning_s is not None
    # The run recorded its search's own CPU: no more than the search's wall seconds.
    assert cpu is not None and 0.0 <= cpu <= run.planning_s - plans_at
    expected = run_time_split(run.planning_s, plans_at, outcomes, cpu)
    by_stream = expected.pop("queries_by_stream_s")
    assert split["queries_by_stream_s"] == pytest.approx(by_stream)
    assert {k: split[k] for k in expected} == pytest.approx(expected)
    assert sum(by_stream.values()) == pytest.approx(split["queries_s"])
    assert split["until_plans_s"] + split["queries_s"] + split["search_s"] == pytest.approx(
        split["planning_s"]
    )
    assert split["execution_s"] == pytest.approx(run.execution_s)
    counts = data["a"]["queries"]
    assert sum(c["queries"] for c in counts.values()) == run.queries == len(outcomes)
    assert sum(c["failed"] for c in counts.values()) == sum(not q.success for q in outcomes)
    curve = data["a"]["curve"]
    assert curve["queries"][-1] == run.queries
    assert curve["t"] == sorted(curve["t"]) and curve["t"][-1] <= run.planning_s


def test_other_scenes_and_seeds_are_compared_and_say_so(
    client: TestClient, runs: dict[str, str]
) -> None:
    scenes = client.get("/api/compare", params={"a": runs["line"], "b": runs["tabletop"]})
    assert scenes.status_code == 200
    assert not scenes.json()["same_scene"]
    assert "different scenes (line-2 and tabletop-3)" in scenes.json()["notes"][0]
    seeds = client.get("/api/compare", params={"a": runs["line"], "b": runs["line_seed"]}).json()
    assert seeds["same_scene"] and "different seeds (0 and 1)" in seeds["notes"][0]


def test_unknown_runs_are_404_naming_them(client: TestClient, runs: dict[str, str]) -> None:
    response = client.get("/api/compare", params={"a": runs["line"], "b": "nope"})
    assert response.status_code == 404 and "'nope'" in response.json()["detail"]
    assert client.get("/api/runs/nope/tree").status_code == 404
    missing = client.get("/api/compare", params={"a": runs["line"]})
    assert missing.status_code == 422
    assert missing.json()["detail"][0]["loc"] == ["query", "b"]


def test_skeletons_added_during_the_search_are_in_the_tree(tmp_path: Path) -> None:
    """Skeletons on demand: a later batch (skeletons_added) adds plan nodes under the root;
    the tree the page and compare draw lists those plans too, and a node of one is keyed by its
    actions as the first batch's are."""
    from app.compare import choice_keys, read_tree
    from planner.events import AbstractPlansFound, NodeAdded, SkeletonProgress, SkeletonsAdded

    def plan(i: int) -> dict[str, Any]:
        return {"index": i, "cost": 1.0, "actions": [f"(a{i})"], "streams": ["s"]}

    with RunStore(tmp_path / "runs.db") as store:
        run_id = store.create_run("line-2", 0, "baseline", {})
        r, t = run_id, 0.0
        store.write_events(
            run_id,
            [
                SkeletonProgress(r, 0, t, phase="search", message="searching", seconds=0.1),
                AbstractPlansFound(r, 1, t, plans=[plan(0), plan(1)], seconds=0.2),
                SkeletonsAdded(r, 2, t, plans=[plan(2)], seconds=0.1, reason="more"),
                NodeAdded(
                    r,
                    3,
                    t,
                    node_id=1,
                    parent_id=0,
                    plan_index=2,
                    depth=0,
                    stream=None,
                    success=True,
                    outputs=[],
                    label="plan 2",
                ),
            ],
        )
        tree = read_tree(store, run_id)
    assert [p["index"] for p in tree.trace.plans] == [0, 1, 2]
    assert tree.trace.order == [0, 1] and tree.trace[1].plan_index == 2
    intern: dict[tuple[object, ...], int] = {}
    (key,) = choice_keys(tree, intern)
    assert any(k[-1] == ("plan", ("(a2)",)) for k in intern if intern[k] == key)

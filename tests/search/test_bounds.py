"""Bounds that do not depend on the machine (planner/search/bounds.py): a run bounded by stream
queries or search iterations stops there whatever its seconds, with the same queries every
time, and says which bound ended it."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

from planner.abstract import AbstractConfig, plan_abstract
from planner.api import RunConfig, plan
from planner.bench import BenchConfig, BenchError, make_config, trial_order
from planner.cli import main
from planner.domains import problem_for_scene
from planner.search.binding import stream_contexts
from planner.search.bounds import SearchBounds
from planner.search.mcts import BaselinePolicy, TreeSearch

ROOT = Path(__file__).resolve().parents[2]
PLANNERS = ("baseline", "paper", "learned", "sequential")
FAR_S = 3600.0  # seconds no bounded run here comes near: the counts end it


@pytest.fixture(scope="module")
def far(tmp_path_factory: pytest.TempPathFactory) -> str:
    """line-2 with its goal out of reach: no planner ends on it by itself."""
    scene = json.loads((ROOT / "scenes" / "line-2.json").read_text())
    scene["name"] = "line-far"
    scene["regions"][1] = {"name": "goal", "lo": 11.0, "hi": 14.0}
    path = tmp_path_factory.mktemp("scenes") / "line-far.json"
    path.write_text(json.dumps(scene))
    return str(path)


def _search(scene: str, seed: int) -> TreeSearch:
    loaded, problem = problem_for_scene(scene, seed=seed)
    plans = plan_abstract(loaded.domain, loaded.streams, problem, AbstractConfig(k=4)).plans
    values = {o.name: o.name for o in problem.objects} | dict(problem.values)
    return TreeSearch(
        plans,
        [stream_contexts(p, loaded.domain, problem) for p in plans],
        values,
        loaded.runtime(problem, seed=seed),
        BaselinePolicy(),
    )


def _queries(out: Any) -> list[tuple[str, bool, Any]]:
    return [(q.stream, q.success, q.outputs) for q in out.result.queries]


@pytest.mark.parametrize("planner", PLANNERS)
def test_a_run_bounded_by_queries_stops_at_that_many_whatever_the_seconds(
    far: str, planner: str
) -> None:
    runs = [plan(far, planner, seed=1, budget_s=s, max_queries=40) for s in (600.0, FAR_S)]
    for out in runs:
        assert out.status == "timeout" and out.valid is None
        assert len(out.result.queries) == 40  # answered by a sampler; reused answers apart
        assert out.result.ended_by == "query budget of 40 reached"
        assert out.message == "no plan (query budget of 40 reached)"
        assert out.planning_s < 600.0
    assert _queries(runs[0]) == _queries(runs[1])  # the same queries: none read the clock


@pytest.mark.parametrize("planner", PLANNERS)
def test_a_run_bounded_by_iterations_stops_there(far: str, planner: str) -> None:
    out = plan(far, planner, seed=1, budget_s=FAR_S, max_iterations=25)
    assert out.status == "timeout"
    assert out.message == "no plan (iteration budget of 25 reached)"
    if planner == "sequential":
        assert out.result.nodes == 25  # its iterations are the skeletons it tried
    again = plan(far, planner, seed=1, budget_s=FAR_S, max_iterations=25)
    assert _queries(again) == _queries(out)


def test_a_run_that_solves_within_its_bounds_is_solved(far: str) -> None:
    out = plan("line-2", "baseline", seed=3, budget_s=FAR_S, max_queries=500, max_iterations=500)
    assert out.status == "solved" and out.valid is True
    assert out.result.ended_by is None


def test_the_seconds_still_bound_a_run_bounded_by_counts(far: str) -> None:
    out = plan(far, "baseline", seed=1, budget_s=0.5, max_queries=10**9)
    assert out.status == "timeout"
    assert out.message == "no plan (time budget of 0.5 s reached)"


def test_a_search_counts_its_bounds_over_every_call(far: str) -> None:
    """TreeSearch.run: iterations and queries answered count over the search's life, as its
    tree does, so a search run in slices stops at the same point as one run whole."""
    ts = _search(far, 3)
    first = ts.run(deadline=time.perf_counter() + FAR_S, bounds=SearchBounds(max_iterations=4))
    assert first.status == "timeout" and first.iterations == 4 == ts.iterations
    assert first.ended_by == "iteration budget of 4 reached"
    second = ts.run(deadline=time.perf_counter() + FAR_S, bounds=SearchBounds(max_iterations=6))
    assert second.iterations == 2 and ts.iterations == 6
    answered = sum(1 for _, r in ts.queries if not r.reused)
    assert answered == ts.answered
    bounded = ts.run(
        deadline=time.perf_counter() + FAR_S, bounds=SearchBounds(max_queries=answered + 3)
    )
    assert bounded.status == "timeout" and ts.answered == answered + 3
    assert bounded.ended_by == f"query budget of {answered + 3} reached"
    assert not ts.run(deadline=time.perf_counter() + FAR_S, bounds=SearchBounds(1, 1)).iterations


@pytest.mark.parametrize("field", ["max_queries", "max_iterations"])
@pytest.mark.parametrize("value", [0, -3, 2.5, True, "10"])
def test_a_bound_is_a_positive_integer_and_a_bad_one_is_named(field: str, value: Any) -> None:
    with pytest.raises(ValueError, match=f"{field} must be a positive integer"):
        RunConfig(scene="line-2", **{field: value})
    with pytest.raises(ValueError, match=f"{field} must be a positive integer"):
        SearchBounds(**{field: value})
    flag = "--" + field.replace("_", "-")
    with pytest.raises(BenchError, match=f"{flag} must be a positive integer"):
        make_config("line-2", ["baseline"], trials=1, seed_start=0, budget_s=10, **{field: value})


def test_tamp_plan_takes_the_bounds_and_says_which_ended_the_run(
    capsys: pytest.CaptureFixture[str], far: str
) -> None:
    argv = ["plan", "--scene", far, "--seed", "1", "--budget", "3600", "--no-record", "--json"]
    assert main([*argv, "--max-queries", "30"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "timeout"
    assert out["message"] == "no plan (query budget of 30 reached)"
    assert sum(c["ok"] + c["failed"] for c in out["queries"].values()) == 30
    assert main([*argv, "--max-iterations", "5"]) == 1
    assert (
        json.loads(capsys.readouterr().out)["message"] == "no plan (iteration budget of 5 reached)"
    )
    with pytest.raises(SystemExit) as refused:
        main([*argv, "--max-queries", "0"])
    assert refused.value.code == 2
    assert "--max-queries: expected a positive whole number, got 0" in capsys.readouterr().err


def test_benchmarks_keep_their_bounds_and_older_ones_load_without() -> None:
    config = make_config(
        "line-2", ["baseline"], trials=2, seed_start=0, budget_s=60, max_queries=300
    )
    stored = config.to_dict()
    assert stored["max_queries"] == 300 and stored["max_iterations"] is None
    assert BenchConfig.from_dict(stored) == config
    older = {k: v for k, v in stored.items() if not k.startswith("max_")}  # before the bounds
    loaded = BenchConfig.from_dict(older)
    assert (loaded.max_queries, loaded.max_iterations) == (None, None)
    assert {(t.max_queries, t.max_iterations) for t in trial_order(config)} == {(300, None)}

"""Planning runs end to end: the baseline solves, every event and query is recorded, the plan
file validates, and a budget that runs out is a recorded timeout."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from planner.domains.kitchen.features import room_left
from planner.events import NodeAdded, RunFinished, RunStarted, SolutionFound, StreamQueried
from planner.runs import RunConfig, run
from planner.store import RunStore, StoreSink

pytestmark = pytest.mark.slow

LINE = str(Path(__file__).parent / "search" / "line-reach.json")


def tamp(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "planner.cli", *args], capture_output=True, text=True, check=False
    )


def test_recorded_run_keeps_every_event_and_query(tmp_path: Path) -> None:
    store = RunStore(tmp_path / "runs.db")
    config = RunConfig(scene=LINE, seed=3, k=4, budget_s=30)
    run_id = store.create_run(LINE, 3, "baseline", {"k": 4})
    sink = StoreSink(store, run_id)
    result, _, _ = run(config, sink=sink, run_id=run_id)
    sink.close()
    assert result.solved and result.status == "solved"
    assert result.oracle_s is not None and result.topk_s <= result.oracle_s <= result.planning_s
    events = store.events(run_id)
    assert [e.seq for e in events] == list(range(len(events)))
    assert isinstance(events[0], RunStarted) and isinstance(events[-1], RunFinished)
    assert sum(isinstance(e, SolutionFound) for e in events) == 1
    queried = [e for e in events if isinstance(e, StreamQueried) and e.reused_from is None]
    assert len(queried) == len(result.queries)
    rows = store.stream_queries(run_ids=[run_id])
    assert len(rows) == len(queried)  # answers taken from an identical query are no rows
    assert {r.stream for r in rows} == {"sample-pose", "test-reachable"}
    assert any(not r.success for r in rows)  # the short reach makes tests fail
    store.close()


def test_sequential_run_is_recorded_as_a_tree(tmp_path: Path) -> None:
    """The sequential planner reports its queries as the tree searches do: the store keeps
    every one as a training row, and the events form a tree the dashboard can show, each query
    under the last success of its restart, ending in the solution."""
    store = RunStore(tmp_path / "runs.db")
    config = RunConfig(scene=LINE, seed=3, k=4, budget_s=30, planner="sequential")
    run_id = store.create_run(LINE, 3, "sequential", {"k": 4})
    sink = StoreSink(store, run_id)
    result, _, _ = run(config, sink=sink, run_id=run_id)
    sink.close()
    assert result.solved
    assert result.oracle_s is not None and result.topk_s <= result.oracle_s <= result.planning_s
    events = store.events(run_id)
    queried = [e for e in events if isinstance(e, StreamQueried)]
    assert len(queried) == len(result.queries) > 0
    rows = store.stream_queries(run_ids=[run_id])
    assert len(rows) == len(queried)
    assert any(not r.success for r in rows)  # the short reach makes tests fail
    assert all(r.context.get("facts") is not None for r in rows)
    added = {e.node_id: e for e in events if isinstance(e, NodeAdded)}
    assert {q.node_id for q in queried} <= set(added)
    for node in added.values():  # every parent is the root or an earlier successful node
        assert node.parent_id == 0 or (node.parent_id in added and added[node.parent_id].success)
        if node.stream is not None:
            assert node.depth == added[node.parent_id].depth + 1  # type: ignore[index]
    (solution,) = [e for e in events if isinstance(e, SolutionFound)]
    leaf = added[solution.node_id]
    assert leaf.success and leaf.plan_index == solution.plan_index
    depth, node = 0, leaf
    while node.parent_id:  # the solution's branch binds a whole plan
        depth, node = depth + 1, added[node.parent_id]
    assert depth == leaf.depth
    store.close()


def test_plan_kitchen_1_writes_a_plan_that_validates(tmp_path: Path) -> None:
    db, plan = tmp_path / "runs.db", tmp_path / "plan.json"
    proc = tamp(
        "plan",
        "--scene",
        "kitchen-1",
        "--seed",
        "1",
        "--db",
        str(db),
        "--out",
        str(plan),
        "--json",
        "--budget",
        "120",
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = json.loads(proc.stdout)
    assert out["status"] == "solved" and out["valid"] is True
    assert out["execution_s"] > 0 and out["oracle_s"] <= out["planning_s"]
    assert set(out["queries"]) == {
        "sample-grasp",
        "sample-placement",
        "inverse-kinematics",
        "plan-motion",
    }
    check = tamp("validate", str(plan))
    assert check.returncode == 0 and "valid" in check.stdout
    record = RunStore(db).get_run(out["run_id"])
    assert record.status == "solved" and record.plan is not None
    # Each query carries the scene's geometry, so a model can tell how much room a platform
    # has left (the stove is 22 cm square in kitchen-1).
    placements = [
        q
        for q in RunStore(db).stream_queries(run_ids=[out["run_id"]])
        if q.stream == "sample-placement"
    ]
    assert placements
    geometry = placements[0].context["geometry"]
    xmin, xmax, ymin, ymax = geometry["platforms"]["stove"]
    assert (xmax - xmin, ymax - ymin) == pytest.approx((0.22, 0.22))
    assert geometry["blocks"] == {"b1": 0.07}
    assert all(room_left(*q.inputs, q.context)[0] == 0.0 for q in placements)  # room known


def test_budget_running_out_is_a_recorded_timeout(tmp_path: Path) -> None:
    db = tmp_path / "runs.db"
    proc = tamp("plan", "--scene", "kitchen-2", "--budget", "0.01", "--db", str(db), "--json")
    assert proc.returncode == 1
    out = json.loads(proc.stdout)
    assert out["status"] == "timeout"
    assert out["message"].startswith("no plan (time budget of 0.01 s reached")
    assert RunStore(db).get_run(out["run_id"]).status == "timeout"


def test_unknown_planner_lists_the_known() -> None:
    proc = tamp("plan", "--scene", "kitchen-1", "--planner", "magic")
    assert proc.returncode == 2 and "baseline" in proc.stderr and "Traceback" not in proc.stderr


def test_a_plan_that_does_not_validate_ends_the_run_as_failed_in_its_events_too(
    tmp_path: Path,
) -> None:
    """The closing event says what the store says: a solved search whose plan the domain's
    validator refuses is a failed run, with the validator's message and the plan file."""
    from dataclasses import replace

    from planner.api import solve
    from planner.domains import PlanCheck, load_domain
    from planner.events import ListSink, RunFinished

    line = load_domain("line")
    strict = replace(
        line,
        spec=replace(line.spec, validate=lambda actions, values, problem: PlanCheck(False, "no")),
    )
    sink = ListSink()
    out = solve(RunConfig(scene="line-2", budget_s=30), loaded=strict, sink=sink)
    assert out.result.solved and out.status == "failed" and out.check() == (False, "no")
    (finished,) = [e for e in sink.events if isinstance(e, RunFinished)]
    assert (finished.status, finished.valid, finished.message) == ("failed", False, "no")
    assert finished.plan is not None and finished.plan["domain"] == "line"


def test_a_stopped_run_says_who_stopped_it(tmp_path: Path) -> None:
    """A run its caller stopped is cancelled for the reason the caller gives (a server that
    shuts down is not a user), in the result, the closing event and the stored run."""
    from collections.abc import Callable

    from planner.events import RunCancelled
    from planner.runs import record_run

    config = RunConfig(scene=LINE, seed=3, k=4, budget_s=30)
    given: tuple[tuple[Callable[[], str] | None, str], ...] = (
        (None, "cancelled by the user"),
        (lambda: "stopped: the server shut down while it ran", "stopped: the server shut down"),
    )
    with RunStore(tmp_path / "runs.db") as store:
        for reason, says in given:
            run_id = store.create_run(LINE, 3, "baseline", {})
            recorded = record_run(
                config, store, run_id, should_stop=lambda: True, stop_reason=reason
            )
            assert recorded.status == "cancelled" and recorded.message.startswith(says)
            assert store.get_run(run_id).message == recorded.message
            closing = store.events(run_id)[-1]
            assert isinstance(closing, RunCancelled) and closing.reason == recorded.message

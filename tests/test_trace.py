"""planner/trace.py: every planner's node events fold into the tree the views show (real runs of
the pure-Python line domain, bounded by queries, and hand-made events for the edge cases)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from planner.api import RunConfig, solve
from planner.events import (
    AbstractPlansFound,
    Event,
    ListSink,
    ModelPrediction,
    NodeAdded,
    RunFinished,
    SkeletonsAdded,
    SolutionFound,
    StreamQueried,
    event_from_dict,
    event_to_dict,
)
from planner.trace import NODE_KINDS, ROOT_ID, Trace, TraceError, fold

RUN = "r"
LINE = str(Path(__file__).parent / "search" / "line-reach.json")  # a short reach: tests fail


def line_run(planner: str) -> list[Event]:
    """The events of one run on the line with a short reach (seed 3), bounded by its queries,
    not by seconds."""
    sink = ListSink()
    config = RunConfig(scene=LINE, seed=3, k=4, planner=planner, budget_s=600, max_queries=400)
    out = solve(config, sink=sink)
    assert out.status == "solved", out.message
    return sink.events


@pytest.fixture(scope="module", params=["baseline", "learned", "sequential"])
def run_events(request: pytest.FixtureRequest) -> tuple[str, list[Event]]:
    return request.param, line_run(request.param)


def strict(events: list[Event]) -> Trace:
    trace = Trace()
    for e in events:
        trace.apply(e)  # every event of a real run fits: nothing raises
    return trace


def test_every_planners_run_folds_into_one_tree(run_events: tuple[str, list[Event]]) -> None:
    _, events = run_events
    trace = strict(events)
    added = [e for e in events if isinstance(e, NodeAdded)]
    assert trace.order == [ROOT_ID] + [e.node_id for e in added]
    assert trace.events == len(events)
    assert trace.failed == sum(not e.success for e in added) > 0  # the line's tests fail
    for node in trace.ordered()[1:]:
        assert node.parent is not None
        parent = trace[node.parent]
        assert node.id in parent.children
        assert node.level == parent.level + 1 == node.depth + 1
        assert node.kind in NODE_KINDS
        if node.kind == "plan":
            assert node.parent == ROOT_ID and node.query is None and node.label.startswith("plan")
        else:  # the query that made it comes with it, whichever planner reported it
            assert node.query is not None and node.query.stream == node.stream
            assert node.query.success == node.success
            assert node.label.startswith(node.stream or "?")
            if node.success:
                assert len(node.output_names) == len(node.outputs)
    assert trace.plans == next(e for e in events if isinstance(e, AbstractPlansFound)).plans
    assert isinstance(trace.end, RunFinished) and trace.end.status == "solved"


def test_the_solution_branch_binds_a_whole_plan(run_events: tuple[str, list[Event]]) -> None:
    _, events = run_events
    trace = fold(events)
    assert trace.solution is not None
    path = trace.solution_path()
    assert path[0] == ROOT_ID and path[-1] == trace.solution.node_id
    leaf = trace[path[-1]]
    streams = trace.plans[leaf.plan_index]["streams"]
    assert leaf.depth == len(streams) == len(path) - 2  # root, plan node, one node a stream
    assert all(trace[n].success for n in path)
    assert [trace[n].stream for n in path[2:]] == [s.split("(")[0] for s in streams]


def test_predictions_are_the_learned_planners_only(run_events: tuple[str, list[Event]]) -> None:
    planner, events = run_events
    trace = fold(events)
    predicted = [e for e in events if isinstance(e, ModelPrediction)]
    if planner != "learned":
        assert trace.predictions() == {} and not predicted
        return
    last = {e.node_id: e.q for e in predicted}
    assert trace.predictions() == last and last
    assert all(trace[n].q == q for n, q in last.items())


def test_stored_dicts_fold_as_the_events_do(run_events: tuple[str, list[Event]]) -> None:
    """What the store and the websocket carry (event_to_dict) folds to the same tree."""
    _, events = run_events
    a, b = fold(events), fold(event_from_dict(event_to_dict(e)) for e in events)
    assert a.order == b.order
    assert [(n.parent, n.label, n.success, n.q) for n in a.ordered()] == [
        (n.parent, n.label, n.success, n.q) for n in b.ordered()
    ]


# --- the rules, on events made by hand ----------------------------------------------------------


def node(seq: int, node_id: int, parent: int | None, **kw: Any) -> NodeAdded:
    fields: dict[str, Any] = {
        "plan_index": -1 if parent is None else 0,
        "depth": 0,
        "stream": None,
        "success": True,
        "outputs": [],
        "label": f"n{node_id}",
    }
    return NodeAdded(RUN, seq, 0.0, node_id=node_id, parent_id=parent, **(fields | kw))


def query(seq: int, node_id: int, success: bool) -> StreamQueried:
    return StreamQueried(
        RUN, seq, 0.0, node_id=node_id, stream="s", input_names=[], inputs=[], success=success,
        wall_s=0.1, cpu_s=0.1, execution_s=0.0, error=None,
    )  # fmt: skip


def test_a_query_belongs_to_the_node_it_made() -> None:
    trace = fold(
        [node(0, 1, 0), query(1, 2, False), node(2, 2, 1, depth=1, stream="s", success=False)]
    )
    assert trace[2].query is not None and trace[2].query.seq == 1
    assert trace[2].kind == "failed" and trace.failed == 1
    assert [trace[n].kind for n in trace.order] == ["root", "plan", "failed"]


def test_a_root_the_events_name_takes_the_implicit_ones_place() -> None:
    trace = fold([node(0, 7, None, label="the root"), node(1, 8, 7)])
    assert trace.order == [7, 8] and trace.root == 7 and ROOT_ID not in trace
    assert trace[7].label == "the root" and trace[7].children == [8]
    with pytest.raises(TraceError, match="second root"):
        trace.apply(node(2, 9, None))


def test_an_event_that_does_not_fit_leaves_the_trace_as_it_was() -> None:
    trace = fold([node(0, 1, 0)])
    for bad in (
        node(1, 1, 0),  # added twice
        node(1, 5, 4),  # a parent never seen
        node(1, 6, 6),  # its own parent
        ModelPrediction(RUN, 1, 0.0, node_id=9, p_s=0.5, r_s=1.0, r_f=1.0, r_m=0.0, q=3.0),
        SolutionFound(
            RUN, 1, 0.0, node_id=9, plan_index=0, planning_s=1, execution_s=1, oracle_s=1
        ),
    ):
        with pytest.raises(TraceError):
            trace.apply(bad)
    assert trace.order == [0, 1] and trace.events == 1 and trace[0].children == [1]
    assert trace.solution is None and trace.predictions() == {}
    assert fold([node(0, 1, 0), node(1, 5, 4), node(2, 2, 1, depth=1, stream="s")]).order == [
        0,
        1,
        2,
    ]  # fold leaves it out and goes on


def test_later_skeletons_extend_the_plans() -> None:
    def plan(i: int) -> dict[str, Any]:
        return {"index": i, "cost": 1.0, "actions": [f"(a{i})"], "streams": []}

    trace = fold(
        [
            AbstractPlansFound(RUN, 0, 0.5, plans=[plan(0)], seconds=0.5),
            SkeletonsAdded(RUN, 1, 2.0, plans=[plan(1), plan(2)], seconds=0.25, reason="more"),
            SkeletonsAdded(RUN, 2, 3.0, plans=[plan(3)], seconds=0.5, reason="all dead"),
            node(3, 1, 0, plan_index=3),
        ]
    )
    assert [p["index"] for p in trace.plans] == [0, 1, 2, 3]
    assert trace.plans_t == 0.5 and trace.later_skeletons_s == 0.75
    assert trace[1].plan_index == 3

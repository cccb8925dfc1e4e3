"""Every event class round-trips through JSON; bad JSON is refused by name; emitters and sinks."""

from __future__ import annotations

import dataclasses
import json
import logging
from typing import Any, get_args

import pytest

from planner import events
from planner.events import (
    EVENT_TYPES,
    AbstractPlansFound,
    Emitter,
    Event,
    FanOutSink,
    ListSink,
    ModelPrediction,
    NodeAdded,
    NodeVisited,
    RunCancelled,
    RunFailed,
    RunFinished,
    RunStarted,
    SkeletonProgress,
    SkeletonsAdded,
    SolutionFound,
    StreamQueried,
    event_from_dict,
    event_from_json,
    event_to_dict,
    event_to_json,
)

RUN = "0f3c9a2b5d6e4f718293a4b5c6d7e8f9"

# One realistic example per event class, keyed by type name; a new class needs one here.
EXAMPLES: dict[str, Event] = {
    "run_started": RunStarted(
        RUN,
        0,
        0.0,
        scene="kitchen-2",
        seed=7,
        planner="learned",
        config={"k": 10, "budget_s": 300.0, "model": None, "nested": {"c": [0.5, True]}},
    ),
    "abstract_plans_found": AbstractPlansFound(
        RUN,
        1,
        1.25,
        plans=[
            {"index": 0, "cost": 12.0, "actions": ["move q0 q1", "pick b1"], "streams": ["ik"]},
            {"index": 1, "cost": 14.5, "actions": [], "streams": []},
        ],
        seconds=1.2,
    ),
    "skeleton_progress": SkeletonProgress(
        RUN, 1, 0.4, phase="translate", message="translating 1,153 stream instances", seconds=0.4
    ),
    "skeletons_added": SkeletonsAdded(
        RUN,
        9,
        7.5,
        plans=[{"index": 2, "cost": 13.0, "actions": ["pick b2"], "streams": ["grasp(b2)"]}],
        seconds=0.08,
        reason="all dead",
        learned=["(cfree a p3 b p0) false"],
    ),
    "node_added": NodeAdded(
        RUN,
        2,
        1.3,
        node_id=3,
        parent_id=1,
        plan_index=0,
        depth=1,
        stream="sample-grasp",
        success=True,
        outputs=["#g0"],
        label="sample-grasp #g0",
    ),
    "node_visited": NodeVisited(RUN, 3, 1.31, node_id=3, visits=2, value=-4.75),
    "stream_queried": StreamQueried(
        RUN,
        4,
        1.5,
        node_id=3,
        stream="plan-motion",
        input_names=["?q1", "?q2"],
        inputs=[[0.1, -0.2, 3.0], {"frame": "world", "xyz": [1, 2, 3]}],
        success=False,
        wall_s=0.125,
        cpu_s=0.1,
        execution_s=0.0,
        error="RuntimeError: no path",
    ),
    "model_prediction": ModelPrediction(
        RUN, 5, 1.6, node_id=3, p_s=0.85, r_s=0.02, r_f=0.3, r_m=4.0, q=17.123456789
    ),
    "solution_found": SolutionFound(
        RUN, 6, 9.5, node_id=12, plan_index=1, planning_s=9.5, execution_s=31.0, oracle_s=0.4
    ),
    "run_finished": RunFinished(
        RUN,
        7,
        9.6,
        status="solved",
        planning_s=9.5,
        execution_s=31.0,
        oracle_s=None,
        queries=42,
        message="solved with plan 1",
    ),
    "run_failed": RunFailed(RUN, 8, 9.7, error="ValueError: scene 'x' names no domain"),
    "run_cancelled": RunCancelled(RUN, 9, 9.8, reason="cancelled from the dashboard"),
}


def _event_classes_in_module() -> set[type[Any]]:
    """Every concrete event class defined in planner.events, found without the registry."""
    return {
        obj
        for obj in vars(events).values()
        if isinstance(obj, type)
        and dataclasses.is_dataclass(obj)
        and isinstance(getattr(obj, "type", None), str)
        and obj.__module__ == events.__name__
    }


def test_registry_lists_every_event_class_once() -> None:
    classes = _event_classes_in_module()
    assert set(EVENT_TYPES.values()) == classes
    assert set(get_args(Event)) == classes
    assert all(EVENT_TYPES[cls.type] is cls for cls in classes)


def test_every_event_class_has_an_example() -> None:
    assert set(EXAMPLES) == set(EVENT_TYPES)
    for name, example in EXAMPLES.items():
        assert type(example) is EVENT_TYPES[name]


@pytest.mark.parametrize("name", sorted(EVENT_TYPES))
def test_event_round_trips_through_json_exactly(name: str) -> None:
    event = EXAMPLES[name]
    text = event_to_json(event)
    back = event_from_json(text)
    assert back == event
    for field in dataclasses.fields(event):  # same values and same types (1.0 stays a float)
        assert type(getattr(back, field.name)) is type(getattr(event, field.name)), field.name
    assert event_to_json(back) == text
    data = json.loads(text)
    assert data["type"] == name
    assert set(data) == {"type"} | {f.name for f in dataclasses.fields(event)}
    assert event_from_dict(event_to_dict(event)) == event


def test_int_for_a_float_field_becomes_a_float() -> None:
    event = NodeVisited(RUN, 0, 0, node_id=1, visits=1, value=3)
    assert isinstance(event.t, float) and isinstance(event.value, float)
    assert event_from_json(event_to_json(event)) == event


def test_event_to_dict_is_a_copy() -> None:
    event = EXAMPLES["abstract_plans_found"]
    assert isinstance(event, AbstractPlansFound)
    data = event_to_dict(event)
    data["plans"][0]["actions"].append("cook b1")
    assert event.plans[0]["actions"] == ["move q0 q1", "pick b1"]


def test_unknown_type_is_named() -> None:
    with pytest.raises(ValueError, match=r"unknown event type 'node_deleted'.*node_added"):
        event_from_json(json.dumps({"type": "node_deleted", "run_id": RUN, "seq": 0, "t": 0}))
    with pytest.raises(ValueError, match="unknown event type None"):
        event_from_dict({"run_id": RUN, "seq": 0, "t": 0.0})


def test_missing_and_extra_fields_are_named() -> None:
    data = event_to_dict(EXAMPLES["node_visited"])
    del data["visits"]
    with pytest.raises(ValueError, match=r"'node_visited' is missing field\(s\): visits"):
        event_from_dict(data)
    data = event_to_dict(EXAMPLES["run_cancelled"]) | {"by": "alice"}
    with pytest.raises(ValueError, match=r"'run_cancelled' has unknown field\(s\): by"):
        event_from_dict(data)


def test_events_stored_before_a_field_with_a_default_was_added_still_load() -> None:
    data = event_to_dict(EXAMPLES["stream_queried"])
    del data["reused_from"], data["context"], data["reason"]
    event = event_from_dict(data)
    assert isinstance(event, StreamQueried)
    assert event.reused_from is None and event.context == {} and event.reason is None


@pytest.mark.parametrize("name", sorted(EVENT_TYPES))
def test_a_stored_event_is_read_back_without_checking_it_again(name: str) -> None:
    """What the store reads for a whole tree (event_from_stored) equals the checked read."""
    event = EXAMPLES[name]
    data = json.loads(event_to_json(event))
    assert events.event_from_stored(data) == event_from_dict(data) == event


def test_a_stored_event_missing_a_newer_field_takes_its_default() -> None:
    data = json.loads(event_to_json(EXAMPLES["stream_queried"]))
    del data["reused_from"], data["context"], data["input_labels"]
    a, b = events.event_from_stored(data), events.event_from_stored(dict(data))
    assert isinstance(a, StreamQueried) and isinstance(b, StreamQueried)
    assert a.reused_from is None and a.context == {} and a.input_labels == []
    assert a.context is not b.context  # a fresh default each
    del data["stream"]
    with pytest.raises(ValueError, match="missing field 'stream'"):
        events.event_from_stored(data)
    with pytest.raises(ValueError, match="unknown event type 'node_deleted'"):
        events.event_from_stored({"type": "node_deleted"})


def test_only_a_failure_has_a_reason() -> None:
    data = event_to_dict(EXAMPLES["stream_queried"]) | {"success": True, "error": None}
    with pytest.raises(ValueError, match="reason: a successful query has no failure reason"):
        event_from_dict(data | {"reason": "no path"})
    assert event_from_dict(data | {"reason": None}).reason is None  # type: ignore[attr-defined]


def test_an_error_is_never_reused_but_a_tests_failure_is() -> None:
    data = event_to_dict(EXAMPLES["stream_queried"]) | {"success": False, "reused_from": 3}
    with pytest.raises(ValueError, match="reused_from: an error is never reused"):
        event_from_dict(data | {"error": "ValueError: boom"})
    answer = event_from_dict(data | {"error": None, "reason": "failed on these inputs before"})
    assert answer.reused_from == 3  # type: ignore[attr-defined]


def test_malformed_json_and_wrong_field_types_are_value_errors() -> None:
    with pytest.raises(ValueError, match="not valid JSON"):
        event_from_json("{'type': ")
    with pytest.raises(ValueError, match="an event is a JSON object"):
        event_from_json("[1, 2]")
    data = event_to_dict(EXAMPLES["node_added"]) | {"depth": "2"}
    with pytest.raises(ValueError, match=r"node_added\.depth: expected int, got str"):
        event_from_dict(data)
    data = event_to_dict(EXAMPLES["model_prediction"]) | {"q": float("inf")}
    with pytest.raises(ValueError, match=r"model_prediction\.q: must be finite"):
        event_from_dict(data)
    with pytest.raises(ValueError, match="must be finite"):
        event_from_json(event_to_json(EXAMPLES["node_visited"]).replace("-4.75", "NaN"))


def test_a_long_context_is_checked_deep_down_every_time_it_is_bad() -> None:
    """A search's events share long lists (a state's facts): one found good is not walked
    again, but one with a bad leaf deep inside is refused each time, naming where."""
    facts = [["on", f"b{i}", "table"] for i in range(20)]
    example = EXAMPLES["stream_queried"]
    for _ in range(2):
        dataclasses.replace(example, context={"facts": facts})
    bad = [*facts, ["at", float("nan")]]
    for _ in range(2):
        with pytest.raises(ValueError, match=r"context\['facts'\]\[20\]\[1\]: must be finite"):
            dataclasses.replace(example, context={"facts": bad})


@pytest.mark.parametrize(
    ("cls", "fields", "message"),
    [
        (NodeVisited, {"seq": -1}, r"node_visited\.seq: must be >= 0"),
        (NodeVisited, {"t": -0.5}, r"node_visited\.t: must be >= 0"),
        (NodeVisited, {"run_id": ""}, r"node_visited\.run_id"),
        (NodeVisited, {"visits": True}, r"node_visited\.visits: expected int, got bool"),
        (RunFinished, {"status": "done"}, r"run_finished\.status: unknown status 'done'"),
        (ModelPrediction, {"p_s": 1.5}, r"model_prediction\.p_s: must be a probability"),
        (StreamQueried, {"inputs": [1]}, r"stream_queried\.inputs: 1 values for 2"),
        (StreamQueried, {"inputs": [(1, 2), 3]}, r"stream_queried\.inputs\[0\]: tuple"),
        (StreamQueried, {"success": True}, r"stream_queried\.error: a successful query"),
        (NodeAdded, {"stream": None}, r"node_added\.stream: a node at depth 1 must name"),
        (NodeAdded, {"depth": 0}, r"node_added\.stream: a node at depth 0 has no stream"),
        (NodeAdded, {"depth": -1}, r"node_added\.depth: must be >= 0"),
        (RunStarted, {"config": {1: "a"}}, r"run_started\.config: keys must be str"),
        (AbstractPlansFound, {"plans": [{"index": 0}]}, r"plans\[0\]: missing key 'cost'"),
    ],
)
def test_invariants_name_the_event_and_field(
    cls: type[Event], fields: dict[str, Any], message: str
) -> None:
    example = EXAMPLES[cls.type]
    with pytest.raises(ValueError, match=message):
        dataclasses.replace(example, **fields)


def test_root_and_plan_nodes() -> None:
    root = NodeAdded(RUN, 0, 0.0, 0, None, -1, 0, None, True, [], "root")
    plan = NodeAdded(RUN, 1, 0.0, 1, 0, 0, 0, None, True, [], "plan 0")
    assert event_from_json(event_to_json(root)) == root
    assert event_from_json(event_to_json(plan)) == plan


class _Clock:
    def __init__(self, *times: float) -> None:
        self.times = list(times)

    def __call__(self) -> float:
        return self.times.pop(0)


def test_emitter_numbers_and_times_events() -> None:
    sink = ListSink()
    emitter = Emitter(RUN, sink, clock=_Clock(100.0, 100.5, 100.25, 102.0))
    first = emitter.emit(NodeVisited, node_id=1, visits=1, value=0.0)
    emitter.emit(RunCancelled, reason="a")
    emitter.emit(RunCancelled, reason="b")
    assert isinstance(first, NodeVisited)  # the emitted event is returned, typed
    assert [e.seq for e in sink.events] == [0, 1, 2]
    assert [e.t for e in sink.events] == [0.5, 0.5, 2.0]  # a clock step back does not show
    assert all(e.run_id == RUN for e in sink.events)
    assert emitter.next_seq == 3


def test_emitter_with_real_clock_is_non_decreasing() -> None:
    sink = ListSink()
    emitter = Emitter(RUN, sink)
    for i in range(200):
        emitter.emit(NodeVisited, node_id=i, visits=1, value=0.0)
    times = [e.t for e in sink.events]
    assert times == sorted(times) and times[0] >= 0.0
    assert [e.seq for e in sink.events] == list(range(200))


class _Broken:
    def __init__(self) -> None:
        self.closed = False

    def emit(self, event: Event) -> None:
        raise OSError("disk full")

    def close(self) -> None:
        self.closed = True


def test_fan_out_survives_a_raising_sink(caplog: pytest.LogCaptureFixture) -> None:
    good, broken, other = ListSink(), _Broken(), ListSink()
    fan = FanOutSink(good, broken, other)
    emitter = Emitter(RUN, fan)
    with caplog.at_level(logging.ERROR, logger="planner.events"):
        for _ in range(3):
            emitter.emit(RunCancelled, reason="x")
    assert len(good.events) == len(other.events) == 3
    assert fan.sinks == (good, other)
    assert broken.closed
    assert "disk full" in caplog.text and "dropping it" in caplog.text
    fan.close()
    assert good.closed and other.closed


def test_numpy_floats_become_plain_floats_and_numpy_ints_are_refused() -> None:
    np = pytest.importorskip("numpy")
    event = NodeVisited(RUN, 0, np.float64(0.5), node_id=1, visits=1, value=np.float32(2.0))
    assert type(event.t) is float and type(event.value) is float
    assert event_from_json(event_to_json(event)) == event
    with pytest.raises(ValueError, match=r"node_visited\.node_id: expected int, got int64"):
        NodeVisited(RUN, 0, 0.0, node_id=np.int64(1), visits=1, value=0.0)


def test_a_batching_sinks_writer_thread_counts_the_cpu_it_spends() -> None:
    """What recording costs a run beside the planner's thread (benchmarks/store_backends.py):
    full batches are written by the writer thread, and the CPU seconds it spends are counted;
    the planner's thread writes none of them."""
    import threading
    import time

    writers: list[str] = []
    written: list[events.Event] = []

    def write(batch: list[events.Event]) -> None:
        writers.append(threading.current_thread().name)
        written.extend(batch)
        end = time.thread_time() + 0.02  # a commit that costs 20 ms of CPU
        while time.thread_time() < end:
            pass

    sink = events.BatchingSink(write, name="writer", batch_size=5, flush_interval_s=0.2)
    emitter = events.Emitter("r", sink)
    for i in range(10):
        emitter.emit(events.NodeVisited, node_id=i, visits=1, value=0.0)
    deadline = time.monotonic() + 5
    while len(written) < 10 and time.monotonic() < deadline:
        time.sleep(0.01)
    sink.close()
    assert len(written) == 10 and writers and set(writers) == {"writer"}
    assert sink.writer_cpu_s >= 0.018 * len(writers)

"""What the 3D view is told: the page's run and step, then live events once, then the plan."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from app.hub import EventHub
from app.viewing import ViewerService
from planner.events import Emitter, ListSink, NodeVisited, RunStarted, event_to_dict
from planner.store import RunStore


class RecordingViewer:
    """Records what it is asked to show (the real one is tested in test_viewer.py)."""

    url = "http://127.0.0.1:1"

    def __init__(self) -> None:
        self.calls: list[tuple[str, Any]] = []
        self.runs: list[str | None] = []  # the run of each show

    def show(
        self,
        scene: str,
        seed: int,
        events: Any,
        plan: dict[str, Any] | None,
        *,
        domain: str | None = None,
        focus: int | None = None,
        run_id: str | None = None,
    ) -> None:
        self.calls.append(("show", ([e["seq"] for e in events], plan)))
        self.runs.append(run_id)

    picked = None

    def extend(self, events: Any) -> None:
        self.calls.append(("extend", [e["seq"] for e in events]))

    def close(self) -> None:
        self.calls.append(("close", None))


def _wait(viewer: RecordingViewer, n: int) -> None:
    deadline = time.monotonic() + 5
    while len(viewer.calls) < n:
        assert time.monotonic() < deadline, viewer.calls
        time.sleep(0.01)


def test_follows_the_page_then_live_events_then_the_plan(tmp_path: Path) -> None:
    store = RunStore(tmp_path / "runs.db")
    hub = EventHub()
    viewer = RecordingViewer()
    service = ViewerService(viewer, store, hub)
    run_id = store.create_run("kitchen-1", 0, "baseline", {})
    hub.open(run_id)
    sink = ListSink()
    emitter = Emitter(run_id, sink)
    emitter.emit(RunStarted, scene="kitchen-1", seed=0, planner="baseline", config={})
    for i in range(5):
        emitter.emit(NodeVisited, node_id=i, visits=1, value=0.0)
    events = [event_to_dict(e) for e in sink.events]
    store.write_events(run_id, sink.events[:4])  # the store lags behind the hub
    hub.publish(run_id, events[:4])

    service.follow(run_id, 2)  # the page's step 2: events 0..2, not live
    _wait(viewer, 1)
    assert viewer.calls[-1] == ("show", ([0, 1, 2], None))
    hub.publish(run_id, events[4:5])
    time.sleep(0.1)
    assert len(viewer.calls) == 1  # not following live at a fixed step

    service.follow(run_id, None)  # the end: everything so far, and live from then on
    _wait(viewer, 2)
    assert viewer.calls[-1] == ("show", ([0, 1, 2, 3, 4], None))
    hub.publish(run_id, events[5:])
    _wait(viewer, 3)
    assert viewer.calls[-1] == ("extend", [5])

    store.write_events(run_id, sink.events[4:])
    store.finish_run(run_id, "solved", plan={"format": "x"})
    hub.end(run_id, "solved")  # the run is over: shown whole, with its plan to animate
    _wait(viewer, 4)
    assert viewer.calls[-1] == ("show", ([0, 1, 2, 3, 4, 5], {"format": "x"}))
    assert viewer.runs == [run_id] * 3  # the run is named: its state is the view's to reset
    service.close()
    assert viewer.calls[-1] == ("close", None)

"""Kitchen trials at fixed seeds stay the same trials: the stream queries of two runs (which
stream, on which inputs, with which outcome, in order) match those recorded before domains
became plug-ins (tests/search/golden/kitchen-*.json, recorded at e5923b3). A change to the
featurizer, the model file, the stream order, the samplers or the search shows up here.

Trajectories are not compared: OMPL's simplification is cut by time, so a motion's waypoints
(and the plan's execution seconds) vary with the machine's load; no query reads them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from planner.api import RunConfig, solve
from planner.events import ListSink, event_to_dict

pytestmark = pytest.mark.slow

GOLDEN = Path(__file__).parent / "golden"


@pytest.mark.parametrize(
    ("scene", "seed", "planner"),
    [("kitchen-4", 1001, "learned"), ("kitchen-2", 1000, "baseline")],
)
def test_the_query_sequence_is_the_recorded_one(scene: str, seed: int, planner: str) -> None:
    golden = json.loads((GOLDEN / f"{scene}-seed{seed}.json").read_text())[planner]
    sink = ListSink()
    out = solve(RunConfig(scene=scene, seed=seed, planner=planner, budget_s=300), sink=sink)
    queries = [
        [e["stream"], e["inputs"], e["success"]]
        for e in map(event_to_dict, sink.events)
        if e["type"] == "stream_queried"
    ]
    queries = json.loads(json.dumps(queries))  # tuples as lists, as recorded
    assert out.status == golden["status"] == "solved"
    assert len(queries) == len(golden["queries"])
    for i, (ours, theirs) in enumerate(zip(queries, golden["queries"], strict=True)):
        assert ours == theirs, f"query {i} differs"

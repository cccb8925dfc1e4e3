"""Trials at fixed seeds stay the same trials: the stream queries of kitchen and Panda runs (which
stream, on which inputs, with which outcome, in order) and the execution seconds of the plans
they bind match those recorded (tests/search/golden/*.json). A change to the featurizer, the
model file, the stream order, the samplers, the search or a robot's collision model shows up
here; the robots' and the kitchen's visual meshes do not.

Each run gets a fresh process, as a benchmark trial does: OMPL takes one random seed per
process, so a second run in one process draws other motions. Motion searches stop after a
number of iterations and their paths are shortened in counted steps, so a trial's motions, and
its execution seconds, are the same on any machine at any load. The baseline's queries were
recorded at e5923b3 (before domains became plug-ins), its execution seconds at 15f517c (before
the visual meshes); the kitchen's learned trial was recorded again when the learned planner
lost two of its parts, which made it another trial. The Panda's trials (baseline, and learned
with its shipped model) were recorded when the domain came in; both learned trials were recorded
again when the learned planner came to choose stream plans by their estimate
(``plans_by_estimate``); the Panda's learned trial again when skeletons came on demand from the
adaptive source and the learned search came to trust only validated streams (issues 52, 53),
and both Panda trials again when known failures stopped being asked twice (the Panda's IK
says when the hand is blocked both ways round: ``TreeSearch.memo_exhausted``); both kitchen
trials again when every placement try went on the packing grid (the kitchen's
``SamplerConfig.corner_fraction`` 1.0, issue 52).

To record a trial afresh after a change that is meant to change it:
``python -m tests.search.test_pinned SCENE SEED PLANNER``.
"""

from __future__ import annotations

import json
import multiprocessing
from pathlib import Path
from typing import Any

import pytest

from planner.api import RunConfig, solve
from planner.events import ListSink, event_to_dict

pytestmark = pytest.mark.slow

GOLDEN = Path(__file__).parent / "golden"


def _trial(scene: str, seed: int, planner: str) -> dict[str, Any]:
    sink = ListSink()
    out = solve(RunConfig(scene=scene, seed=seed, planner=planner, budget_s=300), sink=sink)
    queries = [
        [e["stream"], e["inputs"], e["success"]]
        for e in map(event_to_dict, sink.events)
        if e["type"] == "stream_queried"
    ]
    return {
        "status": out.status,
        "execution_s": out.execution_s,
        "queries": json.loads(json.dumps(queries)),  # tuples as lists, as recorded
    }


@pytest.mark.parametrize(
    ("scene", "seed", "planner"),
    [
        ("kitchen-4", 1001, "learned"),
        ("kitchen-2", 1000, "baseline"),
        ("panda-4", 1000, "baseline"),
        ("panda-4", 1000, "learned"),
    ],
)
def test_the_trial_is_the_recorded_one(scene: str, seed: int, planner: str) -> None:
    golden = json.loads((GOLDEN / f"{scene}-seed{seed}.json").read_text())[planner]
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        ours = pool.apply(_trial, (scene, seed, planner))
    assert ours["status"] == golden["status"] == "solved"
    queries = ours["queries"]
    assert len(queries) == len(golden["queries"])
    for i, (mine, theirs) in enumerate(zip(queries, golden["queries"], strict=True)):
        assert mine == theirs, f"query {i} differs"
    assert ours["execution_s"] == pytest.approx(golden["execution_s"], rel=1e-9)


if __name__ == "__main__":
    import sys

    scene, seed, planner = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    path = GOLDEN / f"{scene}-seed{seed}.json"
    recorded = json.loads(path.read_text()) if path.is_file() else {}
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        recorded[planner] = pool.apply(_trial, (scene, seed, planner))
    path.write_text(json.dumps(recorded, separators=(",", ":")))
    trial = recorded[planner]
    print(f"{path}: {planner} {trial['status']}, {len(trial['queries'])} queries")

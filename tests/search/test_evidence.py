"""What failed queries teach, kept up to date as the tree grows: the dead ends found refresh by
refresh are those found from the whole tree at once, on a search that fails a lot."""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

from planner.abstract import AbstractConfig, plan_abstract
from planner.domains import problem_for_scene
from planner.learning.priors import PriorPredictor
from planner.search.binding import stream_contexts
from planner.search.evidence import Evidence
from planner.search.learned import LearnedConfig, LearnedPolicy
from planner.search.mcts import TreeSearch

TUTORIAL = Path(__file__).resolve().parents[2] / "examples" / "tabletop2d"


def stuck_search(folder: Path, config: LearnedConfig) -> tuple[TreeSearch, LearnedPolicy]:
    """The tutorial's tabletop-4 with its goal region shrunk to room for about three of its
    four blocks: the collision test fails more and more as the tree grows."""
    shutil.copytree(TUTORIAL, folder, ignore=shutil.ignore_patterns("__pycache__"))
    scene = json.loads((folder / "scenes" / "tabletop-4.json").read_text())
    for region in scene["regions"]:
        if region["name"] == "goal":
            region["box"] = [0.2, 0.37, 0.0, 0.17]
    (folder / "scenes" / "stuck.json").write_text(json.dumps({**scene, "name": "stuck"}))
    loaded, problem = problem_for_scene(str(folder / "scenes" / "stuck.json"), seed=0)
    plans = plan_abstract(loaded.domain, loaded.streams, problem, AbstractConfig(k=10)).plans
    states = [stream_contexts(p, loaded.domain, problem) for p in plans]
    initial = {o.name: o.name for o in problem.objects} | dict(problem.values)
    policy = LearnedPolicy(
        PriorPredictor({}), plans, states, initial, loaded.encode, loaded.fluents, config
    )
    search = TreeSearch(
        plans,
        states,
        initial,
        loaded.runtime(problem, seed=0),
        policy,
        encode=loaded.encode,
        fluents=loaded.fluents,
        reuse=True,
        memo_tests=False,  # the collision test asked again and again: failures to learn from
    )
    return search, policy


def test_dead_ends_found_step_by_step_are_those_of_the_whole_tree(tmp_path: Path) -> None:
    search, policy = stuck_search(tmp_path / "tabletop2d", LearnedConfig())
    # The policy refreshes at every iteration: thousands of small steps.
    assert search.run(deadline=time.perf_counter() + 3.0).status == "timeout"
    policy.pick_plan(search.tree)  # a last refresh: the nodes of the last iteration
    assert len(search.tree) > 1000 and len(policy.dead) > 100
    whole = Evidence(policy.evidence.queries)
    whole.refresh(search.tree)
    assert whole.dead == policy.dead

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
from planner.search.bounds import SearchBounds
from planner.search.costs import StreamCost
from planner.search.evidence import Evidence
from planner.search.learned import LearnedConfig, LearnedPolicy
from planner.search.mcts import TreeSearch
from planner.search.tree import ROOT, Node, Tree

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
    # The policy refreshes at every iteration: thousands of small steps (2,000 iterations, about
    # 3,700 nodes; bounded by iterations, not seconds, so a busy machine makes the same tree).
    far = time.perf_counter() + 300.0  # a net only
    outcome = search.run(deadline=far, bounds=SearchBounds(max_iterations=2000))
    assert outcome.status == "timeout" and outcome.ended_by == "iteration budget of 2000 reached"
    policy.pick_plan(search.tree)  # a last refresh: the nodes of the last iteration
    assert len(search.tree) > 1000 and len(policy.dead) > 100
    whole = Evidence(policy.evidence.queries)
    whole.refresh(search.tree)
    assert whole.dead == policy.dead


class _Told:
    """Predictions and relevant objects given by hand: every query is predicted to succeed 90%
    of the time; a node's next query reads what ``reads`` says, exactly (``precise``) or as a
    guess about a sampler given the whole state, whose objects ``given`` says."""

    def __init__(
        self,
        reads: dict[int, set[str]],
        precise: bool = True,
        given: dict[int, set[str]] | None = None,
    ) -> None:
        self.reads = reads
        self.exact = precise
        self.state = given or {}

    def first(self, node: Node) -> StreamCost | None:
        return StreamCost(0.9, 0.01, 0.01, 0.0)

    def relevant(self, node: Node) -> set[str]:
        return set(self.reads.get(node.id, ()))

    def precise(self, node: Node) -> bool:
        return self.exact

    def given(self, node: Node) -> set[str]:
        return set(self.state.get(node.id, ()))


def test_a_known_failure_of_a_sampler_given_the_state_backjumps_over_what_it_was_not_given() -> (
    None
):
    """A grasp of b8 (opt-g), then placements of other blocks on the stove, then the IK picking
    b8 at its start pose with that grasp: it fails and says exhausted (the gripper collides at
    the grasp), and the state it is given holds none of the placements. The IK's sampler reads
    the whole state, so the domain's guess of what it reads is not precise: the first failure
    leaves the node alone. Under a re-drawn placement the same failure comes back as a known
    one (the memory keys on the inputs and the state's objects): what was re-drawn did not
    matter, the failure is the grasp's, and every node from there up to the grasp is a dead
    end (the search samples another grasp, not more placements). Off (exhausted_given), the
    placements and the grasp stay live."""
    tree = Tree()
    plan = tree.add(ROOT, plan_index=0, depth=0, success=True)
    grasp = tree.add(plan.id, plan_index=0, depth=1, success=True, outputs={"opt-g": 1.0})
    pa = tree.add(grasp.id, plan_index=0, depth=2, success=True, outputs={"opt-pa": 1.0})
    guessed: dict[int, set[str]] = {}  # the domain leaves the grasp's fluents out
    given: dict[int, set[str]] = {}

    def ik_below(parent: Node, x: float, known: bool) -> Node:
        placed = tree.add(parent.id, plan_index=0, depth=3, success=True, outputs={"opt-pb": x})
        tree.add(placed.id, plan_index=0, depth=4, success=False)  # ik(b8 p0-b8 opt-g) failed
        placed.exhausted = True
        placed.known_failure = known
        guessed[placed.id] = {"b8", "p0-b8"}
        given[placed.id] = {"b8", "p0-b8", "opt-g", "q0", "p0-b1"}
        return placed

    first = ik_below(pa, 1.0, known=False)
    evidence = Evidence(_Told(guessed, precise=False, given=given))
    evidence.refresh(tree)
    assert not evidence.dead  # one failure of a sampler given the state: left alone
    again = ik_below(pa, 2.0, known=True)
    evidence.refresh(tree)
    assert again.id in evidence.dead and first.id not in evidence.dead
    assert {pa.id, grasp.id} <= set(evidence.dead)
    assert "opt-g" in evidence.dead[grasp.id]
    assert plan.id not in evidence.dead  # the grasp bound what failed: the jump stops there
    off = Evidence(_Told(guessed, precise=False, given=given), exhausted_given=False)
    off.refresh(tree)
    assert not off.dead


def placement_that_left_no_room(tries: int) -> tuple[Tree, int, dict[int, set[str]]]:
    """Block 1 placed at opt-p1 (node ``first``); under it, ``tries`` placements of block 2,
    each exhausted after its collision test against opt-p1 said false (a PDDLStream test: it
    answers once), so each is dead to the search and nothing below ``first`` lives."""
    tree = Tree()
    plan = tree.add(ROOT, plan_index=0, depth=0, success=True)
    first = tree.add(plan.id, plan_index=0, depth=1, success=True, outputs={"opt-p1": 1.0})
    reads = {first.id: {"b2"}}
    for i in range(tries):
        second = tree.add(
            first.id, plan_index=0, depth=2, success=True, outputs={"opt-p2": 1.0 + i}
        )
        tree.add(second.id, plan_index=0, depth=3, success=False)  # cfree(b2 opt-p2 b1 opt-p1)
        second.exhausted = second.dead = True
        reads[second.id] = {"b2", "opt-p2", "b1", "opt-p1"}
    return tree, first.id, reads


def test_an_exhausted_node_with_nothing_live_below_is_a_dead_end_and_backjumps() -> None:
    """Each re-sampled placement of block 2 fails its test against block 1's placement: the
    failures depend on opt-p1, so once block 2 has been re-sampled as often as the prediction
    allows, block 1's placement is the dead end (the search goes back to re-place block 1).
    Without exhausted_dead the exhausted placements vouch for block 1's as live successes."""
    tree, first, reads = placement_that_left_no_room(tries=2)
    evidence = Evidence(_Told(reads))
    evidence.refresh(tree)
    assert first in evidence.dead and "opt-p1" in evidence.dead[first]
    blind = Evidence(_Told(reads), exhausted_dead=False)
    blind.refresh(tree)
    assert first not in blind.dead
    tree, first, reads = placement_that_left_no_room(tries=1)  # one try is not enough
    evidence = Evidence(_Told(reads))
    evidence.refresh(tree)
    assert first not in evidence.dead and len(evidence.dead) == 1

"""A query made again, with the same inputs in the same world, where nothing reads its output:
the search reuses the earlier result instead of running the sampler (a motion re-made after an
unrelated choice changed costs nothing)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from planner.abstract import AbstractConfig, plan_abstract
from planner.events import Emitter, ListSink, StreamQueried
from planner.pddl.parser import parse_domain, parse_problem, parse_streams
from planner.search.binding import stream_contexts
from planner.search.mcts import BaselinePolicy, TreeSearch
from planner.search.tree import ROOT
from planner.store import RunStore, StoreSink
from planner.streams.adapters import from_fn
from planner.streams.runtime import bind_streams

DOMAIN = """
(define (domain visit)
  (:requirements :strips)
  (:predicates (spot ?s) (conf ?q) (kin ?s ?q) (motion ?q1 ?t ?q2) (at-conf ?q) (visited ?s))
  (:action go
    :parameters (?q1 ?t ?q2 ?s)
    :precondition (and (at-conf ?q1) (motion ?q1 ?t ?q2) (kin ?s ?q2))
    :effect (and (at-conf ?q2) (not (at-conf ?q1)) (visited ?s))))
"""
STREAMS = """
(define (stream visit)
  (:stream ik
    :inputs (?s) :domain (spot ?s) :outputs (?q) :certified (and (conf ?q) (kin ?s ?q)))
  (:stream plan-motion
    :inputs (?q1 ?q2) :domain (and (conf ?q1) (conf ?q2)) :outputs (?t)
    :certified (motion ?q1 ?t ?q2)))
"""
PROBLEM = """
(define (problem visit-1)
  (:domain visit)
  (:objects a q0)
  (:init (spot a) (conf q0) (at-conf q0))
  (:goal (visited a)))
"""


@dataclass(frozen=True)
class Trajectory:
    """A trajectory: it takes ``seconds`` to execute."""

    name: str
    seconds: float


def make(
    sink: ListSink | StoreSink | None = None,
    run_id: str = "r",
) -> tuple[TreeSearch, list[Any]]:
    domain = parse_domain(DOMAIN)
    streams = parse_streams(STREAMS, domain)
    problem = parse_problem(PROBLEM, domain)
    motions: list[Any] = []

    def ik(spot: str) -> tuple[str]:
        return (f"conf-at-{spot}",)  # the same spot always gives the same configuration

    def plan_motion(q1: str, q2: str) -> tuple[Trajectory]:
        motions.append((q1, q2))
        return (Trajectory(f"path-{len(motions)}", 4.0),)

    runtime = bind_streams(streams, {"ik": from_fn(ik), "plan-motion": from_fn(plan_motion)})
    plans = plan_abstract(domain, streams, problem, AbstractConfig(k=1)).plans
    values = {o.name: o.name for o in problem.objects}
    states = [stream_contexts(p, domain, problem) for p in plans]
    fluents = frozenset({"at-conf", "visited"})
    search = TreeSearch(
        plans,
        states,
        values,
        runtime,
        BaselinePolicy(),
        emitter=Emitter(run_id, sink) if sink is not None else None,
        encode=str,
        fluents=fluents,
        reuse=True,
    )
    return search, motions


def test_the_same_motion_in_another_branch_is_reused_and_a_retry_is_not() -> None:
    sink = ListSink()
    search, motions = make(sink)
    plan = search.skeletons[0]
    assert [s.stream for s in plan.stream_plan] == ["ik", "plan-motion"]
    top = search.open_plan(0)
    first, second = search.query(top), search.query(top)  # two IK children, same output
    made = search.query(first)
    again = search.query(second)  # the same motion, same world, in another branch
    assert motions == [("q0", "conf-at-a")]  # the sampler ran once
    assert again.success and again.outputs == made.outputs
    retry = search.query(second)  # asking the same node again wants a new sample
    assert len(motions) == 2 and retry.outputs != made.outputs
    queried = [e for e in sink.events if isinstance(e, StreamQueried)]
    assert [e.reused_from for e in queried] == [None, None, None, made.id, None]
    assert [r.reused for _, r in search.queries] == [False, False, False, True, False]
    # The reused node costs what the original did (its oracle), though no time was spent.
    assert again.query_wall_s == made.query_wall_s
    assert search.tree[ROOT].children == [top.id]


def test_a_reused_result_leaves_no_training_row(tmp_path: Path) -> None:
    store = RunStore(tmp_path / "runs.db")
    run_id = store.create_run("visit", 0, "baseline", {})
    sink = StoreSink(store, run_id)
    search, _ = make(sink, run_id)
    top = search.open_plan(0)
    first, second = search.query(top), search.query(top)
    search.query(first)
    search.query(second)
    sink.close()
    rows = store.stream_queries(run_ids=[run_id])
    assert [r.stream for r in rows] == ["ik", "ik", "plan-motion"]
    assert sum(1 for e in store.events(run_id) if e.type == "stream_queried") == 4


def test_without_reuse_every_query_runs_its_sampler() -> None:
    search, motions = make()
    search.reuse = False
    top = search.open_plan(0)
    first, second = search.query(top), search.query(top)
    search.query(first)
    search.query(second)
    assert len(motions) == 2

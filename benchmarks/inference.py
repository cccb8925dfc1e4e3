"""Benchmark: how long the learned policy takes to score a node (features + forward passes).

    .venv/bin/python benchmarks/inference.py --scene kitchen-4 \\
        --model planner/learning/models/kitchen.pt

Scores the plan node of every skeleton of the scene (nothing bound yet: every remaining stream
of the plan is one row), repeated, and prints microseconds per row and per node.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from planner.abstract import AbstractConfig, plan_abstract
from planner.learning.predictor import ModelPredictor
from planner.runs import DEFAULT_MODEL, jsonable
from planner.search.binding import stream_contexts
from planner.search.learned import LearnedPolicy
from planner.search.tree import ROOT, Tree


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", default="kitchen-4")
    parser.add_argument("--model", type=Path, default=DEFAULT_MODEL)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    from planner.domains import problem_for_scene

    loaded, problem = problem_for_scene(args.scene)
    plans = plan_abstract(loaded.domain, loaded.streams, problem, AbstractConfig(k=50)).plans
    states = [stream_contexts(p, loaded.domain, problem) for p in plans]
    values = {o.name: o.name for o in problem.objects} | dict(problem.values)
    fluents = frozenset(
        a.predicate for act in loaded.domain.actions for a in act.add_effects + act.del_effects
    )
    predictor = ModelPredictor.load(args.model, domain="kitchen")
    rows = nodes = 0
    start = time.perf_counter()
    for _ in range(args.repeats):
        policy = LearnedPolicy(predictor, plans, states, values, jsonable, fluents)
        tree = Tree()
        for i, plan in enumerate(plans):
            node = tree.add(ROOT, plan_index=i, depth=0, success=True)
            policy.q(tree, node)
            rows += len(plan.stream_plan)
            nodes += 1
    seconds = time.perf_counter() - start
    print(
        f"{args.scene}: {nodes} nodes, {rows} rows in {seconds:.2f} s: "
        f"{seconds / rows * 1e6:.0f} us per row, {seconds / nodes * 1e3:.1f} ms per node "
        f"({rows / nodes:.0f} streams each, one batch per stream)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: the learned search's own seconds per node as its tree grows.

    .venv/bin/python benchmarks/search_overhead.py --marks 1000,3000,10000 --budget 300 \\
        [--planner learned] [--model MODEL]

A search that cannot finish: the tutorial domain's tabletop-4 with its goal region shrunk to
room for about three of its four blocks, so the collision test fails more and more as the tree
grows. The policy (selection, estimates, what failed queries teach, predictions) is timed
apart from the stream queries and the loop; at each mark the script prints the policy's seconds
per node since the last mark. Flat is the goal: a refresh should cost what changed since the
last one, not the whole tree. Without ``--model`` the policy runs on uniform priors (no model
inference in the figures).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from planner.abstract import AbstractConfig, plan_abstract
from planner.domains import problem_for_scene
from planner.learning.priors import PriorPredictor
from planner.planners import get_planner
from planner.search.binding import stream_contexts
from planner.search.learned import LearnedPolicy, Predictor
from planner.search.mcts import TreeSearch

TUTORIAL = Path(__file__).resolve().parents[1] / "examples" / "tabletop2d"


class _Timed:
    """A policy whose every call is timed."""

    def __init__(self, inner: LearnedPolicy) -> None:
        self.inner = inner
        self.spent = 0.0

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self.inner, name)
        if not callable(attr):
            return attr

        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return attr(*args, **kwargs)
            finally:
                self.spent += time.perf_counter() - start

        return timed


class _TimedPredictor:
    """A predictor whose calls are timed (the model's share of the policy's seconds)."""

    def __init__(self, inner: Predictor) -> None:
        self.inner = inner
        self.spent = 0.0

    def predict_rows(self, rows: Any) -> Any:
        start = time.perf_counter()
        try:
            return self.inner.predict_rows(rows)
        finally:
            self.spent += time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--marks", default="1000,3000,10000", help="tree sizes to report at")
    parser.add_argument("--budget", type=float, default=300.0, help="seconds at most")
    parser.add_argument("--planner", default="learned", help="paper, learned or a variant")
    parser.add_argument("--model", type=Path, help="a tabletop2d model (default: priors)")
    args = parser.parse_args()
    marks = sorted(int(m) for m in args.marks.split(","))
    parts = get_planner(args.planner).parts
    if parts is None:
        raise SystemExit(f"{args.planner}: not a learned planner")

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "tabletop2d"
        shutil.copytree(TUTORIAL, folder, ignore=shutil.ignore_patterns("__pycache__"))
        scene = json.loads((folder / "scenes" / "tabletop-4.json").read_text())
        scene["name"] = "stuck"
        for region in scene["regions"]:
            if region["name"] == "goal":
                region["box"] = [0.2, 0.37, 0.0, 0.17]  # room for about three 8 cm blocks
        (folder / "scenes" / "stuck.json").write_text(json.dumps(scene))
        loaded, problem = problem_for_scene(str(folder / "scenes" / "stuck.json"), seed=0)
        plans = plan_abstract(loaded.domain, loaded.streams, problem, AbstractConfig(k=10)).plans
        states = [stream_contexts(p, loaded.domain, problem) for p in plans]
        initial = {o.name: o.name for o in problem.objects} | dict(problem.values)
        predictor: Predictor = PriorPredictor({})
        if args.model is not None:
            from planner.learning.predictor import ModelPredictor

            predictor = ModelPredictor.load(args.model, domain=loaded)
        timed_predictor = _TimedPredictor(predictor)
        predictor = timed_predictor
        policy = _Timed(
            LearnedPolicy(predictor, plans, states, initial, loaded.encode, loaded.fluents, parts)
        )
        search = TreeSearch(
            plans,
            states,
            initial,
            loaded.runtime(problem, seed=0),
            policy,  # type: ignore[arg-type]  # a timing proxy of a Policy
            encode=loaded.encode,
            fluents=loaded.fluents,
            reuse=True,
        )
        start = time.perf_counter()
        deadline = start + args.budget
        last_spent, last_nodes = 0.0, 0
        print(f"{args.planner} on a stuck tabletop search ({'model' if args.model else 'priors'})")
        while marks and time.perf_counter() < deadline:
            out = search.run(deadline=min(deadline, time.perf_counter() + 0.25))
            nodes = len(search.tree)
            while marks and nodes >= marks[0]:
                per = (policy.spent - last_spent) / max(nodes - last_nodes, 1)
                print(
                    f"  {nodes:6d} nodes: policy {policy.spent:7.1f} s in all "
                    f"(predictions {timed_predictor.spent:.1f} s), "
                    f"{per * 1e3:6.2f} ms per node since {last_nodes}",
                    flush=True,
                )
                last_spent, last_nodes = policy.spent, nodes
                marks.pop(0)
            if out.status == "solved":
                print("  solved (the scene was not stuck enough)")
                break
        print(f"  {len(search.tree)} nodes in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

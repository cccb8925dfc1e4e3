"""Benchmark: what the learned policy's model rows cost.

    .venv/bin/python benchmarks/inference.py --scene kitchen-4 --repeats 5

1. **Features per row, paired**: the model rows of every stream of every skeleton of the scene
   (as the policy scores a plan node: nothing bound, the scene's initial facts and values) are
   featurized by the kitchen's own feature hook (what the shipped model reads) and by the
   generic encoding of the fluent facts and their values (``FactFeatures``, fitted on the same
   rows), in alternating blocks; microseconds per row for each and their ratio, with the
   spread over the blocks.
2. **Scoring a node**: the plan node of every skeleton through the learned policy with the
   domain's model (features and forward passes), microseconds per row and milliseconds per node.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from planner.abstract import AbstractConfig, plan_abstract
from planner.domains import problem_for_scene
from planner.learning.features import Featurizer
from planner.learning.predictor import ModelPredictor
from planner.search.binding import stream_contexts
from planner.search.learned import LearnedPolicy, stream_rows
from planner.search.tree import ROOT, Tree


@dataclass(frozen=True)
class _Row:
    stream: str
    inputs: list[Any]
    context: dict[str, Any]


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", default="kitchen-4")
    parser.add_argument("--domain", help="the domain's name or folder (default: the scene's)")
    parser.add_argument("--model", type=Path, help="model file (default: the domain's own)")
    parser.add_argument("--repeats", type=int, default=5, help="blocks per featurizer")
    args = parser.parse_args()

    loaded, problem = problem_for_scene(args.scene, domain=args.domain)
    plans = plan_abstract(loaded.domain, loaded.streams, problem, AbstractConfig(k=50)).plans
    states = [stream_contexts(p, loaded.domain, problem) for p in plans]
    values = {o.name: o.name for o in problem.objects} | dict(problem.values)
    static = loaded.static_context(problem)
    rows = [
        _Row(stream, list(inputs), context)
        for plan, plan_states in zip(plans, states, strict=True)
        for stream, inputs, context in stream_rows(
            plan,
            plan_states,
            values,
            encode=loaded.encode,
            fluents=loaded.fluents,
            static_context=static,
        )
    ]
    own = Featurizer.fit(rows, domain=loaded)
    generic_domain = replace(loaded, spec=replace(loaded.spec, features=None))
    generic = Featurizer.fit(rows, domain=generic_domain)
    timings: dict[str, list[float]] = {"domain hook": [], "generic": []}
    for i in range(2 * args.repeats):
        name, featurizer = ("domain hook", own) if i % 2 == 0 else ("generic", generic)
        start = time.perf_counter()
        for r in rows:
            featurizer.row(r.stream, r.inputs, r.context)
        timings[name].append((time.perf_counter() - start) / len(rows) * 1e6)
    ratios = [g / o for g, o in zip(timings["generic"], timings["domain hook"], strict=True)]
    widths = {name: f.width(rows[0].stream) for name, f in (("hook", own), ("generic", generic))}
    print(
        f"{args.scene}: {len(rows)} rows, {args.repeats} blocks each, alternating "
        f"(row widths of {rows[0].stream}: {widths})"
    )
    for name, ts in timings.items():
        print(
            f"  features, {name:11}: {statistics.median(ts):6.1f} us per row "
            f"(blocks {min(ts):.1f} to {max(ts):.1f})"
        )
    print(
        f"  generic / domain hook: {statistics.median(ratios):.2f} "
        f"(blocks {min(ratios):.2f} to {max(ratios):.2f})"
    )

    model = args.model or loaded.spec.model
    if model is None:
        print("  no model for this domain: node scoring not measured")
        return 0
    predictor = ModelPredictor.load(model, domain=loaded)
    n_rows = nodes = 0
    start = time.perf_counter()
    for _ in range(args.repeats):
        policy = LearnedPolicy(
            predictor, plans, states, values, loaded.encode, loaded.fluents, static_context=static
        )
        tree = Tree()
        for i, plan in enumerate(plans):
            node = tree.add(ROOT, plan_index=i, depth=0, success=True)
            policy.q(tree, node)
            n_rows += len(plan.stream_plan)
            nodes += 1
    seconds = time.perf_counter() - start
    print(
        f"  scoring: {nodes} nodes, {n_rows} rows in {seconds:.2f} s: "
        f"{seconds / n_rows * 1e6:.0f} us per row, {seconds / nodes * 1e3:.1f} ms per node "
        f"({n_rows / nodes:.0f} streams each, one batch per stream)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

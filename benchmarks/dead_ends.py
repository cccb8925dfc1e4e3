"""Probe: which nodes of one learned run's tree are taken for dead ends, by plan and depth.

    .venv/bin/python benchmarks/dead_ends.py --scene kitchen-4 --seed 1009 --budget 40 \\
        --field ik_attempts --value 96 --no-shared

Runs one learned trial in this process (``SamplerConfig.FIELD`` set to ``VALUE`` when given)
and prints its status, then, for the tree as the policy last saw it, one line per (plan, depth,
query outcome, dead end) with its node count. ``--no-shared`` switches off the blame of the
choices a repeatedly failing query shares (``LearnedPolicy._shared_culprits``, 2af562f), to see
the search as it was before. A run that times out makes as many queries as the machine's pace
allows within the budget, so its counts vary from run to run.
"""

from __future__ import annotations

import argparse
import logging
import random
import sys
from collections import Counter
from typing import Any

import planner.search.learned as learned
from planner.runs import RunConfig, run
from planner.search.tree import Tree


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", default="kitchen-4")
    parser.add_argument("--seed", type=int, default=1009)
    parser.add_argument("--budget", type=float, default=40.0)
    parser.add_argument("--field", help="a SamplerConfig field to set")
    parser.add_argument("--value", help="its value")
    parser.add_argument("--no-shared", action="store_true", help="no blame of shared choices")
    args = parser.parse_args()
    if (args.field is None) != (args.value is None):
        parser.error("--field and --value go together")
    if args.budget <= 0:
        parser.error("--budget must be positive")
    logging.basicConfig(level=logging.WARNING)
    if args.field is not None:
        import planner.domains.kitchen.samplers as ks

        try:
            config = ks.SamplerConfig().with_text(args.field, args.value)
        except ValueError as exc:
            parser.error(f"--field {args.field!r} --value {args.value!r}: {exc}")
        original = ks.KitchenSamplers.__init__

        def init(self: Any, geometry: Any, rng: random.Random, **kw: Any) -> None:
            kw.setdefault("config", config)
            original(self, geometry, rng, **kw)

        ks.KitchenSamplers.__init__ = init  # type: ignore[method-assign]
    if args.no_shared:
        learned.LearnedPolicy._shared_culprits = lambda self, tree: []  # type: ignore[method-assign]
    seen: dict[str, Any] = {}
    dead_ends = learned.LearnedPolicy._dead_ends

    def watch(self: learned.LearnedPolicy, tree: Tree) -> set[int]:
        out = dead_ends(self, tree)
        seen["tree"], seen["dead"] = tree, out
        return out

    learned.LearnedPolicy._dead_ends = watch  # type: ignore[method-assign]
    result, _, _ = run(
        RunConfig(scene=args.scene, seed=args.seed, planner="learned", budget_s=args.budget)
    )
    execution = "-" if result.execution_s is None else f"{result.execution_s:.1f} s"
    print(
        f"{args.scene} seed {args.seed} learned: {result.status}, planning "
        f"{result.planning_s:.1f} s, execution {execution}"
    )
    if "tree" not in seen:
        print("the policy never refreshed: no tree to show")
        return 0
    tree, dead = seen["tree"], seen["dead"]
    counts = Counter(
        (n.plan_index, n.depth, n.success, n.id in dead) for n in tree.nodes[1:] if n.depth > 0
    )
    print(f"{len(dead)} dead ends among {len(tree.nodes) - 1} nodes")
    print("plan  depth  outcome  dead  nodes")
    for (plan, depth, ok, is_dead), n in sorted(counts.items()):
        outcome = "success" if ok else "failed"
        print(f"{plan:4d}  {depth:5d}  {outcome:7s}  {'yes' if is_dead else 'no':4s}  {n:5d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

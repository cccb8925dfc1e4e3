"""Benchmark: k unique skeletons per kitchen size with each top-k backend.

Runs K* and SymK alternately on the same task (so machine noise hits both alike), several
repeats, and prints a Markdown table: median seconds, the SymK / K* ratio of paired runs, the
top-k calls made, and how diverse the k plans are.

    .venv/bin/python benchmarks/abstract_topk.py --scenes 1,2,4,6,8 --k 50 --repeats 3
"""

from __future__ import annotations

import argparse
import logging
import platform
import statistics
import sys
import time

from planner.abstract import AbstractConfig, AbstractResult, plan_abstract, replay
from planner.abstract.topk import TOPK_PLANNERS
from planner.domains import problem_for_scene


def run_once(scene: str, backend: str, k: int) -> AbstractResult:
    loaded, problem = problem_for_scene(scene)
    config = AbstractConfig(k=k, backend=backend, diversity_ignore=loaded.spec.diversity_ignore)
    result = plan_abstract(loaded.domain, loaded.streams, problem, config)
    for plan in result.plans:
        replay(plan, loaded.domain, problem)  # every stream plan is checked, not just timed
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="1,2,4,6,8", help="kitchen sizes, comma-separated")
    parser.add_argument("--k", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--backends", default="kstar,symk")
    args = parser.parse_args()
    backends = args.backends.split(",")
    for b in backends:
        if b not in TOPK_PLANNERS:
            parser.error(f"unknown backend {b!r} (known: {', '.join(TOPK_PLANNERS)})")
    logging.basicConfig(level=logging.WARNING)
    print(f"machine: {platform.machine()}, {platform.python_version()}, k={args.k}", flush=True)
    rows = []
    for n in args.scenes.split(","):
        scene = f"kitchen-{n}"
        seconds: dict[str, list[float]] = {b: [] for b in backends}
        last: dict[str, AbstractResult] = {}
        for rep in range(args.repeats):
            order = backends if rep % 2 == 0 else backends[::-1]  # alternate who goes first
            for b in order:
                t = time.perf_counter()
                last[b] = run_once(scene, b, args.k)
                seconds[b].append(time.perf_counter() - t)
                print(f"  {scene} {b} run {rep + 1}: {seconds[b][-1]:.2f} s", file=sys.stderr)
        ratio = ""
        if len(backends) == 2:
            ratios = [
                y / x for x, y in zip(seconds[backends[0]], seconds[backends[1]], strict=True)
            ]
            ratio = f"{statistics.median(ratios):.1f}"
        for b in backends:
            r = last[b]
            rows.append(
                f"| {scene} | {b} | {statistics.median(seconds[b]):.2f} | "
                f"{r.seconds['topk']:.2f} | {len(r.plans)} | {r.rounds} | {r.requested} | "
                f"{r.unique} | {r.distinct_multisets} | {r.distinct_choices} | "
                f"{ratio if b == backends[-1] else ''} |"
            )
    print(
        "| scene | top-k | median s | top-k s | plans | calls | asked | unique "
        f"| multisets | w/o move | {'/'.join(reversed(backends))} |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())

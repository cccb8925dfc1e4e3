"""Benchmark: skeleton sources by scene, paired: seconds to the first skeleton and to k.

For each scene and repeat, each source in turn (the order alternates, so machine noise hits
every source alike) on a fresh source object:

- ``first``: seconds of ``request(1)`` (instantiation, grounding, the planner, stream plans);
- ``to k``: the adaptive source's ``request(k - 1)`` after it, on the same object (skeletons on
  demand), or a top-k planner's ``request(k)`` on a fresh object (it plans all k at once).

Every skeleton is replayed fact by fact, not just timed. Prints a Markdown table: the median
seconds, the costs of the cheapest and of the dearest skeleton, the unique skeletons, and per
scene the median ratio of each source's seconds to the first source's (paired by repeat).

    .venv/bin/python benchmarks/abstract_topk.py --scenes kitchen-4,kitchen-8,kitchen-12 \\
        --sources adaptive,kstar --k 50 --repeats 3
"""

from __future__ import annotations

import argparse
import logging
import platform
import statistics
import sys
import time

from planner.abstract import AbstractConfig, AbstractPlan, replay
from planner.abstract.source import SKELETON_SOURCES
from planner.domains import problem_for_scene


def run_once(scene: str, source: str, k: int) -> tuple[float, float, list[AbstractPlan]]:
    """(seconds to the first skeleton, seconds to k, the k skeletons)."""
    loaded, problem = problem_for_scene(scene)
    runtime = loaded.runtime(problem, seed=0) if loaded.streams.functions else None
    config = AbstractConfig(k=k, backend=source, diversity_ignore=loaded.spec.diversity_ignore)
    made = config.source(loaded.domain, loaded.streams, problem, functions=runtime)
    t0 = time.perf_counter()
    plans = list(made.request(1).plans)
    first = time.perf_counter() - t0
    if k > 1:
        if source == "adaptive":
            plans += made.request(k - 1).plans
        else:
            again = config.source(loaded.domain, loaded.streams, problem, functions=runtime)
            t0 = time.perf_counter()
            plans = list(again.request(k).plans)
    to_k = time.perf_counter() - t0  # adaptive: since its first request; top-k: its own
    for plan in plans:
        replay(plan, loaded.domain, problem, loaded.streams)
    return first, to_k, plans


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="kitchen-4,kitchen-8,kitchen-12")
    parser.add_argument("--sources", default="adaptive,kstar", help="skeleton sources to pair")
    parser.add_argument("--k", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    sources = args.sources.split(",")
    for s in sources:
        if s not in SKELETON_SOURCES:
            parser.error(f"unknown source {s!r} (known: {', '.join(SKELETON_SOURCES)})")
    logging.basicConfig(level=logging.WARNING)
    print(f"machine: {platform.machine()}, {platform.python_version()}, k={args.k}", flush=True)
    rows = []
    for scene in args.scenes.split(","):
        first: dict[str, list[float]] = {s: [] for s in sources}
        to_k: dict[str, list[float]] = {s: [] for s in sources}
        last: dict[str, list[AbstractPlan]] = {}
        for rep in range(args.repeats):
            order = sources if rep % 2 == 0 else sources[::-1]
            for s in order:
                a, b, plans = run_once(scene, s, args.k)
                first[s].append(a)
                to_k[s].append(b)
                last[s] = plans
                print(
                    f"  {scene} {s} run {rep + 1}: first {a:.2f} s, {args.k}: {b:.2f} s",
                    file=sys.stderr,
                    flush=True,
                )
        for s in sources:
            ratio = ""
            if s != sources[0]:
                ratios = [y / x for x, y in zip(to_k[sources[0]], to_k[s], strict=True)]
                ratio = f"{statistics.median(ratios):.1f}"
            costs = [p.cost for p in last[s]]
            rows.append(
                f"| {scene} | {s} | {statistics.median(first[s]):.2f} | "
                f"{statistics.median(to_k[s]):.2f} | {len(last[s])} | "
                f"{min(costs):g} | {max(costs):g} | {ratio} |"
            )
    print(
        f"| scene | source | first s (median) | {args.k} s (median) | skeletons "
        f"| cheapest | dearest | {args.k} s against {sources[0]} |"
    )
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())

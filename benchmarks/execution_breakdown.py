"""Benchmark analysis: where a benchmark's execution seconds go, per planner.

    .venv/bin/python benchmarks/execution_breakdown.py BENCH_ID --db bench-k4.db

Reads the plans the benchmark's solved trials stored (kitchen plans: trajectories made of base
and arm segments) and prints, over the seeds every planner solved, the mean seconds of base
travel and of arm motion, and the straight-line lower bound of the same base moves (each move
from its first to its last pose: distance at 0.5 m/s or turn at 1 rad/s, whichever is longer).
Base travel far above its bound means detours; a bound that differs between planners means
base poses farther apart.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
from typing import Any

from planner.robots.pr2.model import BASE_VELOCITY
from planner.sim.transforms import wrap_angle
from planner.store import RunStore


def breakdown(plan: dict[str, Any]) -> tuple[float, float, float]:
    """(base seconds, arm seconds, straight-line bound of the base moves) of one stored plan."""
    linear, angular = BASE_VELOCITY
    base = arm = bound = 0.0
    for value in plan.get("values", {}).values():
        if not isinstance(value, dict) or "segments" not in value:
            continue
        for seg in value["segments"]:
            if seg["kind"] == "base":
                base += seg["seconds"]
                a, b = seg["base"][0], seg["base"][-1]
                bound += max(
                    math.dist(a[:2], b[:2]) / linear, abs(wrap_angle(b[2] - a[2])) / angular
                )
            else:
                arm += seg["seconds"]
    return base, arm, bound


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("bench_id")
    parser.add_argument("--db", required=True)
    args = parser.parse_args()
    rows: dict[tuple[int, str], tuple[float, float, float]] = {}
    with RunStore(args.db) as store:
        try:
            store.get_bench(args.bench_id)
        except KeyError as exc:  # the message lists the known benchmarks
            print(exc.args[0], file=sys.stderr)
            return 2
        for t in store.bench_trials(args.bench_id):
            if t.status != "solved" or t.run_id is None:
                continue
            plan = store.get_run(t.run_id).plan
            if plan:
                rows[(t.seed, t.planner)] = breakdown(plan)
    planners = sorted({p for _, p in rows})
    seeds = sorted({s for s, _ in rows if all((s, p) in rows for p in planners)})
    if not seeds:
        print("no seed solved by every planner", file=sys.stderr)
        return 1
    print(f"{len(seeds)} seeds solved by every planner ({', '.join(planners)})")
    print("| planner | base travel s | arm s | base straight-line bound s | base / bound |")
    print("| --- | --- | --- | --- | --- |")
    for p in planners:
        base, arm, bound = (statistics.mean(rows[(s, p)][i] for s in seeds) for i in range(3))
        print(f"| {p} | {base:.1f} | {arm:.1f} | {bound:.1f} | {base / bound:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: planners compared on the same seeds, interleaved, as paired ratios.

    .venv/bin/python benchmarks/paired.py --scene kitchen-2 --planners baseline,learned \\
        --seeds 100-109 --budget 120 --workers 2

Trials run through planner.experiment (fresh process per trial, recorded); for each seed every
planner runs, interleaved so machine noise hits both alike. Printed: per planner, solved
fraction and median planning / execution / total seconds; and over the seeds both solved, the
median paired ratio (second planner / first) of planning, execution and total seconds.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

from planner.experiment import Trial, run_trials, stderr_progress


def seeds(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", default="kitchen-2")
    parser.add_argument("--planners", default="baseline,learned")
    parser.add_argument("--seeds", default="100-109")
    parser.add_argument("--budget", type=float, default=120.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--model", default=None)
    parser.add_argument("--db", default=None)
    args = parser.parse_args()
    planners = args.planners.split(",")
    db = args.db or str(Path(tempfile.mkdtemp()) / "paired.db")
    trials = [
        Trial(args.scene, s, p, args.budget, args.model if p == "learned" else None)
        for s in seeds(args.seeds)
        for p in (planners if s % 2 == 0 else planners[::-1])
    ]
    results = run_trials(trials, db, workers=args.workers, progress=stderr_progress)
    by = {(r.trial.planner, r.trial.seed): r for r in results}
    print(f"{args.scene}, seeds {args.seeds}, budget {args.budget:g} s, db {db}")
    print("| planner | solved | planning s | execution s | total s |")
    print("|---|---|---|---|---|")
    for p in planners:
        ok = [r for r in results if r.trial.planner == p and r.status == "solved"]

        def med(xs: list[float]) -> float:
            return statistics.median(xs) if xs else float("nan")

        print(
            f"| {p} | {len(ok)}/{len(seeds(args.seeds))} "
            f"| {med([r.planning_s or 0 for r in ok]):.1f} "
            f"| {med([r.execution_s or 0 for r in ok]):.1f} "
            f"| {med([(r.planning_s or 0) + (r.execution_s or 0) for r in ok]):.1f} |"
        )
    a, b = planners[0], planners[1]
    both = [
        s
        for s in seeds(args.seeds)
        if by[(a, s)].status == "solved" and by[(b, s)].status == "solved"
    ]
    if both:

        def ratio(key: str) -> float:
            def val(p: str, s: int) -> float:
                r = by[(p, s)]
                if key == "total":
                    return (r.planning_s or 0) + (r.execution_s or 0)
                return float(getattr(r, key) or 0)

            return statistics.median(val(b, s) / max(val(a, s), 1e-9) for s in both)

        print(
            f"paired over {len(both)} seeds solved by both, median {b}/{a}: planning "
            f"{ratio('planning_s'):.2f}, execution {ratio('execution_s'):.2f}, "
            f"total {ratio('total'):.2f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())

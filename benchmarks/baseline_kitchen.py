"""Benchmark: the eTAMP baseline on kitchen-1 .. kitchen-4, many seeds, each trial recorded.

    .venv/bin/python benchmarks/baseline_kitchen.py --scenes 1,2,3,4 --seeds 20 --budget 300 \\
        --workers 2 --db bench-baseline.db

Trials run through planner.experiment (a fresh process per trial, recorded in one SQLite store
like `tamp plan`, plans validated in simulation). Printed: per scene, solved fraction, medians
of planning / execution seconds and queries on the solved trials, the median ratio planning /
oracle, and what recording cost (seconds spent handing events to the store over planning
seconds). The store doubles as training data for the learned planner.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

from planner.experiment import Trial, TrialResult, run_trials, stderr_progress


def table(results: list[TrialResult], scenes: list[str]) -> str:
    lines = [
        "| scene | solved | valid | planning s (median) | execution s | queries "
        "| planning/oracle | recording |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for scene in scenes:
        rs = [r for r in results if r.trial.scene == scene]
        ok = [r for r in rs if r.status == "solved"]

        def med(values: list[float]) -> float:
            return statistics.median(values) if values else float("nan")

        planning = [r.planning_s or 0.0 for r in rs]
        record = sum(r.record_s for r in rs) / max(sum(planning), 1e-9)
        lines.append(
            f"| {scene} | {len(ok)}/{len(rs)} | {sum(bool(r.valid) for r in ok)}/{len(ok)} "
            f"| {med([r.planning_s or 0 for r in ok]):.1f} "
            f"| {med([r.execution_s or 0 for r in ok]):.1f} "
            f"| {med([float(r.queries) for r in ok]):.0f} "
            f"| {med([(r.planning_s or 0) / (r.oracle_s or 1) for r in ok]):.2f} "
            f"| {record:.2%} |"
        )
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scenes", default="1,2,3,4")
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--seed-start", type=int, default=0)
    parser.add_argument("--budget", type=float, default=300.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--db", default=None, help="SQLite file (default: a temporary one)")
    parser.add_argument("--out", default=None, help="write every trial as JSON here")
    args = parser.parse_args()
    db = args.db or str(Path(tempfile.mkdtemp()) / "bench.db")
    scenes = [f"kitchen-{n}" for n in args.scenes.split(",")]
    trials = [
        Trial(scene, seed, "baseline", args.budget)
        for seed in range(args.seed_start, args.seed_start + args.seeds)
        for scene in scenes
    ]
    start = time.perf_counter()
    results = run_trials(trials, db, workers=args.workers, progress=stderr_progress)
    if args.out:
        Path(args.out).write_text(json.dumps([r.to_dict() for r in results], indent=1))
    print(
        f"budget {args.budget:g} s, {args.workers} workers, {args.seeds} seeds per scene, db {db}"
    )
    print(table(results, scenes))
    print(f"wall time of the whole benchmark: {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

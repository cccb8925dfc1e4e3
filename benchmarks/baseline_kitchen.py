"""Benchmark: the eTAMP baseline on kitchen-1 .. kitchen-4, many seeds, each trial recorded.

    .venv/bin/python benchmarks/baseline_kitchen.py --scenes 1,2,3,4 --seeds 20 --budget 300 \\
        --workers 2

Each trial runs in a fresh process (OMPL takes one seed per process), is recorded in a SQLite
store like `tamp plan`, and its plan is validated in simulation. Printed: per scene, solved
fraction, medians of planning / execution seconds and queries on the solved trials, the median
ratio planning / oracle, and what recording cost (seconds spent inside the store sink over
planning seconds).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from planner.events import Event
from planner.runs import RunConfig, run
from planner.store import RunStore, StoreSink


class TimedSink:
    """Forwards to a sink and counts the seconds spent in it."""

    def __init__(self, inner: StoreSink) -> None:
        self.inner = inner
        self.seconds = 0.0

    def emit(self, event: Event) -> None:
        t = time.perf_counter()
        self.inner.emit(event)
        self.seconds += time.perf_counter() - t

    def close(self) -> None:
        t = time.perf_counter()
        self.inner.close()
        self.seconds += time.perf_counter() - t


def trial(scene: str, seed: int, budget: float, db: str) -> dict[str, Any]:
    from planner.domains.kitchen.validate import validate_plan

    store = RunStore(db)
    config = RunConfig(scene=scene, seed=seed, budget_s=budget)
    run_id = store.create_run(scene, seed, "baseline", {"budget_s": budget})
    sink = TimedSink(StoreSink(store, run_id))
    result, _, problem = run(config, sink=sink, run_id=run_id)
    sink.close()
    valid = None
    if result.bound is not None:
        report = validate_plan(result.bound.skeleton.actions, result.bound.values, problem)
        valid = report.ok
    store.finish_run(
        run_id,
        result.status,
        planning_s=result.planning_s,
        execution_s=result.execution_s,
        oracle_s=result.oracle_s,
        queries=len(result.queries),
        message="valid" if valid else "",
    )
    store.close()
    return {
        "scene": scene,
        "seed": seed,
        "status": result.status,
        "valid": valid,
        "planning_s": result.planning_s,
        "execution_s": result.execution_s,
        "oracle_s": result.oracle_s,
        "queries": len(result.queries),
        "record_s": sink.seconds,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="1,2,3,4")
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--seed-start", type=int, default=0)
    parser.add_argument("--budget", type=float, default=300.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--db", default=None, help="SQLite file (default: a temporary one)")
    parser.add_argument("--out", default=None, help="write every trial as JSON here")
    args = parser.parse_args()
    db = args.db or str(Path(tempfile.mkdtemp()) / "bench.db")
    RunStore(db).close()
    jobs = [
        (f"kitchen-{n}", s)
        for n in args.scenes.split(",")
        for s in range(args.seed_start, args.seed_start + args.seeds)
    ]
    results: list[dict[str, Any]] = []
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers, max_tasks_per_child=1) as pool:
        futures = [pool.submit(trial, scene, seed, args.budget, db) for scene, seed in jobs]
        for done, fut in enumerate(as_completed(futures), 1):
            r = fut.result()
            results.append(r)
            print(
                f"[{done}/{len(jobs)}] {r['scene']} seed {r['seed']}: {r['status']} "
                f"{r['planning_s']:.1f} s ({time.perf_counter() - start:.0f} s elapsed)",
                file=sys.stderr,
                flush=True,
            )
    if args.out:
        Path(args.out).write_text(json.dumps(results, indent=1))
    print(f"budget {args.budget:g} s, {args.workers} workers, {args.seeds} seeds per scene")
    print(
        "| scene | solved | valid | planning s (median) | execution s | queries "
        "| planning/oracle | recording |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for n in args.scenes.split(","):
        rs = [r for r in results if r["scene"] == f"kitchen-{n}"]
        ok = [r for r in rs if r["status"] == "solved"]

        def med(key: str, ok: list[dict[str, Any]] = ok) -> float:
            return statistics.median(r[key] for r in ok) if ok else float("nan")

        ratio = (
            statistics.median(r["planning_s"] / r["oracle_s"] for r in ok) if ok else float("nan")
        )
        rec = sum(r["record_s"] for r in rs) / sum(r["planning_s"] for r in rs)
        print(
            f"| kitchen-{n} | {len(ok)}/{len(rs)} | {sum(bool(r['valid']) for r in ok)}/{len(ok)} "
            f"| {med('planning_s'):.1f} | {med('execution_s'):.1f} | {med('queries'):.0f} "
            f"| {ratio:.2f} | {rec:.2%} |"
        )
    print(f"wall time of the whole benchmark: {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

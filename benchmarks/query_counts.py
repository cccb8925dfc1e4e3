"""Benchmark analysis: how many queries of one stream each planner made, and their seconds.

    .venv/bin/python benchmarks/query_counts.py BENCH_ID --db bench-k4.db [--stream plan-motion]
        [--at-most 13]

Reads the stream queries each trial's run stored (reused results are not stored, so they do
not count) and prints, per planner: trials, the mean number of queries of the stream per
trial, how many trials made at most ``--at-most`` of them, the mean seconds they took per
trial and per query, the mean planning seconds, and how many trials reused results of the
stream (``stream_queried`` events with ``reused_from``) and how many results in all. With
``plan-motion`` on kitchen-4 (a plan needs 12 motions) this says how close a planner comes to
planning only what it keeps.
"""

from __future__ import annotations

import argparse
import statistics
import sys

from planner.events import StreamQueried
from planner.store import RunStore


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("bench_id")
    parser.add_argument("--db", required=True)
    parser.add_argument("--stream", default="plan-motion")
    parser.add_argument("--at-most", type=int, default=13)
    args = parser.parse_args(argv)
    with RunStore(args.db) as store:
        trials = [t for t in store.bench_trials(args.bench_id) if t.run_id is not None]
        if not trials:
            print(f"no trials with a run in benchmark {args.bench_id}", file=sys.stderr)
            return 1
        print(
            f"| planner | trials | mean {args.stream} queries | trials with at most "
            f"{args.at_most} | mean s per trial | s per query | mean planning s | "
            "trials reusing | results reused |"
        )
        print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
        for planner in sorted({t.planner for t in trials}):
            mine = [t for t in trials if t.planner == planner]
            counts, seconds, reused = [], [], []
            for t in mine:
                assert t.run_id is not None
                queries = store.stream_queries(stream=args.stream, run_ids=[t.run_id])
                counts.append(len(queries))
                seconds.append(sum(q.wall_s for q in queries))
                reused.append(
                    sum(
                        1
                        for e in store.events(t.run_id)
                        if isinstance(e, StreamQueried)
                        and e.stream == args.stream
                        and e.reused_from is not None
                    )
                )
            planning = [t.planning_s for t in mine if t.planning_s is not None]
            per_query = sum(seconds) / sum(counts) if sum(counts) else float("nan")
            print(
                f"| {planner} | {len(mine)} | {statistics.mean(counts):.1f} | "
                f"{sum(1 for c in counts if c <= args.at_most)} | "
                f"{statistics.mean(seconds):.1f} | {per_query:.2f} | "
                f"{statistics.mean(planning):.1f} | {sum(1 for r in reused if r)} | "
                f"{sum(reused)} |"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

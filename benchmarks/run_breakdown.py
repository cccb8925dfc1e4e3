"""Probe: where one run's time went, by stream and outcome, with a sampler setting changed.

    .venv/bin/python benchmarks/run_breakdown.py --scene kitchen-8 --seed 1003 \\
        --planner learned --budget 200 --field ik_attempts --value 96

Runs one trial in this process (``SamplerConfig.FIELD`` set to ``VALUE`` when given) and prints
its status, planning and execution seconds, the queries of each stream by outcome with the
seconds they took, and the five commonest failure reasons. ``--db FILE`` also records the run
(events and queries) in that store, for queries such as which block's streams were asked:
``sqlite3 FILE "select stream, json_extract(inputs, '$[0]'), success, count(*) from
stream_queries group by 1, 2, 3 order by 4 desc"``. A run that times out makes as many queries
as the machine's pace allows within the budget.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections import Counter

from planner.api import solve
from planner.runs import PLANNERS, RunConfig


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", default="kitchen-8")
    parser.add_argument("--seed", type=int, default=1003)
    parser.add_argument("--planner", default="learned", choices=PLANNERS)
    parser.add_argument("--budget", type=float, default=200.0)
    parser.add_argument("--field", help="a SamplerConfig field to set")
    parser.add_argument("--value", help="its value")
    parser.add_argument("--db", help="also record the run in this store (SQLite file)")
    args = parser.parse_args()
    if (args.field is None) != (args.value is None):
        parser.error("--field and --value go together")
    logging.basicConfig(level=logging.WARNING)
    loaded = None
    if args.field is not None:
        from planner.domains import load_domain
        from planner.domains.kitchen import with_samplers
        from planner.domains.kitchen.samplers import SamplerConfig

        try:
            config = SamplerConfig().with_text(args.field, args.value)
        except ValueError as exc:
            parser.error(f"--field {args.field!r} --value {args.value!r}: {exc}")
        loaded = with_samplers(load_domain("kitchen"), config)
    config_run = RunConfig(
        scene=args.scene, seed=args.seed, planner=args.planner, budget_s=args.budget
    )
    if args.db is None:
        result = solve(config_run, loaded=loaded).result
    else:
        from planner.store import RunStore, StoreSink

        store = RunStore(args.db)
        run_id = store.create_run(args.scene, args.seed, args.planner, {"budget_s": args.budget})
        sink = StoreSink(store, run_id)
        try:
            result = solve(config_run, loaded=loaded, sink=sink, run_id=run_id).result
        finally:
            sink.close()
            store.close()
        print(f"recorded as run {run_id} in {args.db}")
    execution = "-" if result.execution_s is None else f"{result.execution_s:.1f} s"
    print(
        f"{args.scene} seed {args.seed} {args.planner}: {result.status}, planning "
        f"{result.planning_s:.1f} s, execution {execution}"
    )
    counts: Counter[tuple[str, bool]] = Counter()
    seconds: Counter[tuple[str, bool]] = Counter()
    for q in result.queries:
        counts[(q.stream, q.success)] += 1
        seconds[(q.stream, q.success)] += q.wall_s
    for stream, ok in sorted(counts):
        outcome = "succeeded" if ok else "failed"
        n, s = counts[(stream, ok)], seconds[(stream, ok)]
        print(f"  {stream} {outcome}: {n} queries, {s:.1f} s")
    reasons = Counter((q.reason or q.error or "?")[:80] for q in result.queries if not q.success)
    for reason, n in reasons.most_common(5):
        print(f"  {n} x {reason}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: the run store on SQLite against PostgreSQL.

1. Events per second through ``StoreSink`` (default batch size, 200) into a new SQLite file
   (WAL) and into a new PostgreSQL database on a server started for the purpose (tests/postgres.py:
   PostgreSQL's default durability, fsync and synchronous commit on), over 127.0.0.1; backends
   alternate within each repeat, the table shows medians.
2. What recording costs a planning run: the same seeds planned with no store (events kept in a
   list), recording into SQLite and recording into PostgreSQL, each run in a fresh process (as
   a benchmark's trials are), backends interleaved per seed. Reported: the median planning
   seconds of each, and the recording overhead measured inside the run (so it does not drown
   in the run-to-run noise of planning times): the seconds the planner's thread spent handing
   its events to the store, and the CPU seconds the store's writer thread spent writing them
   beside it, each over the planning seconds. Their sum bounds what recording can take from
   the planner: the writer can slow it only by holding the interpreter or a core.

    .venv/bin/python benchmarks/store_backends.py --events 50000 --repeats 3 \\
        --scene kitchen-1 --seeds 0-3
"""

from __future__ import annotations

import argparse
import logging
import multiprocessing
import os
import platform
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

from _common import parse_seeds  # noqa: E402
from store_throughput import measure_into, synthetic_events  # noqa: E402

from planner.events import ListSink  # noqa: E402
from tests.postgres import postgres_server  # noqa: E402

log = logging.getLogger("store_backends")
BACKENDS = ("none", "sqlite", "postgresql")


@dataclass(frozen=True)
class Planned:
    backend: str
    seed: int
    status: str
    planning_s: float
    record_s: float  # seconds handing events to the store (0 without one)
    writer_s: float  # CPU seconds of the store's writer thread, beside the planner
    events: int


def _plan(scene: str, seed: int, planner: str, budget_s: float, backend: str, db: str) -> Planned:
    """One planning run in this (fresh) process, recorded into ``db`` unless ``none``."""
    from planner.api import solve
    from planner.runs import RunConfig, preload_libraries, record_run
    from planner.store import RunStore

    config = RunConfig(scene=scene, seed=seed, planner=planner, budget_s=budget_s)
    preload_libraries(config)
    if backend == "none":
        sink = ListSink()
        result = solve(config, sink=sink).result
        return Planned(backend, seed, result.status, result.planning_s, 0.0, 0.0, len(sink.events))
    with RunStore(db) as store:
        run_id = store.create_run(scene, seed, planner, {})
        recorded = record_run(config, store, run_id)
        events = store.last_seq(run_id) + 1
    result = recorded.result
    return Planned(
        backend,
        seed,
        recorded.status,
        result.planning_s,
        recorded.record_s,
        recorded.writer_cpu_s,
        events,
    )


def _plan_in_process(args: tuple[str, int, str, float, str, str]) -> Planned:
    logging.basicConfig(level=logging.WARNING)
    return _plan(*args)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=50_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--batch-size", type=int, default=200)
    parser.add_argument("--scene", default="kitchen-1")
    parser.add_argument("--planner", default="baseline")
    parser.add_argument("--seeds", default="0-3", help="a range, e.g. 0-3")
    parser.add_argument("--budget", type=float, default=120.0)
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    for noisy in ("alembic", "planner.store.schema", "planner.store.migrations"):
        logging.getLogger(noisy).setLevel(logging.WARNING)

    events = synthetic_events("0" * 32, args.events)
    rates: dict[str, list[float]] = {"sqlite": [], "postgresql": []}
    planned: list[Planned] = []
    with tempfile.TemporaryDirectory() as tmp, postgres_server(durable=True) as server:
        for repeat in range(args.repeats):
            order = ["sqlite", "postgresql"][:: 1 if repeat % 2 == 0 else -1]
            for backend in order:
                db = (
                    str(Path(tmp) / f"events-{repeat}.db")
                    if backend == "sqlite"
                    else server.new_database("events")
                )
                seconds = measure_into(db, events, args.batch_size)
                rates[backend].append(args.events / seconds)
                log.info("events, repeat %d, %s: %.2f s", repeat + 1, backend, seconds)

        ctx = multiprocessing.get_context("spawn")
        for i, seed in enumerate(parse_seeds(args.seeds)):
            order = BACKENDS if i % 2 == 0 else BACKENDS[::-1]
            for backend in order:
                db = (
                    str(Path(tmp) / "plan.db")
                    if backend == "sqlite"
                    else server.new_database("plan")
                )
                job = (args.scene, seed, args.planner, args.budget, backend, db)
                with ctx.Pool(1) as pool:  # a fresh process per run
                    run = pool.apply(_plan_in_process, (job,))
                planned.append(run)
                log.info(
                    "seed %d, %s: %s, planning %.2f s, recording %.4f s, writer %.4f s, %d events",
                    seed,
                    backend,
                    run.status,
                    run.planning_s,
                    run.record_s,
                    run.writer_s,
                    run.events,
                )

    print(
        f"Python {platform.python_version()}, {platform.machine()}, {os.cpu_count()} cores, "
        f"{time.strftime('%Y-%m-%d')}\n"
    )
    print(f"Events into the store, {args.events} events, batch {args.batch_size}, medians:\n")
    print("| backend | events/s | us per event |")
    print("|---|---|---|")
    for backend, values in rates.items():
        rate = statistics.median(values)
        print(f"| {backend} | {rate:,.0f} | {1e6 / rate:.1f} |")
    print(f"\nPlanning runs: {args.scene}, {args.planner}, seeds {args.seeds}:\n")
    print(
        "| store | solved | planning s (median) | events (median) | recording / planning "
        "| writer thread CPU / planning | at most |"
    )
    print("|---|---|---|---|---|---|---|")
    for backend in BACKENDS:
        mine = [p for p in planned if p.backend == backend]
        solved = sum(p.status == "solved" for p in mine)
        planning = sum(p.planning_s for p in mine)
        shares = [
            sum(p.record_s for p in mine) / planning,
            sum(p.writer_s for p in mine) / planning,
        ]
        shares.append(sum(shares))
        cells = " | ".join("-" if backend == "none" else f"{100 * x:.3f}%" for x in shares)
        print(
            f"| {backend} | {solved}/{len(mine)} | "
            f"{statistics.median(p.planning_s for p in mine):.2f} | "
            f"{statistics.median(p.events for p in mine):.0f} | {cells} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())

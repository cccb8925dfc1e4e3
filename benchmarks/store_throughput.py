"""Benchmark: events per second the run store absorbs through StoreSink, per batch size.

Builds a synthetic search's events (NodeAdded, StreamQueried, NodeVisited in turn), then times
``StoreSink.emit`` for each plus the final ``close()`` into a fresh SQLite file (WAL) per
measurement. Batch sizes alternate within each repeat so machine noise hits all alike; the
table reports the median. Building the events (what the planner's Emitter does) is timed apart.

    .venv/bin/python benchmarks/store_throughput.py --events 50000 --repeats 3
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

from planner.events import (
    Emitter,
    Event,
    ListSink,
    NodeAdded,
    NodeVisited,
    StreamQueried,
)
from planner.store import RunStore, StoreSink

RUN_ID = "0" * 32  # replaced by the store's id before writing


def synthetic_events(run_id: str, n: int) -> list[Event]:
    """``n`` events of a plausible search: a node, the query that made it, a back-up."""
    sink = ListSink()
    emitter = Emitter(run_id, sink)
    for i in range(n):
        node = i // 3 + 1
        match i % 3:
            case 0:
                emitter.emit(
                    NodeAdded,
                    node_id=node,
                    parent_id=node - 1,
                    plan_index=node % 10,
                    depth=node % 6 + 1,
                    stream="sample-grasp",
                    success=node % 4 != 0,
                    outputs=[f"#g{node}"],
                    label=f"sample-grasp #g{node}",
                )
            case 1:
                emitter.emit(
                    StreamQueried,
                    node_id=node,
                    stream="plan-base-motion" if node % 2 else "sample-grasp",
                    input_names=["?b", "?q1", "?q2"],
                    inputs=[f"b{node % 8}", [0.5, -1.25, 0.0], [1.0, 2.0, 3.14159]],
                    success=node % 4 != 0,
                    wall_s=0.0123,
                    cpu_s=0.0119,
                    execution_s=2.5 if node % 2 else 0.0,
                    error=None if node % 4 else "no sample",
                )
            case _:
                emitter.emit(NodeVisited, node_id=node, visits=node % 17 + 1, value=-12.5)
    return sink.events


def with_run_id(events: list[Event], run_id: str) -> list[Event]:
    return [dataclasses.replace(e, run_id=run_id) for e in events]


def measure(events: list[Event], batch_size: int, directory: Path) -> float:
    """Seconds to push ``events`` through a StoreSink into a new SQLite file, close included."""
    return measure_into(
        directory / f"runs-{batch_size}-{time.monotonic_ns()}.db", events, batch_size
    )


def measure_into(db: str | Path, events: list[Event], batch_size: int) -> float:
    """Seconds to push ``events`` through a StoreSink into a new run of the store ``db``
    (a path or a URL), close included."""
    with RunStore(db) as store:
        run_id = store.create_run("kitchen-8", 0, "benchmark", {"batch_size": batch_size})
        ours = with_run_id(events, run_id)
        sink = StoreSink(store, run_id, batch_size=batch_size)
        start = time.perf_counter()
        for event in ours:
            sink.emit(event)
        sink.close()
        seconds = time.perf_counter() - start
        stored = store.last_seq(run_id) + 1
    if stored != len(events):
        raise RuntimeError(f"{stored} of {len(events)} events stored")
    return seconds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=50_000)
    parser.add_argument("--batch-sizes", default="1,50,200,1000")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    sizes = [int(s) for s in args.batch_sizes.split(",")]

    start = time.perf_counter()
    events = synthetic_events(RUN_ID, args.events)
    build_s = time.perf_counter() - start

    seconds: dict[int, list[float]] = {b: [] for b in sizes}
    with tempfile.TemporaryDirectory() as tmp:
        for repeat in range(args.repeats):
            order = sizes if repeat % 2 == 0 else sizes[::-1]
            for b in order:
                seconds[b].append(measure(events, b, Path(tmp)))
                print(f"repeat {repeat + 1}, batch {b}: {seconds[b][-1]:.2f} s", file=sys.stderr)

    print(
        f"{args.events} events, {args.repeats} repeats, Python {platform.python_version()}, "
        f"{platform.machine()}, {os.cpu_count()} cores"
    )
    print(f"building the events (Emitter + checks): {args.events / build_s:,.0f} events/s\n")
    print("| batch size | median s | events/s | us per event | transactions |")
    print("|---|---|---|---|---|")
    for b in sizes:
        med = statistics.median(seconds[b])
        print(
            f"| {b} | {med:.2f} | {args.events / med:,.0f} | {med / args.events * 1e6:.1f} "
            f"| {-(-args.events // b):,} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())

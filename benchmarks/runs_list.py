"""Benchmark: ``GET /api/runs`` latency with many requests at once, on a store of many runs.

Fills a fresh SQLite store with ``--runs`` finished runs (the config a dashboard launch stores,
mixed statuses and scenes), starts a real ``tamp serve --no-viewer`` on it, opens
``--concurrency`` keep-alive connections, then sends ``--rounds`` rounds of one request per
connection at the same instant (the page's own query: ``?limit=50``, and every fifth request a
status filter) and times each from its first byte written to its last byte read. Meanwhile a
writer commits a batch of events to a live run ``--writes-per-s`` times a second, as a planning
run's store sink does, so pages are read again after each change, as they are while a run
plans. The client is a minimal asyncio HTTP/1.1 client in this process, so the timing is the
server's share and not an HTTP library's.

    .venv/bin/python benchmarks/runs_list.py --runs 10000 --concurrency 200 --rounds 20

Prints one markdown row for docs/BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import multiprocessing
import os
import random
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from dataclasses import asdict
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

from sqlalchemy import insert

from planner.events import NodeVisited, RunStarted
from planner.runs import RunConfig
from planner.store import RunStore
from planner.store.db import RunRow

STATUSES = ("solved", "solved", "solved", "timeout", "failed", "cancelled", "interrupted")
SCENES = ("kitchen-1", "kitchen-2", "kitchen-4", "kitchen-6", "kitchen-8", "line-2")
PLANNERS = ("baseline", "learned", "sequential")


def fill(store: RunStore, n: int, seed: int = 0) -> None:
    """``n`` finished runs, as a dashboard that has been used for a long time holds them."""
    rng = random.Random(seed)
    start = datetime.now(UTC) - timedelta(days=60)
    rows = []
    for i in range(n):
        scene, planner = rng.choice(SCENES), rng.choice(PLANNERS)
        config = asdict(RunConfig(scene=scene, seed=i, planner=planner, k=50, budget_s=120.0))
        status = rng.choice(STATUSES)
        created = start + timedelta(seconds=i * 500)
        rows.append(
            {
                "id": f"{i:032x}",
                "scene": scene,
                "seed": i,
                "planner": planner,
                "config": json.dumps(config),
                "status": status,
                "created_at": created,
                "finished_at": created + timedelta(seconds=rng.uniform(5, 300)),
                "planning_s": rng.uniform(1, 200) if status == "solved" else None,
                "execution_s": rng.uniform(10, 90) if status == "solved" else None,
                "oracle_s": rng.uniform(1, 50) if status == "solved" else None,
                "queries": rng.randint(0, 2000),
                "message": "solved" if status == "solved" else f"no plan ({status})",
                "plan": None,
            }
        )
    with store.engine.begin() as conn:
        for i in range(0, n, 1000):
            conn.execute(insert(RunRow), rows[i : i + 1000])


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def start_server(db: Path, log: Path) -> tuple[subprocess.Popen[bytes], int]:
    port = _free_port()
    tamp = Path(sys.executable).with_name("tamp")
    command = [str(tamp), "serve", "--no-viewer", "--port", str(port), "--db", str(db)]
    with log.open("wb") as out:
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 60
    while True:
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=2).close()
            return process, port
        except OSError:
            if process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"tamp serve did not start:\n{log.read_text()}") from None
            time.sleep(0.1)


class Connection:
    """One keep-alive HTTP/1.1 connection that sends GETs and reads whole responses."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader = reader
        self.writer = writer

    @classmethod
    async def open(cls, port: int) -> Connection:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        return cls(reader, writer)

    async def get(self, path: str, port: int) -> tuple[float, int, int]:
        """(seconds, status, body bytes); a connection the server closed while idle (its
        keep-alive timeout) is opened again, outside the timing."""
        try:
            return await self._get(path, port)
        except (asyncio.IncompleteReadError, ConnectionError):
            self.writer.close()
            self.reader, self.writer = await asyncio.open_connection("127.0.0.1", port)
            return await self._get(path, port)

    async def _get(self, path: str, port: int) -> tuple[float, int, int]:
        request = f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode()
        start = time.perf_counter()
        self.writer.write(request)
        head = await self.reader.readuntil(b"\r\n\r\n")
        status = int(head.split(b" ", 2)[1])
        length = 0
        for line in head.split(b"\r\n")[1:]:
            name, _, value = line.partition(b":")
            if name.strip().lower() == b"content-length":
                length = int(value)
        await self.reader.readexactly(length)
        return time.perf_counter() - start, status, length

    def close(self) -> None:
        self.writer.close()


async def measure(
    port: int, concurrency: int, rounds: int, limit: int
) -> tuple[list[float], list[float]]:
    """Latencies of every request in every round, and each round's wall time."""
    connections = await asyncio.gather(*(Connection.open(port) for _ in range(concurrency)))
    paths = [f"/api/runs?limit={limit}"] * 4 + [f"/api/runs?limit={limit}&status=solved"]
    for c in connections:  # warm: every connection has served one request
        await c.get(paths[0], port)
    latencies: list[float] = []
    walls: list[float] = []
    for _ in range(rounds):
        start = time.perf_counter()
        results = await asyncio.gather(
            *(c.get(paths[i % len(paths)], port) for i, c in enumerate(connections))
        )
        walls.append(time.perf_counter() - start)
        for seconds, status, size in results:
            if status != 200 or size < 100:
                raise RuntimeError(f"GET /api/runs answered {status} with {size} bytes")
            latencies.append(seconds)
        await asyncio.sleep(0.25)
    for c in connections:
        c.close()
    return latencies, walls


def writer(db: Path, per_s: float, stop: Any) -> int:
    """Commit a small batch of events to a live run ``per_s`` times a second."""
    if per_s <= 0:
        return 0
    with RunStore(db) as store:
        run_id = store.create_run("kitchen-4", 0, "baseline", {})
        store.write_events(
            run_id, [RunStarted(run_id, 0, 0.0, scene="kitchen-4", seed=0, planner="b", config={})]
        )
        seq = 1
        while not stop.wait(1.0 / per_s):
            batch = [
                NodeVisited(run_id, seq + i, seq * 0.01, node_id=1, visits=seq + i, value=-1.0)
                for i in range(20)
            ]
            store.write_events(run_id, batch)
            seq += len(batch)
    return seq


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000)
    parser.add_argument("--concurrency", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=20)
    parser.add_argument("--writes-per-s", type=float, default=2.0)
    parser.add_argument("--limit", type=int, default=50, help="runs per page (the page asks 50)")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory(prefix="tamp-runs-list-") as tmp:
        db = Path(tmp) / "runs.db"
        with RunStore(db) as store:
            fill(store, args.runs)
            assert store.count_runs() == args.runs
        process, port = start_server(db, Path(tmp) / "serve.log")
        stop = multiprocessing.get_context("spawn").Event()
        write = multiprocessing.get_context("spawn").Process(
            target=writer, args=(db, args.writes_per_s, stop), daemon=True
        )  # its own process, so it never holds this client's GIL
        try:
            single = [asyncio.run(_one(port)) for _ in range(20)]  # one at a time, for scale
            write.start()
            cpu = _cpu_seconds(process.pid)
            latencies, walls = asyncio.run(measure(port, args.concurrency, args.rounds, args.limit))
            cpu = _cpu_seconds(process.pid) - cpu
        finally:
            stop.set()
            write.join(timeout=10)
            process.terminate()
            process.wait(timeout=30)
    load = os.getloadavg()[0]
    ms = [x * 1000 for x in latencies]
    print(
        f"| {args.runs} | {args.concurrency} | {args.rounds} | {args.writes_per_s:g} | "
        f"{statistics.median(ms):.0f} | {percentile(ms, 0.95):.0f} | {percentile(ms, 0.99):.0f} | "
        f"{max(ms):.0f} | {statistics.median(single) * 1000:.1f} | "
        f"{statistics.median(walls) * 1000:.0f} | {cpu / len(latencies) * 1000:.2f} | {load:.1f} |"
    )
    return 0


def _cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` so far (Linux)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


async def _one(port: int) -> float:
    connection = await Connection.open(port)
    try:
        seconds, _, _ = await connection.get("/api/runs?limit=50", port)
        return seconds
    finally:
        connection.close()


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: many readers of a big run's event pages at once, and the rest of the server.

Records the run of ``open_run.py`` (``--nodes`` nodes of ``page_render.Synth``: 21,600 make
about 100,000 events, 30 MB of JSON) into a fresh SQLite store, starts a real ``tamp serve
--no-viewer`` on it, then ``--readers`` clients at once each read ``--pages`` pages of
``GET /api/runs/{id}/events?limit=5000`` (random pages of the run; each on its own connection,
every byte read). Meanwhile one prober asks ``GET /api/health`` and another ``GET /api/runs``
every ``--probe-ms`` ms on a kept-alive connection, as a page asks (``--fresh-probes``: a new
connection each time), each timed from the request to the last byte, and the server's
resident memory (``/proc/PID/status`` VmRSS) is sampled every 100 ms, from before the readers
until ``--settle`` seconds after the last reader is done.

Targets (issue 54): the health check answers within 0.5 s throughout, no reader gets a 5xx
(or an error of any kind), and the server's memory comes back within 20% of its size before
the readers.

    .venv/bin/python benchmarks/event_readers.py --readers 200 --pages 1
"""

from __future__ import annotations

import argparse
import http.client
import os
import platform
import random
import shlex
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path
from urllib.parse import urlsplit

from open_run import record
from page_render import percentile, start_server

HEALTH_TARGET_S = 0.5
MEMORY_TARGET = 0.20  # back within this share of the size before the readers
PAGE = 5000


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def get(host: str, port: int, path: str, timeout: float = 600.0) -> tuple[int, int]:
    """(status, bytes read) of one GET on a fresh connection."""
    conn = http.client.HTTPConnection(host, port, timeout=timeout)
    try:
        conn.request("GET", path)
        answer = conn.getresponse()
        size = 0
        while chunk := answer.read(1 << 16):
            size += len(chunk)
        return answer.status, size
    finally:
        conn.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=21_600, help="tree nodes to synthesise")
    parser.add_argument("--readers", type=int, default=200, help="clients reading at once")
    parser.add_argument("--pages", type=int, default=1, help="pages each reader reads")
    parser.add_argument("--probe-ms", type=float, default=100.0, help="between probes")
    parser.add_argument("--settle", type=float, default=10.0, help="seconds watched after")
    parser.add_argument("--fresh-probes", action="store_true", help="a connection per probe")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        run_id, n_events, size = record(Path(tmp) / "runs.db", args.nodes, args.seed)
        server, url = start_server(Path(tmp))
        parts = urlsplit(url)
        host, port = parts.hostname or "127.0.0.1", parts.port or 80
        try:
            for _ in range(3):  # warm: the first reads of the file, the routes' first calls
                get(host, port, f"/api/runs/{run_id}/events?after=-1&limit={PAGE}")
                get(host, port, "/api/runs")
            time.sleep(2.0)
            before = rss_mb(server.pid)
            stop = threading.Event()
            probes: dict[str, list[tuple[float, float, int]]] = {"health": [], "runs": []}
            memory: list[tuple[float, float]] = []
            t0 = time.perf_counter()

            def probe(name: str, path: str) -> None:
                """Ask again and again on one kept-alive connection, as a page does (with
                --fresh-probes, a new connection each time, which waits behind the readers'
                in the server's accept queue)."""
                conn: http.client.HTTPConnection | None = None
                while not stop.is_set():
                    start = time.perf_counter()
                    try:
                        if args.fresh_probes:
                            status, _ = get(host, port, path, timeout=120)
                        else:
                            if conn is None:
                                conn = http.client.HTTPConnection(host, port, timeout=120)
                            conn.request("GET", path)
                            answer = conn.getresponse()
                            answer.read()
                            status = answer.status
                    except (OSError, http.client.HTTPException):
                        status, conn = -1, None
                    probes[name].append((start - t0, time.perf_counter() - start, status))
                    stop.wait(args.probe_ms / 1000)

            def watch() -> None:
                while not stop.is_set():
                    memory.append((time.perf_counter() - t0, rss_mb(server.pid)))
                    stop.wait(0.1)

            rng = random.Random(args.seed)
            pages_of_run = (n_events + PAGE - 1) // PAGE
            results: list[tuple[int, int, float]] = []
            lock = threading.Lock()
            gate = threading.Barrier(args.readers)

            def reader(i: int) -> None:
                mine = [rng.randrange(pages_of_run) for _ in range(args.pages)]
                gate.wait()  # all at once
                for k in mine:
                    start = time.perf_counter()
                    try:
                        path = f"/api/runs/{run_id}/events?after={k * PAGE - 1}&limit={PAGE}"
                        status, got = get(host, port, path)
                    except OSError:
                        status, got = -1, 0
                    with lock:
                        results.append((status, got, time.perf_counter() - start))

            helpers = [
                threading.Thread(target=probe, args=("health", "/api/health")),
                threading.Thread(target=probe, args=("runs", "/api/runs")),
                threading.Thread(target=watch),
            ]
            for h in helpers:
                h.start()
            time.sleep(1.0)
            readers = [threading.Thread(target=reader, args=(i,)) for i in range(args.readers)]
            started = time.perf_counter() - t0
            for r in readers:
                r.start()
            for r in readers:
                r.join()
            ended = time.perf_counter() - t0
            time.sleep(args.settle)
            stop.set()
            for h in helpers:
                h.join()
            after = rss_mb(server.pid)
        finally:
            server.terminate()
            server.wait(10)

    during = [p for p in probes["health"] if started <= p[0] <= ended]
    runs_during = [p for p in probes["runs"] if started <= p[0] <= ended]
    statuses: dict[int, int] = {}
    for status, _, _ in results:
        statuses[status] = statuses.get(status, 0) + 1
    worst_health = max((p[1] for p in during), default=float("nan"))
    worst_at = next((p[0] - started for p in during if p[1] == worst_health), float("nan"))
    peak = max(m for _, m in memory)
    back = (after - before) / before
    print(
        f"{n_events:,} events ({size / 1e6:.1f} MB of JSON); {args.readers} readers x "
        f"{args.pages} page(s) of {PAGE:,} events, at once; {platform.machine()}, "
        f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}\n"
    )
    print(
        f"readers done in {ended - started:.1f} s; answers by status: "
        f"{dict(sorted(statuses.items()))}"
    )
    print(
        f"bytes per page: median {statistics.median(r[1] for r in results) / 1e6:.2f} MB; "
        f"a page's seconds: median {statistics.median(r[2] for r in results):.2f}, "
        f"p95 {percentile([r[2] for r in results], 0.95):.2f}, max {max(r[2] for r in results):.2f}"
    )
    print("\n| measurement | value | target |")
    print("|---|---|---|")
    ok = worst_health < HEALTH_TARGET_S
    print(
        f"| GET /api/health while they read: {len(during)} probes, median / p95 / max s | "
        f"{statistics.median(p[1] for p in during):.3f} / "
        f"{percentile([p[1] for p in during], 0.95):.3f} / {worst_health:.3f} | "
        f"< {HEALTH_TARGET_S} s {'ok' if ok else 'MISSED'} |"
    )
    print(
        f"| the slowest health check, asked at (s after the readers started) | {worst_at:.1f} | |"
    )
    print(
        f"| GET /api/runs while they read: {len(runs_during)} probes, median / max s | "
        f"{statistics.median(p[1] for p in runs_during):.3f} / "
        f"{max(p[1] for p in runs_during):.3f} | |"
    )
    errors = sum(n for s, n in statuses.items() if s != 200)
    print(f"| readers answered other than 200 | {errors} | 0 {'ok' if errors == 0 else 'MISSED'} |")
    print(
        f"| server memory MB: before / peak / {args.settle:.0f} s after | {before:.0f} / "
        f"{peak:.0f} / {after:.0f} ({100 * back:+.0f}%) | within 20% "
        f"{'ok' if abs(back) <= MEMORY_TARGET else 'MISSED'} |"
    )
    print(f"\n    {shlex.join([Path(sys.executable).name, *sys.argv])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

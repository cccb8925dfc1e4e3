"""Dashboard streaming: events per second to a websocket client, and the planner's slowdown with
two clients attached versus none (paired runs, same seeds, alternating order).

    .venv/bin/python benchmarks/dashboard_stream.py --events 20000 --scene kitchen-2 --seeds 0-5

Prints a markdown table for docs/BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import json
import socket
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import httpx
import uvicorn
from _common import parse_seeds
from websockets.sync.client import connect

from app.main import create_app
from app.settings import Settings
from planner.store import RunStore


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Server:
    def __init__(self, db: Path) -> None:
        self.port = _free_port()
        self.app = create_app(
            Settings(database_url=str(db), viewer=False, port=self.port, max_running=1)
        )
        config = uvicorn.Config(self.app, host="127.0.0.1", port=self.port, log_level="warning")
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(target=self.server.run, daemon=True)
        self.thread.start()
        while not self.server.started:
            time.sleep(0.05)
        self.base = f"http://127.0.0.1:{self.port}"
        self.ws = f"ws://127.0.0.1:{self.port}"

    def close(self) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=30)


def _synthetic(run_id: str, n: int) -> list[dict[str, Any]]:
    """A realistic mix: each query a stream_queried + node_added + node_visited."""
    events: list[dict[str, Any]] = []
    seq = 0
    while len(events) < n:
        node = seq // 3 + 1
        events.append(
            {
                "type": "stream_queried",
                "run_id": run_id,
                "seq": seq,
                "t": seq * 1e-3,
                "node_id": node,
                "stream": "sample-placement",
                "input_names": ["b1", "stove"],
                "inputs": ["b1", "stove"],
                "success": True,
                "wall_s": 0.01,
                "cpu_s": 0.01,
                "execution_s": 0.0,
                "error": None,
                "context": {"facts": [["on", "b1", "table"]], "values": {}},
            }
        )
        events.append(
            {
                "type": "node_added",
                "run_id": run_id,
                "seq": seq + 1,
                "t": seq * 1e-3,
                "node_id": node,
                "parent_id": max(node - 1, 0),
                "plan_index": 0,
                "depth": 1,
                "stream": "sample-placement",
                "success": True,
                "outputs": [{"type": "pose", "x": 1.0, "y": 0.2, "z": 0.8, "yaw": 0.1}],
                "label": "sample-placement(b1 stove) -> opt-p1",
                "output_names": ["opt-p1"],
            }
        )
        events.append(
            {
                "type": "node_visited",
                "run_id": run_id,
                "seq": seq + 2,
                "t": seq * 1e-3,
                "node_id": node,
                "visits": 1,
                "value": -1.0,
            }
        )
        seq += 3
    return events[:n]


def delivery(server: Server, n: int) -> dict[str, float]:
    """Events per second from the hub to one websocket client (the server's share of the path)."""
    dash = server.app.state.dashboard
    run_id = dash.store.create_run("kitchen-2", 0, "baseline", {}, status="queued")
    dash.hub.open(run_id)
    events = _synthetic(run_id, n)
    received = 0
    ready = threading.Event()
    done = threading.Event()
    timing: dict[str, float] = {}

    def client() -> None:
        nonlocal received
        with connect(f"{server.ws}/api/runs/{run_id}/stream", max_size=None) as ws:
            for message in ws:
                data = json.loads(message)
                if data["type"] == "control":
                    if data["kind"] == "caught_up":
                        ready.set()
                    elif data["kind"] == "end":
                        timing["end"] = time.perf_counter()
                        break
                    continue
                if received == 0:
                    timing["first"] = time.perf_counter()
                received += 1
        done.set()

    thread = threading.Thread(target=client)
    thread.start()
    ready.wait(10)
    start = time.perf_counter()
    for i in range(0, n, 100):  # batches as a worker sends them
        dash.hub.publish(run_id, events[i : i + 100])
    published = time.perf_counter() - start
    dash.store.finish_run(run_id, "solved")
    dash.hub.end(run_id, "solved")
    done.wait(120)
    thread.join()
    elapsed = timing["end"] - start
    return {"events": received, "seconds": elapsed, "per_s": received / elapsed, "pub_s": published}


def _wait(client: httpx.Client, run_id: str) -> dict[str, Any]:
    while True:
        run: dict[str, Any] = client.get(f"/api/runs/{run_id}").json()
        if run["status"] not in ("queued", "running"):
            return run
        time.sleep(0.2)


def slowdown(server: Server, scene: str, seeds: list[int], budget: float) -> list[dict[str, Any]]:
    rows = []
    with httpx.Client(base_url=server.base, timeout=30) as client:
        for i, seed in enumerate(seeds):
            order = ("none", "two") if i % 2 == 0 else ("two", "none")
            result: dict[str, Any] = {"seed": seed}
            for mode in order:
                body = {"scene": scene, "seed": seed, "budget_s": budget}
                run = client.post("/api/runs", json=body).json()
                threads = []
                if mode == "two":
                    for _ in range(2):
                        t = threading.Thread(target=_drain, args=(server, run["id"]), daemon=True)
                        t.start()
                        threads.append(t)
                finished = _wait(client, run["id"])
                for t in threads:
                    t.join(timeout=30)
                result[mode] = finished["planning_s"]
                result[f"{mode}_status"] = finished["status"]
            rows.append(result)
            print(f"seed {seed}: {result}", file=sys.stderr)
    return rows


def _drain(server: Server, run_id: str) -> None:
    with connect(f"{server.ws}/api/runs/{run_id}/stream", max_size=None) as ws:
        for message in ws:
            data = json.loads(message)
            if data["type"] == "control" and data["kind"] == "end":
                return


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--events", type=int, default=20_000)
    parser.add_argument("--scene", default="kitchen-2")
    parser.add_argument("--seeds", default="0-5")
    parser.add_argument("--budget", type=float, default=120.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        server = Server(Path(tmp) / "runs.db")
        try:
            d = delivery(server, args.events)
            rows = slowdown(server, args.scene, parse_seeds(args.seeds), args.budget)
        finally:
            server.close()
        RunStore(Path(tmp) / "runs.db").close()
    ratios = [r["two"] / r["none"] for r in rows if r["two"] and r["none"]]
    print(f"command: {' '.join(sys.argv)}")
    print("| measure | value |")
    print("| --- | --- |")
    print(
        f"| events delivered to one websocket client | {d['events']:.0f} in {d['seconds']:.2f} s "
        f"= {d['per_s']:,.0f} events/s |"
    )
    print(
        f"| planning s, two clients / none ({args.scene}, {len(ratios)} paired seeds) | median "
        f"{statistics.median(ratios):.3f}, mean {statistics.mean(ratios):.3f} |"
    )
    for r in rows:
        print(f"|   seed {r['seed']} | none {r['none']:.2f} s, two {r['two']:.2f} s |")


if __name__ == "__main__":
    main()

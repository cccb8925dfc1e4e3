"""Benchmark: how fast the dashboard page shows a 20,000-node search tree and steps through it.

Synthesises a plausible learned-planner run in the kitchen (k stream plans of 8-16 streams;
an MCTS-like loop that re-queries nodes, simulates until a stream fails, backs values up and
predicts Q for every new node) as the JSON events of planner/events.py: run_started,
abstract_plans_found, then node_added, stream_queried, model_prediction and node_visited until
the tree has ``--nodes`` nodes, then solution_found and run_finished. It starts ``tamp serve``
(temporary database, no viewer) to serve the page, hands the events to the page on the same
origin, and times the page's test hook in headless Chromium:

- ``window.dashboard.loadEvents(events)``: fold every event, lay out and draw the whole tree
  (target < 2 s), and the same until the next animation frame has been painted;
- ``window.dashboard.step(k)``: one event forward and one event back from random steps
  (target < 50 ms each), and random jumps.

    .venv/bin/python benchmarks/page_render.py --nodes 20000 --steps 300 --repeats 5
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import shlex
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from typing import Any

from playwright.sync_api import Page, Route, sync_playwright

from app.browser import CHROMIUM_ARGS, require_chromium

ROOT = Path(__file__).resolve().parent.parent
EVENTS_PATH = "/bench/events.json"  # answered by the benchmark itself, on the page's origin
LOAD_TARGET_MS = 2000.0
STEP_TARGET_MS = 50.0

# Kitchen streams: (name, inputs, outputs, failure probability, mean wall seconds)
STREAMS = (
    ("sample-grasp", ["b"], ["g"], 0.02, 0.0001),
    ("inverse-kinematics", ["b", "p", "g"], ["q"], 0.35, 0.004),
    ("plan-motion", ["q1", "q2"], ["t"], 0.25, 0.9),
    ("sample-placement", ["b", "r"], ["p"], 0.1, 0.0001),
)


class Synth:
    """Builds the events of one run; node ids and seq numbers count up from 0 and 1."""

    def __init__(self, nodes: int, seed: int, plans: int = 50) -> None:
        self.rng = random.Random(seed)
        self.target = nodes
        self.events: list[dict[str, Any]] = []
        self.run_id = "bench" + "0" * 27
        self.t = 0.0
        self.plans = [
            [self.rng.choice(STREAMS) for _ in range(self.rng.randint(8, 16))] for _ in range(plans)
        ]
        self.parent: dict[int, int] = {}
        self.children: dict[int, list[int]] = {0: []}
        self.depth: dict[int, int] = {}
        self.plan_of: dict[int, int] = {}
        self.visits: dict[int, int] = {}
        self.ok: dict[int, bool] = {}
        self.next_id = 1

    def emit(self, kind: str, **fields: Any) -> None:
        self.t += self.rng.expovariate(1 / 0.002)
        seq = len(self.events)
        self.events.append({"type": kind, "run_id": self.run_id, "seq": seq, "t": self.t, **fields})

    def value(self, kind: str) -> Any:
        r = self.rng.random
        if kind in ("g",):
            return {"type": "grasp", "kind": "side", "position": [0, 0, 0.01], "approach": 0.1}
        if kind in ("p",):
            return {"type": "pose", "x": r(), "y": r(), "z": 0.755, "yaw": r() * 3}
        if kind in ("q", "q1", "q2"):
            return {
                "type": "conf",
                "base": [r(), r(), r()],
                "torso": 0.2,
                "arm": [r() for _ in range(7)],
            }
        if kind == "t":
            return {"type": "trajectory", "segments": [{"kind": "base", "base": [[r(), r(), r()]]}]}
        return kind

    def predict(self, node: int) -> None:
        plan = self.plans[self.plan_of[node]]
        rest = plan[self.depth[node] :]
        q = sum(s[4] * 30 + (s[3] / (1 - s[3])) * 2 for s in rest) * self.rng.uniform(0.5, 1.5)
        p_s = 1 - rest[0][3] if rest else 1.0
        self.emit(
            "model_prediction",
            node_id=node,
            p_s=max(min(p_s * self.rng.uniform(0.9, 1.0), 1.0), 0.0),
            r_s=rest[0][4] if rest else 0.0,
            r_f=rest[0][4] * 1.5 if rest else 0.0,
            r_m=5.0 if rest and rest[0][0] == "plan-motion" else 0.0,
            q=q,
        )

    def add(self, parent: int, plan: int, depth: int, ok: bool, stream: Any = None) -> int:
        node = self.next_id
        self.next_id += 1
        self.parent[node] = parent
        self.children[node] = []
        self.children[parent].append(node)
        self.depth[node] = depth
        self.plan_of[node] = plan
        self.ok[node] = ok
        self.visits[node] = 0
        outputs = [self.value(o) for o in stream[2]] if stream and ok else []
        names = [f"opt-{o}{node}" for o in stream[2]] if stream and ok else []
        self.emit(
            "node_added",
            node_id=node,
            parent_id=parent,
            plan_index=plan,
            depth=depth,
            stream=stream[0] if stream else None,
            success=ok,
            outputs=outputs,
            label=(f"{stream[0]}({' '.join(stream[1])})" if stream else f"plan {plan}")
            + ("" if ok else " (failed)"),
            output_names=names,
        )
        return node

    def query(self, node: int) -> int:
        plan = self.plan_of[node]
        stream = self.plans[plan][self.depth[node]]
        ok = self.rng.random() > stream[3]
        wall = self.rng.expovariate(1 / stream[4])
        child = self.next_id
        self.emit(
            "stream_queried",
            node_id=child,
            stream=stream[0],
            input_names=stream[1],
            inputs=[self.value(i) for i in stream[1]],
            success=ok,
            wall_s=wall,
            cpu_s=wall * 0.95,
            execution_s=self.rng.uniform(2, 15) if ok and stream[0] == "plan-motion" else 0.0,
            error=None if ok else "no solution",
            context={"facts": [["at", "b1", "p0-b1"], ["hand-empty"]], "values": {}},
        )
        self.t += wall
        self.add(node, plan, self.depth[node] + 1, ok, stream)
        if ok:
            self.predict(child)
        return child

    def backup(self, leaf: int) -> None:
        node: int | None = leaf
        value = self.depth[leaf] / len(self.plans[self.plan_of[leaf]])
        while node is not None:
            self.visits[node] = self.visits.get(node, 0) + 1
            self.emit("node_visited", node_id=node, visits=self.visits[node], value=value)
            node = self.parent.get(node)

    def build(self) -> list[dict[str, Any]]:
        rng = self.rng
        self.emit("run_started", scene="kitchen-4", seed=0, planner="learned", config={})
        self.emit(
            "abstract_plans_found",
            plans=[
                {
                    "index": i,
                    "cost": float(len(p)),
                    "actions": [f"(act{j})" for j in range(len(p) // 2)],
                    "streams": [f"{s[0]}({' '.join(s[1])})" for s in p],
                }
                for i, p in enumerate(self.plans)
            ],
            seconds=2.1,
        )
        self.depth[0] = 0
        self.visits[0] = 0
        roots = []
        for i in range(len(self.plans)):
            node = self.add(0, i, 0, True)
            self.parent[node] = 0
            roots.append(node)
            self.predict(node)
        weights = [rng.paretovariate(1.2) for _ in roots]
        leaf = roots[0]
        while self.next_id <= self.target:
            node = rng.choices(roots, weights)[0]
            # Selection: walk down through existing successful children, widen sometimes.
            while True:
                kids = [c for c in self.children[node] if self.ok[c]]
                full = self.depth[node] >= len(self.plans[self.plan_of[node]])
                if full or not kids or rng.random() < 1 / (1 + len(self.children[node])):
                    break
                node = rng.choice(kids)
            if self.depth[node] >= len(self.plans[self.plan_of[node]]):
                leaf = node
                self.backup(leaf)
                continue
            leaf = self.query(node)  # expansion, then simulation until a failure or the end
            while self.ok[leaf] and self.depth[leaf] < len(self.plans[self.plan_of[leaf]]):
                if self.next_id > self.target:
                    break
                leaf = self.query(leaf)
            self.backup(leaf)
        self.emit(
            "solution_found",
            node_id=leaf,
            plan_index=self.plan_of[leaf],
            planning_s=self.t,
            execution_s=40.0,
            oracle_s=12.0,
        )
        queries = sum(1 for e in self.events if e["type"] == "stream_queried")
        self.emit(
            "run_finished",
            status="solved",
            planning_s=self.t,
            execution_s=40.0,
            oracle_s=12.0,
            queries=queries,
            message="solved",
        )
        return self.events


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def start_server(directory: Path) -> tuple[subprocess.Popen[bytes], str]:
    port = free_port()
    tamp = Path(sys.executable).with_name("tamp")
    command = [str(tamp), "serve", "--host", "127.0.0.1", "--port", str(port)]
    command += ["--db", str(directory / "runs.db"), "--no-viewer"]
    log = (directory / "serve.log").open("wb")
    server = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, cwd=ROOT)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if server.poll() is not None:
            raise RuntimeError(f"tamp serve exited: {(directory / 'serve.log').read_text()}")
        try:
            with urllib.request.urlopen(f"{url}/api/health", timeout=1):
                return server, url
        except OSError:
            time.sleep(0.2)
    server.terminate()
    raise RuntimeError("tamp serve did not answer /api/health within 60 s")


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def measure(page: Page, repeats: int, steps: int, seed: int) -> dict[str, list[float]]:
    page.evaluate(
        f"""async () => {{
            const r = await fetch("{EVENTS_PATH}");
            window.__benchEvents = await r.json();
        }}"""
    )
    results: dict[str, list[float]] = {"load": [], "load_painted": []}
    for _ in range(repeats):
        hook, painted = page.evaluate(
            """async () => {
                const t0 = performance.now();
                const ms = window.dashboard.loadEvents(window.__benchEvents);
                await new Promise((ok) => requestAnimationFrame(() => setTimeout(ok, 0)));
                return [ms, performance.now() - t0];
            }"""
        )
        results["load"].append(hook)
        results["load_painted"].append(painted)
    timed = page.evaluate(
        """([steps, seed]) => {
            let s = seed + 1;
            const rand = () => ((s = (s * 16807) % 2147483647) / 2147483647);
            const last = window.dashboard.state().last;
            const out = { forward: [], back: [], jump: [] };
            for (let i = 0; i < steps; i++) {
                const k = 1 + Math.floor(rand() * (last - 1));
                out.jump.push(window.dashboard.step(k));
                out.forward.push(window.dashboard.step(k + 1));
                out.back.push(window.dashboard.step(k));
            }
            return out;
        }""",
        [steps, seed],
    )
    results.update(timed)
    return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=20_000, help="tree nodes to synthesise")
    parser.add_argument("--steps", type=int, default=300, help="random steps to time")
    parser.add_argument("--repeats", type=int, default=5, help="loads of the whole tree to time")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--url", help="use this running dashboard instead of starting one")
    parser.add_argument("--screenshot", type=Path, help="save the page with the tree here")
    args = parser.parse_args()

    events = Synth(args.nodes, args.seed).build()
    body = json.dumps(events, separators=(",", ":")).encode()
    counts: dict[str, int] = {}
    for e in events:
        counts[e["type"]] = counts.get(e["type"], 0) + 1

    with tempfile.TemporaryDirectory() as tmp:
        server = None
        url = args.url
        if url is None:
            server, url = start_server(Path(tmp))
        try:
            with sync_playwright() as pw:
                browser = pw.chromium.launch_persistent_context(
                    str(Path(tmp) / "profile"),
                    executable_path=require_chromium(),
                    args=CHROMIUM_ARGS,
                    headless=True,
                    viewport={"width": 1440, "height": 1000},
                )
                page = browser.new_page()

                def answer(route: Route) -> None:
                    route.fulfill(status=200, body=body, content_type="application/json")

                page.route(f"**{EVENTS_PATH}", answer)
                page.goto(url)
                page.wait_for_function("window.dashboard !== undefined")
                results = measure(page, args.repeats, args.steps, args.seed)
                page.evaluate("window.dashboard.step(window.dashboard.state().last)")
                state = page.evaluate("window.dashboard.state()")
                if args.screenshot:
                    page.wait_for_timeout(500)  # the charts follow the step after 250 ms
                    page.screenshot(path=str(args.screenshot), full_page=True)
                version = browser.browser.version if browser.browser else "?"
                browser.close()
        finally:
            if server is not None:
                server.terminate()
                server.wait(10)

    print(
        f"{state['nodes']:,} nodes ({state['failed']:,} failed), {len(events):,} events "
        f"({', '.join(f'{k} {v:,}' for k, v in sorted(counts.items()))}), "
        f"{len(body) / 1e6:.1f} MB of JSON"
    )
    print(
        f"Chromium {version} headless (software rendering), {platform.machine()}, "
        f"{os.cpu_count()} cores; {args.repeats} loads, {args.steps} random steps\n"
    )
    rows = [
        ("show the whole tree: loadEvents (fold + layout + draw)", "load", LOAD_TARGET_MS),
        ("show the whole tree, until the next frame is painted", "load_painted", LOAD_TARGET_MS),
        ("step one event forward: step(k + 1)", "forward", STEP_TARGET_MS),
        ("step one event back: step(k)", "back", STEP_TARGET_MS),
        ("jump to a random step", "jump", None),
    ]
    print("| measurement | median ms | p95 ms | max ms | target |")
    print("|---|---|---|---|---|")
    for label, key, target in rows:
        values = results[key]
        p95 = percentile(values, 0.95)
        verdict = ""
        if target is not None:
            verdict = f"< {target:.0f} ms {'ok' if p95 < target else 'MISSED'}"
        print(
            f"| {label} | {statistics.median(values):.1f} | {p95:.1f} | {max(values):.1f} "
            f"| {verdict} |"
        )
    print(f"\n    {shlex.join([Path(sys.executable).name, *sys.argv])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

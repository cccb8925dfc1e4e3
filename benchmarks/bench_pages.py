"""Benchmark: the researcher's pages of the dashboard, in headless Chromium.

Records into a temporary store two synthetic 20,000-node runs (page_render.py's plausible
learned-planner kitchen run, two seeds) and a finished benchmark of two planners over
``--seeds`` seeds (every trial a stored run with ``--queries`` stream queries), starts
``tamp serve`` on it, and times:

- the compare view of the two 20,000-node runs (``#compare=A,B``): from the hash set to both
  trees, the charts and the tables drawn (GET /api/compare and both GET /api/runs/{id}/tree
  included, the server's cache of trees cold, then warm) (target < 3 s);
- the benchmark's page (``#bench=ID``): from the hash set to its scatter, per-planner table,
  paired improvement and trials drawn (GET /api/benchmarks/{id}, which runs tamp report's
  summarize, included) (target < 1 s);
- then the planner's slowdown with those pages open versus without (paired runs through
  POST /api/runs, same seeds, alternating order, as dashboard_stream.py measures): two tabs,
  one on the compare view and one on the benchmark page, opened and drawn before the run starts
  and left open (``--reload 0``), or reloaded every S seconds while it plans (``--reload S``: a
  user clicking about) (target: planning seconds with / without < 1.05).

    .venv/bin/python benchmarks/bench_pages.py --nodes 20000 --seeds 1000 --repeats 5 \\
        --scene kitchen-2 --runs 0-3 --reload 0,10
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import shlex
import statistics
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from typing import Any

from _common import parse_seeds
from page_render import Synth, start_server
from playwright.sync_api import Page, sync_playwright

from app.browser import CHROMIUM_ARGS, require_chromium
from planner.events import event_from_dict
from planner.store import BenchTrialRecord, RunStore

COMPARE_TARGET_MS = 3000.0
BENCH_TARGET_MS = 1000.0
SLOWDOWN_TARGET = 1.05
STREAMS = ("sample-grasp", "inverse-kinematics", "plan-motion", "sample-placement")


def record_tree(store: RunStore, nodes: int, seed: int) -> str:
    """A finished synthetic run of ``nodes`` nodes; returns its id."""
    run_id = store.create_run("kitchen-4", seed, "learned", {})
    synth = Synth(nodes, seed)
    synth.run_id = run_id
    events = [event_from_dict(e) for e in synth.build()]
    for i in range(0, len(events), 5000):
        store.write_events(run_id, events[i : i + 5000])
    end = events[-1]
    store.finish_run(
        run_id,
        "solved",
        planning_s=getattr(end, "planning_s", None),
        execution_s=40.0,
        queries=getattr(end, "queries", 0),
        message="solved",
    )
    return run_id


def record_bench(store: RunStore, seeds: int, queries: int) -> str:
    """A finished benchmark of baseline and learned over ``seeds`` seeds; returns its id."""
    rng = random.Random(0)
    planners = ["baseline", "learned"]
    config = {
        "scene": "kitchen-4",
        "planners": planners,
        "seeds": list(range(seeds)),
        "budget_s": 120.0,
        "model": None,
        "order": "auto",
        "domain": None,
    }
    bench_id = store.create_bench(config)
    for seed in range(seeds):
        for planner in planners:
            run_id = store.create_run("kitchen-4", seed, planner, {})
            events: list[dict[str, Any]] = [
                {"type": "run_started", "scene": "kitchen-4", "seed": seed, "planner": planner,
                 "config": {}},
                {"type": "abstract_plans_found", "plans": [], "seconds": 2.0},
            ]  # fmt: skip
            for q in range(queries):
                ok = rng.random() > 0.3
                events.append(
                    {
                        "type": "stream_queried",
                        "node_id": q + 1,
                        "stream": STREAMS[q % len(STREAMS)],
                        "input_names": ["b"],
                        "inputs": ["b1"],
                        "success": ok,
                        "wall_s": rng.expovariate(1 / 0.05),
                        "cpu_s": 0.01,
                        "execution_s": 0.0,
                        "error": None,
                        "reason": None if ok else "no solution in 100 iterations",
                        "context": {},
                    }
                )
            for i, e in enumerate(events):
                e.update(run_id=run_id, seq=i, t=i * 0.01)
            store.write_events(run_id, [event_from_dict(e) for e in events])
            solved = rng.random() > 0.05
            planning = rng.lognormvariate(2.5 if planner == "baseline" else 2.0, 0.5)
            execution = rng.uniform(30, 60)
            status = "solved" if solved else "timeout"
            store.finish_run(
                run_id,
                status,
                planning_s=planning if solved else 120.0,
                execution_s=execution if solved else None,
                queries=queries,
            )
            store.record_trial(
                BenchTrialRecord(
                    bench_id=bench_id,
                    seed=seed,
                    planner=planner,
                    run_id=run_id,
                    status=status,
                    valid=True if solved else None,
                    planning_s=planning if solved else None,
                    execution_s=execution if solved else None,
                    oracle_s=None,
                    queries=queries,
                    error=None,
                )
            )
    store.set_bench_status(bench_id, "done")
    return bench_id


def time_compare(page: Page, url: str, a: str, b: str) -> float:
    """Milliseconds from the hash set to both trees and the charts drawn (a fresh page)."""
    page.goto(f"{url}/?load={time.monotonic_ns()}#runs")
    page.wait_for_function("window.dashboard !== undefined && window.dashboard.page() === 'runs'")
    ms = page.evaluate(
        """async (hash) => {
            const t0 = performance.now();
            location.hash = hash;
            while (document.body.dataset.compare !== "drawn") {
                if (document.body.dataset.compare === "error") throw new Error("compare failed");
                await new Promise((ok) => setTimeout(ok, 5));
            }
            await new Promise((ok) => requestAnimationFrame(() => setTimeout(ok, 0)));
            return performance.now() - t0;
        }""",
        f"#compare={a},{b}",
    )
    return float(ms)


def time_bench(page: Page, url: str, bench_id: str) -> float:
    """Milliseconds from the hash set to the benchmark's page drawn (a fresh page)."""
    page.goto(f"{url}/?load={time.monotonic_ns()}#runs")
    page.wait_for_function("window.dashboard !== undefined && window.dashboard.page() === 'runs'")
    ms = page.evaluate(
        """async (id) => {
            const t0 = performance.now();
            location.hash = `#bench=${id}`;
            while (!(document.body.dataset.bench || "").startsWith(id)
                   || !document.querySelector("[data-testid=bench-scatter]")?.dataset.points) {
                await new Promise((ok) => setTimeout(ok, 5));
            }
            await new Promise((ok) => requestAnimationFrame(() => setTimeout(ok, 0)));
            return performance.now() - t0;
        }""",
        bench_id,
    )
    return float(ms)


def _get(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=30) as response:
        return json.load(response)


def _post(url: str, body: dict[str, Any]) -> Any:
    request = urllib.request.Request(
        url, data=json.dumps(body).encode(), headers={"Content-Type": "application/json"}
    )
    with urllib.request.urlopen(request, timeout=30) as response:
        return json.load(response)


def slowdown(
    context: Any, url: str, hashes: list[str], scene: str, seeds: list[int], reload_s: float
) -> list[dict[str, Any]]:
    """Planning seconds of paired runs with the pages open (opened and drawn before the run
    starts, and reloaded every ``reload_s`` if > 0) and without a browser on the page at all."""
    rows = []
    for i, seed in enumerate(seeds):
        order = ("none", "pages") if i % 2 == 0 else ("pages", "none")
        result: dict[str, Any] = {"seed": seed}
        for mode in order:
            tabs = []
            if mode == "pages":  # open and drawn before the run starts
                for h in hashes:
                    tab = context.new_page()
                    tab.goto(f"{url}/{h}")
                    tabs.append(tab)
                tabs[0].wait_for_function("document.body.dataset.compare === 'drawn'")
                tabs[1].wait_for_function("document.body.dataset.bench !== undefined")
            run = _post(f"{url}/api/runs", {"scene": scene, "seed": seed, "budget_s": 120})
            last = time.monotonic()
            while (info := _get(f"{url}/api/runs/{run['id']}"))["status"] in ("queued", "running"):
                if tabs and reload_s > 0 and time.monotonic() - last > reload_s:
                    for tab in tabs:
                        tab.reload()
                    last = time.monotonic()
                for tab in tabs:
                    tab.wait_for_timeout(100)  # let the tabs' own timers and requests run
                if not tabs:
                    time.sleep(0.2)
            for tab in tabs:
                tab.close()
            result[mode] = info["planning_s"]
            result[f"{mode}_status"] = info["status"]
        rows.append(result)
        print(f"seed {seed}: {result}", file=sys.stderr)
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=20_000, help="nodes of each compared tree")
    parser.add_argument("--seeds", type=int, default=1000, help="seeds of the benchmark")
    parser.add_argument("--queries", type=int, default=20, help="stream queries per trial")
    parser.add_argument("--repeats", type=int, default=5, help="loads of each page to time")
    parser.add_argument("--scene", default="kitchen-2", help="the planner timed for slowdown")
    parser.add_argument("--runs", default="0-5", help="its seeds (paired runs); '' to skip")
    parser.add_argument(
        "--reload",
        default="0",
        help="s between page reloads while the planner runs (0: left open); several: 0,10",
    )
    parser.add_argument("--screenshots", type=Path, help="save the two pages here")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        with RunStore(Path(tmp) / "runs.db") as store:
            a = record_tree(store, args.nodes, 0)
            b = record_tree(store, args.nodes, 1)
            bench_id = record_bench(store, args.seeds, args.queries)
        print(f"store recorded in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
        server, url = start_server(Path(tmp))
        try:
            with sync_playwright() as pw:
                context = pw.chromium.launch_persistent_context(
                    str(Path(tmp) / "profile"),
                    executable_path=require_chromium(),
                    args=CHROMIUM_ARGS,
                    headless=True,
                    viewport={"width": 1440, "height": 1000},
                )
                page = context.new_page()
                compare = [time_compare(page, url, a, b) for _ in range(args.repeats)]
                state = page.evaluate("window.dashboard.compare()")
                if args.screenshots:
                    args.screenshots.mkdir(parents=True, exist_ok=True)
                    page.screenshot(path=str(args.screenshots / "compare-20000.png"))
                bench = [time_bench(page, url, bench_id) for _ in range(args.repeats)]
                points = page.get_attribute("[data-testid=bench-scatter]", "data-points")
                if args.screenshots:
                    page.screenshot(path=str(args.screenshots / "bench-1000.png"), full_page=True)
                page.close()
                hashes = [f"#compare={a},{b}", f"#bench={bench_id}"]
                modes = [float(r) for r in args.reload.split(",")] if args.runs else []
                rows = {
                    reload: slowdown(
                        context, url, hashes, args.scene, parse_seeds(args.runs), reload
                    )
                    for reload in modes
                }
                version = context.browser.version if context.browser else "?"
                context.close()
        finally:
            server.terminate()
            server.wait(10)

    print(
        f"compare: {state['nodes']['a']:,} and {state['nodes']['b']:,} nodes; benchmark: "
        f"{args.seeds} seeds x 2 planners ({points} scatter points), {args.queries} queries "
        f"per trial\nChromium {version} headless (software rendering), {platform.machine()}, "
        f"{os.cpu_count()} cores; {args.repeats} loads of each page (the first with the "
        "server's caches cold)\n"
    )
    print("| measurement | first ms | median ms | max ms | target |")
    print("|---|---|---|---|---|")
    for label, values, target in (
        (f"compare view of two {args.nodes:,}-node trees", compare, COMPARE_TARGET_MS),
        (f"benchmark page, {2 * args.seeds:,} trials", bench, BENCH_TARGET_MS),
    ):
        worst = max(values)
        verdict = f"< {target:.0f} ms {'ok' if worst < target else 'MISSED'}"
        print(
            f"| {label} | {values[0]:.0f} | {statistics.median(values):.0f} | {worst:.0f} "
            f"| {verdict} |"
        )
    for reload, pairs in rows.items():
        ratios = [r["pages"] / r["none"] for r in pairs if r["pages"] and r["none"]]
        median = statistics.median(ratios)
        verdict = "ok" if median < SLOWDOWN_TARGET else "MISSED"
        how = f"reloaded every {reload:g} s" if reload > 0 else "left open"
        print(
            f"| {args.scene} planning s, both pages open ({how}) / "
            f"none, {len(ratios)} paired seeds | median ratio {median:.3f}, mean "
            f"{statistics.mean(ratios):.3f} | | | < {SLOWDOWN_TARGET} {verdict} |"
        )
        for r in pairs:
            seconds = f"none {r['none']:.2f} s, pages {r['pages']:.2f} s"
            print(f"|   seed {r['seed']}: {seconds} | | | | |")
    print(f"\n    {shlex.join([Path(sys.executable).name, *sys.argv])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

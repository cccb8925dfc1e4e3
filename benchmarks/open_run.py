"""Benchmark: how soon a finished run of 100,000 events is drawn and steppable when it is opened
from the server, and how long a step takes then.

Synthesises a learned-planner kitchen run with ``page_render.Synth`` (``--nodes`` nodes; 21,600
make about 100,000 events), records it into a fresh SQLite store as any run is recorded
(:meth:`planner.store.RunStore.write_events`), starts a real ``tamp serve --no-viewer`` on that
store and opens ``/#run=ID`` in headless Chromium, ``--repeats`` times, each a fresh load of the
page. It times, from the navigation's start (``performance.now()``'s origin):

- **drawn and steppable**: the page has read every stored event (pages of
  ``GET /api/runs/{id}/events``), folded them, knows the run is over (``state().done``, no
  websocket) and has painted the next frame (target: 2 s);
- then one event forward and one back from ``--steps`` random steps (``dashboard.step``, which
  folds and draws; target 50 ms each).

It also times one 5,000-event page read over HTTP alone, each page of the run once.

    .venv/bin/python benchmarks/open_run.py --nodes 21600 --repeats 5 --steps 300
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

from page_render import Synth, percentile, start_server
from playwright.sync_api import sync_playwright

from app.browser import CHROMIUM_ARGS, require_chromium
from planner.events import event_from_dict
from planner.store import RunStore

OPEN_TARGET_MS = 2000.0
STEP_TARGET_MS = 50.0
PAGE = 5000


def cpu_s(pid: int) -> float:
    """CPU seconds (user + system) the process has used."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def record(db: Path, nodes: int, seed: int) -> tuple[str, int, int]:
    """The synthetic run in the store: its id, events and bytes of their JSON."""
    synth = Synth(nodes, seed)
    with RunStore(db) as store:
        run_id = store.create_run("kitchen-4", 0, "learned", {})
        synth.run_id = run_id
        events = synth.build()
        for e in events:
            e["run_id"] = run_id
        typed = [event_from_dict(e) for e in events]
        for i in range(0, len(typed), 5000):
            store.write_events(run_id, typed[i : i + 5000])
        finished = events[-1]
        store.finish_run(
            run_id,
            "solved",
            planning_s=finished["planning_s"],
            execution_s=finished["execution_s"],
            queries=finished["queries"],
            message="solved",
        )
    size = sum(len(json.dumps(e, separators=(",", ":"))) for e in events)
    return run_id, len(events), size


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=21_600, help="tree nodes to synthesise")
    parser.add_argument("--repeats", type=int, default=5, help="fresh openings of the page")
    parser.add_argument("--steps", type=int, default=300, help="random steps to time")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=120.0, help="seconds an opening may take")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        db = Path(tmp) / "runs.db"
        run_id, n_events, size = record(db, args.nodes, args.seed)
        server, url = start_server(Path(tmp))
        try:
            page_s = []
            for k in range((n_events + PAGE - 1) // PAGE):
                t0 = time.perf_counter()
                with urllib.request.urlopen(
                    f"{url}/api/runs/{run_id}/events?after={k * PAGE - 1}&limit={PAGE}"
                ) as answer:
                    answer.read()
                page_s.append(time.perf_counter() - t0)
            opened: list[float] = []
            marks: list[dict[str, float]] = []
            server_cpu: list[float] = []
            forward: list[float] = []
            back: list[float] = []
            with sync_playwright() as pw:
                browser = pw.chromium.launch_persistent_context(
                    str(Path(tmp) / "profile"),
                    executable_path=require_chromium(),
                    args=CHROMIUM_ARGS,
                    headless=True,
                    viewport={"width": 1600, "height": 1000},
                )
                version = browser.browser.version if browser.browser else "?"
                page = browser.new_page()
                rng = random.Random(args.seed)
                for _ in range(args.repeats):
                    page.goto("about:blank")
                    before = cpu_s(server.pid)
                    page.goto(f"{url}/#run={run_id}")
                    page.wait_for_function(
                        "([id, last]) => { const s = window.dashboard?.state();"
                        " return s && s.runId === id && !s.live && s.last === last; }",
                        arg=[run_id, n_events - 1],
                        timeout=args.timeout * 1000,
                    )
                    opened.append(
                        page.evaluate(
                            "() => new Promise((ok) => requestAnimationFrame(() =>"
                            " setTimeout(() => ok(performance.now()), 0)))"
                        )
                    )
                    server_cpu.append(cpu_s(server.pid) - before)
                    marks.append(page.evaluate("window.dashboard.timings?.() ?? {}"))
                    state = page.evaluate("window.dashboard.state()")
                    assert not state["live"] and state["step"] == n_events - 1, state
                    for _ in range(args.steps // args.repeats):
                        k = rng.randrange(1, n_events - 1)
                        page.evaluate(f"window.dashboard.step({k})")
                        forward.append(page.evaluate(f"window.dashboard.step({k + 1})"))
                        back.append(page.evaluate(f"window.dashboard.step({k})"))
                browser.close()
        finally:
            server.terminate()
            server.wait(10)

    print(
        f"{state['nodes']:,} nodes, {n_events:,} events, {size / 1e6:.1f} MB of JSON; "
        f"Chromium {version} headless (software rendering), {platform.machine()}, "
        f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; "
        f"{args.repeats} openings, {len(forward)} random steps\n"
    )
    print("| measurement | median ms | p95 ms | max ms | target |")
    print("|---|---|---|---|---|")
    rows = [
        ("open the run: drawn and steppable", opened, OPEN_TARGET_MS),
        ("one event forward: step(k + 1)", forward, STEP_TARGET_MS),
        ("one event back: step(k)", back, STEP_TARGET_MS),
        ("one 5,000-event page over HTTP", [1000 * s for s in page_s], None),
    ]
    for label, values, target in rows:
        p95 = percentile(values, 0.95)
        verdict = f"< {target:.0f} ms {'ok' if p95 < target else 'MISSED'}" if target else ""
        print(
            f"| {label} | {statistics.median(values):.1f} | {p95:.1f} | {max(values):.1f} "
            f"| {verdict} |"
        )
    print(
        "\nWhere the opening went (median ms since the navigation started): "
        + ", ".join(
            f"{name} {statistics.median(m.get(name, float('nan')) for m in marks):.0f}"
            for name in ("selected", "detail", "read", "folded", "drawn")
        )
        + f", painted {statistics.median(opened):.0f}; the server's CPU seconds for it (the page,"
        f" the run and every page of its events): median {statistics.median(server_cpu):.2f}"
    )
    print(f"\n    {shlex.join([Path(sys.executable).name, *sys.argv])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

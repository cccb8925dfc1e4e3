"""The dashboard page in a real browser against a real ``tamp serve``.

Starts the server on free ports with a temporary database, drives Debian's Chromium through
Playwright, launches runs from the form and checks what a user sees: the tree growing live, the
stepper, the node inspector, the charts and the 3D view; and the researcher's bench: a benchmark
launched and watched from the page, its scatter, two runs compared, a model trained from the
benchmark's runs and a run launched with it. Screenshots go to test-artifacts/.
"""

from __future__ import annotations

import json
import re
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from app.browser import CHROMIUM_ARGS, require_chromium
from tests.app.viser_client import viser_client

playwright_api = pytest.importorskip("playwright.sync_api")

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
TABLETOP = ROOT / "examples" / "tabletop2d"
RUN_TIMEOUT_MS = 240_000  # a kitchen-1 baseline run takes 5-20 s alone; the CI box is shared


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _get(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=5) as response:
        return json.load(response)


class Server:
    def __init__(self, url: str, process: subprocess.Popen[bytes], log: Path, db: Path) -> None:
        self.url = url
        self.process = process
        self.log = log
        self.db = db

    def api(self, path: str) -> Any:
        return _get(self.url + path)

    def events(self, run_id: str) -> list[dict[str, Any]]:
        events: list[dict[str, Any]] = []
        after = -1
        while True:
            page = self.api(f"/api/runs/{run_id}/events?after={after}&limit=1000")
            events += page["events"]
            if not page["events"]:
                return events
            after = page["next_after"]


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    tmp = tmp_path_factory.mktemp("serve")
    port, viewer_port = _free_port(), _free_port()
    tamp = Path(sys.executable).with_name("tamp")
    log = tmp / "serve.log"
    command = [str(tamp), "serve", "--host", "127.0.0.1", "--port", str(port)]
    command += ["--db", str(tmp / "runs.db"), "--viewer-port", str(viewer_port)]
    reports = tmp / "reports"
    reports.mkdir()
    (reports / "bench-demo.html").write_text("<html><body>a benchmark report</body></html>")
    command += ["--reports", str(reports), "--models", str(tmp / "models")]
    command += ["--domain", str(TABLETOP)]  # the tutorial's tiny domain: benchmarks, training
    with log.open("wb") as out:
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, cwd=ROOT)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 90
    while True:
        if process.poll() is not None:
            pytest.fail(f"tamp serve exited with {process.returncode}:\n{log.read_text()}")
        try:
            _get(url + "/api/health")
            break
        except OSError:
            if time.monotonic() > deadline:
                process.terminate()
                pytest.fail(f"tamp serve did not answer /api/health:\n{log.read_text()}")
            time.sleep(0.2)
    yield Server(url, process, log, tmp / "runs.db")
    process.terminate()
    try:
        process.wait(20)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


@pytest.fixture(scope="module")
def browser(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    with playwright_api.sync_playwright() as pw:
        context = pw.chromium.launch_persistent_context(
            str(tmp_path_factory.mktemp("chromium-profile")),
            executable_path=require_chromium(),
            args=CHROMIUM_ARGS,
            headless=True,
            viewport={"width": 1440, "height": 1000},
        )
        yield context
        context.close()


@pytest.fixture
def page(browser: Any, server: Server) -> Iterator[Any]:
    page = browser.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(server.url)
    page.wait_for_function("document.querySelectorAll('#launch-scene option').length > 0")
    yield page
    page.close()
    assert errors == [], f"JavaScript errors on the page: {errors}"


def _state(page: Any) -> dict[str, Any]:
    return dict(page.evaluate("window.dashboard.state()"))


def _record_growth(page: Any) -> None:
    """Keep every node count the page shows, with whether the run was live, in __growth."""
    page.evaluate(
        """() => {
            window.__growth = [];
            const count = document.getElementById("node-count");
            new MutationObserver(() => {
                const s = window.dashboard.state();
                window.__growth.push({ nodes: Number(count.dataset.nodes), live: s.live });
            }).observe(count, { attributes: true, attributeFilter: ["data-nodes"] });
        }"""
    )


def _launch(page: Any, scene: str, planner: str, budget: str = "120") -> str:
    page.select_option("#launch-scene", scene)
    page.select_option("#launch-planner", planner)
    page.fill("#launch-seed", "0")
    page.fill("#launch-budget", budget)
    page.click("#launch-submit")
    page.wait_for_function("window.dashboard.state().runId !== null")
    run_id = str(_state(page)["runId"])
    row = page.locator(f'#runs-list [data-run-id="{run_id}"]')
    row.wait_for()
    assert row.get_attribute("aria-current") == "true"  # the new run is the one shown
    return run_id


def _wait_finished(page: Any) -> None:
    page.wait_for_function(
        "window.dashboard.state().runId !== null && !window.dashboard.state().live",
        timeout=RUN_TIMEOUT_MS,
    )


def _node_count(page: Any) -> int:
    return int(page.locator("#node-count").get_attribute("data-nodes"))


def _step(page: Any) -> int:
    return int(page.locator("#step-label").get_attribute("data-step"))


def _step_back_over_last_node(page: Any, events: list[dict[str, Any]]) -> None:
    """Step back with the button until the last node_added is undone, then forward again."""
    last = len(events) - 1
    assert _step(page) == last
    assert page.locator("#step-label").inner_text() == f"step {last} / {last}"
    nodes = _node_count(page)
    added = max(i for i, e in enumerate(events) if e["type"] == "node_added")
    for k in range(last - 1, added - 1, -1):
        page.click("#btn-step-back")
        assert _step(page) == k
        assert page.locator("#step-label").inner_text() == f"step {k} / {last}"
        assert _node_count(page) == nodes  # the node is still there up to its own event
    page.click("#btn-step-back")
    assert _step(page) == added - 1
    assert _node_count(page) == nodes - 1
    assert f"{nodes - 1:,} node" in page.locator("#node-count").inner_text()
    page.click("#btn-step-forward")
    assert _step(page) == added
    assert _node_count(page) == nodes
    assert f"node {events[added]['node_id']} added" in page.locator("#step-event").inner_text()


def _viewer_body(request: Any) -> dict[str, Any] | None:
    """The body of a PUT /api/viewer request; None for any other request."""
    if request.method == "PUT" and request.url.endswith("/api/viewer"):
        return dict(json.loads(request.post_data or "{}"))
    return None


def _click_node(
    page: Any, node: dict[str, Any], error: str | None = None, reason: str | None = None
) -> None:
    """Zoom in on a node, click it on the canvas and check what the inspector shows: its
    stream, outcome, seconds, the query's error (a sampler that raised) if it had one, and
    why it found nothing if the sampler said."""
    page.click("#btn-last")
    page.click("#btn-fit")
    at = f"window.dashboard.nodePosition({node['node_id']})"
    position = page.evaluate(at)
    assert position is not None
    page.mouse.move(position["x"], position["y"])
    for _ in range(4):  # the wheel zooms around the pointer: the node stays under it
        page.mouse.wheel(0, -400)
    page.wait_for_function(
        f"Math.abs({at}.x - {position['x']}) < 2 && Math.abs({at}.y - {position['y']}) < 40"
    )
    position = page.evaluate(at)
    hit = page.evaluate(
        "([x, y]) => document.elementFromPoint(x, y).id", [position["x"], position["y"]]
    )
    assert hit == "tree-canvas"
    page.mouse.click(position["x"], position["y"])
    page.wait_for_function(f"window.dashboard.state().selected === {node['node_id']}")
    inspector = page.locator("#inspector")
    assert inspector.locator('[data-testid="inspector-stream"]').inner_text() == node["stream"]
    outcome = "ok" if node["success"] else "failed"
    assert inspector.locator('[data-testid="inspector-outcome"]').inner_text() == outcome
    wall_cpu = inspector.locator('[data-testid="inspector-seconds"]').inner_text()
    assert re.fullmatch(r"[\d.]+ (µs|ms|s) / [\d.]+ (µs|ms|s)", wall_cpu), wall_cpu
    shown = inspector.locator('[data-testid="inspector-error"]')
    if error:
        assert error in shown.inner_text()
    else:  # a query that just found nothing (IK out of reach) has no error to show
        assert not shown.is_visible()
    why = inspector.locator('[data-testid="inspector-reason"]')
    if reason:
        assert why.inner_text() == reason
    else:
        assert not why.is_visible()


def _check_charts(page: Any, run: dict[str, Any], events: list[dict[str, Any]]) -> None:
    """At the last step the charts show the run's query counts and its time split."""
    page.click("#btn-last")
    queries = page.locator("#chart-queries")
    total = sum(c["ok"] + c["failed"] for c in run["query_counts"].values())
    page.wait_for_function(
        "document.getElementById('chart-queries').dataset.bars === "
        f"'{len(run['query_counts'])}' && document.getElementById('chart-queries')"
        f".textContent.includes('Queries per stream ({total})')"
    )
    assert sorted(queries.locator(".legendtext").all_text_contents()) == ["failed", "ok"]
    assert queries.locator(".bars path").count() >= len(run["query_counts"])
    for stream in run["query_counts"]:
        assert stream in (queries.text_content() or "")
    finished = next(e for e in events if e["type"] == "run_finished")
    time_chart = page.locator("#chart-time")
    page.wait_for_function(
        "document.getElementById('chart-time').textContent.includes("
        f"'planning {finished['planning_s']:.2f} s')"
    )
    assert "execution" in (time_chart.text_content() or "")


def test_line_run_from_the_form(page: Any, server: Server) -> None:
    # The reports the server has are linked from the page.
    link = page.locator("#reports a", has_text="bench-demo")
    link.wait_for()
    assert link.get_attribute("href") == "/reports/bench-demo.html"

    # A bad budget: the server's 422 is shown in the form, naming the field.
    page.select_option("#launch-scene", "line-2")
    page.fill("#launch-budget", "-5")
    page.click("#launch-submit")
    error = page.locator("#launch-error")
    error.wait_for()
    assert "422" in error.inner_text()
    assert "budget" in error.inner_text()

    viewer_puts: list[dict[str, Any] | None] = []
    page.on("request", lambda r: viewer_puts.append(_viewer_body(r)))
    _record_growth(page)
    run_id = _launch(page, "line-2", "baseline", budget="60")
    assert error.is_hidden()
    _wait_finished(page)
    growth = page.evaluate("window.__growth")
    assert any(g["live"] and g["nodes"] > 0 for g in growth), growth  # arrived while live
    run = server.api(f"/api/runs/{run_id}")
    assert run["status"] == "solved"
    row = page.locator(f'#runs-list [data-run-id="{run_id}"]')
    page.wait_for_function(
        f"document.querySelector('[data-run-id=\"{run_id}\"]').dataset.status === 'solved'"
    )
    assert f"{run['queries']} queries" in row.inner_text()

    # The status filter keeps the list to one status.
    page.select_option("#status-filter", "failed")
    page.wait_for_function("!document.querySelector('#runs-list [data-run-id]')")
    assert "No runs with status failed" in page.locator("#runs-list").inner_text()
    page.select_option("#status-filter", "solved")
    row.wait_for()
    statuses = page.locator("#runs-list [data-run-id]").evaluate_all(
        "rows => rows.map((r) => r.dataset.status)"
    )
    assert set(statuses) == {"solved"}
    page.select_option("#status-filter", "")

    events = server.events(run_id)
    nodes = [e for e in events if e["type"] == "node_added"]
    state = _state(page)
    assert state["last"] == len(events) - 1 and state["step"] == state["last"]
    assert state["nodes"] == len(nodes) + 1  # and the root
    assert state["solution"] is not None
    page.wait_for_function(
        "document.querySelector('#run-header [data-testid=run-status]').textContent === 'solved'"
    )

    _step_back_over_last_node(page, events)

    # The viewer follows what the page shows: a step back is sent, debounced, as that step.
    if server.api("/api/health")["viewer_url"] is not None:
        assert {"run_id": run_id, "step": None} in viewer_puts  # following it live
        # Let the last step's debounced PUT go out first: on a loaded machine the clicks above
        # can outpace the 200 ms debounce, and a step the view already shows is not re-sent.
        page.wait_for_timeout(600)
        expected = {"run_id": run_id, "step": events[_step(page) - 1]["seq"]}
        with page.expect_request(lambda r: _viewer_body(r) == expected, timeout=5000):
            page.click("#btn-step-back")

    leaf = next(n for n in nodes if n["node_id"] == state["solution"])
    _click_node(page, leaf)
    _check_charts(page, run, events)

    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "page-line-2.png"), full_page=True)


def test_kitchen_baseline_run_grows_live(page: Any, server: Server) -> None:
    _record_growth(page)
    run_id = _launch(page, "kitchen-1", "baseline")
    page.locator("#live-badge").wait_for()
    # The tree grows over the websocket while the run is live: several counts, increasing.
    page.wait_for_function(
        """() => {
            const live = window.__growth.filter((g) => g.live && g.nodes > 0).map((g) => g.nodes);
            return new Set(live).size >= 3;
        }""",
        timeout=RUN_TIMEOUT_MS,
    )
    _wait_finished(page)
    live = [g["nodes"] for g in page.evaluate("window.__growth") if g["live"]]
    assert live == sorted(live), live  # following the live end, the tree only grows
    assert page.locator("#live-badge").is_hidden()

    run = server.api(f"/api/runs/{run_id}")
    assert run["status"] == "solved", run
    events = server.events(run_id)
    nodes = [e for e in events if e["type"] == "node_added"]
    assert _state(page)["nodes"] == len(nodes) + 1

    _step_back_over_last_node(page, events)

    # Replay from the start with play; pause; the step moved and the tree shrank back.
    page.click("#btn-first")
    assert _step(page) == 0
    assert _node_count(page) == 0
    page.click("#btn-play")
    page.wait_for_function("window.dashboard.state().step > 10")
    page.click("#btn-play")
    paused = _step(page)
    assert not _state(page)["playing"]
    assert 10 < paused < len(events) - 1
    assert page.locator("#step-label").inner_text() == f"step {paused} / {len(events) - 1}"
    page.click("#btn-last")
    assert _node_count(page) == len(nodes) + 1

    queried = [n for n in nodes if n["stream"] is not None]
    failed = [n for n in queried if not n["success"]]
    clicked = failed[-1] if failed else queried[-1]
    query = next(
        e for e in events if e["type"] == "stream_queried" and e["node_id"] == clicked["node_id"]
    )
    if not clicked["success"]:  # every kitchen sampler says why it found nothing
        assert query["reason"], query
    _click_node(page, clicked, query.get("error"), query.get("reason"))
    _check_charts(page, run, events)

    page.click("#btn-fit")
    ARTIFACTS.mkdir(exist_ok=True)
    viewer_url = server.api("/api/health")["viewer_url"]
    frame = page.locator("#viewer-frame")
    if viewer_url is None:
        assert frame.is_hidden()
        assert "off" in page.locator("#viewer-note").inner_text()
        page.screenshot(path=str(ARTIFACTS / "page.png"), full_page=True)
        return
    assert frame.is_visible()
    assert frame.get_attribute("src").rstrip("/") == viewer_url.rstrip("/")
    frame.scroll_into_view_if_needed()  # Chromium paints an iframe only once it is in view
    viewer = page.frame_locator("#viewer-frame")
    viewer.locator("canvas").first.wait_for(timeout=60_000)
    viewer.get_by_text("Connected").first.wait_for(timeout=30_000)  # viser's own status
    frame.screenshot(path=str(ARTIFACTS / "viewer-in-page.png"))
    page.screenshot(path=str(ARTIFACTS / "page.png"), full_page=True)


def _record_reuse_run(db: Path) -> str:
    """Record, into the server's store, a run of the visit domain (tests/search/test_reuse.py)
    in which a motion made in one branch is reused in another: no sampler ran for it."""
    from planner.events import AbstractPlansFound, RunFinished, RunStarted
    from planner.runs import plan_summaries
    from planner.store import RunStore, StoreSink
    from tests.search.test_reuse import make

    store = RunStore(db)
    run_id = store.create_run("visit", 0, "baseline", {})
    sink = StoreSink(store, run_id)
    search, _ = make(sink, run_id)
    assert search.emitter is not None
    search.emitter.emit(RunStarted, scene="visit", seed=0, planner="baseline", config={})
    search.emitter.emit(AbstractPlansFound, plans=plan_summaries(search.skeletons), seconds=0.01)
    top = search.open_plan(0)
    first, second = search.query(top), search.query(top)
    search.query(first)
    search.query(second)  # the same motion from the other IK child: reused
    queries = len(search.queries)
    search.emitter.emit(
        RunFinished,
        status="timeout",
        planning_s=0.1,
        execution_s=None,
        oracle_s=None,
        queries=queries,
        message="no plan (timeout)",
    )
    sink.close()
    store.finish_run(
        run_id, "timeout", planning_s=0.1, queries=queries, message="no plan (timeout)"
    )
    store.close()
    return run_id


def test_a_reused_query_is_shown_as_reused(page: Any, server: Server) -> None:
    run_id = _record_reuse_run(server.db)
    events = server.events(run_id)
    reused = [e for e in events if e["type"] == "stream_queried" and e["reused_from"] is not None]
    assert len(reused) == 1
    query = reused[0]
    page.reload()
    row = page.locator(f'#runs-list [data-run-id="{run_id}"]')
    row.click()
    page.wait_for_function(f"window.dashboard.state().runId === '{run_id}'")
    page.wait_for_function(f"window.dashboard.state().last === {len(events) - 1}")

    # The stepper names the query as reused, and from which node, instead of its seconds.
    page.click("#btn-first")
    for _ in range(events.index(query)):
        page.click("#btn-step-forward")
    assert _step(page) == events.index(query)
    line = page.locator("#step-event").inner_text()
    assert f"reused from node {query['reused_from']}" in line, line
    assert "ok" in line

    # The inspector of the reused node says whose answer it is.
    node = next(e for e in events if e["type"] == "node_added" and e["node_id"] == query["node_id"])
    _click_node(page, node)
    shown = page.locator('#inspector [data-testid="inspector-reused"]')
    assert f"the answer of node {query['reused_from']}" in shown.inner_text()
    original = next(
        e for e in events if e["type"] == "stream_queried" and e["node_id"] == query["reused_from"]
    )
    assert original["reused_from"] is None  # the original ran its sampler


def _watch_bench(page: Any) -> None:
    """Keep every (trials done, status) the benchmark page shows in __bench, 10 times a second."""
    page.evaluate(
        """() => {
            window.__bench = [];
            setInterval(() => {
                const bar = document.querySelector("[data-testid=bench-progress]");
                const status = document.querySelector("[data-testid=bench-status]");
                if (bar && status) window.__bench.push([Number(bar.value), status.textContent]);
            }, 100);
        }"""
    )


def _improvement_words(paired: dict[str, Any]) -> str:
    """What the page prints of a paired improvement (as tamp report's "41.9% less")."""
    mean = paired["mean"]
    return f"{100 * abs(mean):.1f}% {'less' if mean >= 0 else 'more'}"


def test_benchmark_compare_train_and_run_from_the_page(page: Any, server: Server) -> None:
    """The issue's "done when" on the tutorial's tiny domain: a benchmark of two planners
    launched from the page and watched, its scatter, a seed clicked and its two runs compared,
    a model trained from the benchmark's baseline runs, and a run launched with it; in the 3D
    view, that run's node selected in the page and a ghost clicked selecting its node."""
    ARTIFACTS.mkdir(exist_ok=True)
    page.click("[data-testid=nav-benchmarks]")
    page.wait_for_function("document.querySelectorAll('#bench-scene option').length > 0")
    page.select_option("#bench-scene", "tabletop-3")
    # Bad input is the server's 422, naming the field.
    for planner in ("baseline", "learned"):
        page.uncheck(f"[data-testid=bench-planner-{planner}]")
    page.click("[data-testid=bench-submit]")
    error = page.locator("#bench-error")
    error.wait_for()
    assert "422" in error.inner_text() and "planners" in error.inner_text()
    for planner in ("baseline", "learned"):
        page.check(f"[data-testid=bench-planner-{planner}]")
    page.fill("#bench-trials", "3")
    page.fill("#bench-budget", "30")
    page.click("[data-testid=bench-submit]")
    page.wait_for_function("location.hash.startsWith('#bench=')")
    assert error.is_hidden()
    bench_id = page.evaluate("decodeURIComponent(location.hash.slice('#bench='.length))")
    page.locator("[data-testid=bench-progress]").wait_for()
    _watch_bench(page)
    row = page.locator(f'#bench-list [data-bench-id="{bench_id}"]')
    row.wait_for()
    assert "tabletop-3" in row.inner_text() and "baseline, learned" in row.inner_text()
    page.wait_for_function(
        "document.querySelector('[data-testid=bench-status]')?.textContent === 'done'",
        timeout=RUN_TIMEOUT_MS,
    )
    seen = page.evaluate("window.__bench")
    done = [d for d, _ in seen]
    assert done == sorted(done), seen  # the bar only grows
    assert any(status == "running" and d < 6 for d, status in seen), seen  # watched it go
    assert page.locator("[data-testid=bench-progress-text]").inner_text() == "6 / 6 trials"
    page.wait_for_function(
        f"document.querySelector('#bench-list [data-bench-id=\"{bench_id}\"]')"
        ".dataset.status === 'done'"
    )

    # The per-planner table and the paired improvement are tamp report's figures.
    bench = server.api(f"/api/benchmarks/{bench_id}")
    summary = bench["summary"]
    table = page.locator("[data-testid=bench-table]")
    for planner, figures in summary["planners"].items():
        line = table.locator(f'tr[data-planner="{planner}"]').inner_text()
        assert f"{figures['solved']} (" in line, line
    paired = summary["paired"]["learned"]["total_censored"]
    paired_row = page.locator('[data-testid=bench-paired] tr[data-planner="learned"]')
    shown = paired_row.locator("[data-measure=total]")
    assert _improvement_words(paired) in shown.inner_text()
    assert f"{paired['n']} seeds" in shown.inner_text()

    # The scatter: a point per seed, the seed on hover, a click opens the two runs compared.
    scatter = page.locator("[data-testid=bench-scatter]")
    page.wait_for_function("document.querySelector('[data-testid=bench-scatter]')?.dataset.points")
    assert scatter.get_attribute("data-points") == "3"
    assert scatter.locator(".shapelayer path").count() == 1  # the diagonal
    page.select_option("[data-testid=scatter-measure]", "planning")
    trial = summary["trials"][0]
    point = page.evaluate(f"window.dashboard.scatterPoint({trial['seed']})")
    assert point is not None
    page.mouse.move(point["x"], point["y"])
    page.locator(".hoverlayer .hovertext").first.wait_for()
    assert f"seed {trial['seed']}" in (page.locator(".hoverlayer").text_content() or "")
    page.screenshot(path=str(ARTIFACTS / "benchmark.png"), full_page=True)
    page.mouse.click(point["x"], point["y"])
    a, b = trial["baseline"]["run_id"], trial["learned"]["run_id"]
    page.wait_for_function(f"location.hash === '#compare={a},{b}'")

    # The compare view: both trees drawn whole, where they parted ringed, the same figures.
    page.wait_for_function("document.body.dataset.compare === 'drawn'", timeout=30_000)
    compared = server.api(f"/api/compare?a={a}&b={b}")
    state = page.evaluate("window.dashboard.compare()")
    assert state["nodes"] == {"a": compared["a"]["nodes"], "b": compared["b"]["nodes"]}
    divergence = compared["divergence"]
    assert (
        page.locator("[data-testid=compare-divergence]").inner_text().startswith(divergence["text"])
    )
    if divergence["a"] is not None:
        assert divergence["a"]["node_id"] in state["marks"]["a"]
        assert divergence["b"]["node_id"] in state["marks"]["b"]
    assert "learned" in page.locator("[data-testid=compare-run-b]").inner_text()
    queries = page.locator("[data-testid=compare-queries]")
    for stream, q in compared["a"]["queries"].items():
        cells = queries.locator(f'tr[data-stream="{stream}"] td').all_inner_texts()
        assert cells[1] == str(q["queries"]) and cells[3] == str(q["failed"]), cells
    assert page.locator("#compare-curve .scatterlayer .trace").count() == 2
    page.screenshot(path=str(ARTIFACTS / "compare.png"), full_page=True)
    # The view is shareable: its URL opened afresh draws the same two trees.
    page.goto("about:blank")
    page.goto(f"{server.url}/#compare={a},{b}")
    page.wait_for_function("document.body.dataset.compare === 'drawn'", timeout=30_000)
    assert page.evaluate("window.dashboard.compare()")["nodes"] == state["nodes"]

    # A model trained from the benchmark's baseline runs, with its validation figures.
    page.goto(f"{server.url}/#bench={bench_id}")
    page.click("[data-testid=bench-train-baseline]")
    page.wait_for_function("location.hash === '#models'")
    page.wait_for_function(
        f"document.getElementById('train-bench').value === '{bench_id}|baseline'"
        " && document.getElementById('train-name').value !== ''"
    )
    name = page.input_value("#train-name")
    page.fill("#train-epochs", "40")
    page.click("[data-testid=train-submit]")
    page.locator("[data-testid=train-progress]").wait_for()
    page.wait_for_function(f"location.hash === '#model={name}'", timeout=RUN_TIMEOUT_MS)
    page.locator("[data-testid=model-validation]").wait_for()
    model = server.api(f"/api/models/{name}")
    provenance = model["metadata"]["provenance"]
    assert provenance["benchmark"] == bench_id
    assert sorted(provenance["runs"]) == sorted(t["baseline"]["run_id"] for t in summary["trials"])
    assert "tabletop-3: 3 seeds" in page.locator("[data-testid=model-seeds]").inner_text()
    validation = page.locator("[data-testid=model-validation]")
    for s in model["metadata"]["validation"]["streams"]:
        auc = validation.locator(f'tr[data-stream="{s["stream"]}"] [data-testid=auc]').inner_text()
        assert auc == ("\u2013" if s["auc"] is None else str(round(s["auc"], 3))), (s, auc)
    page.locator("#model-calibration .scatterlayer .trace").first.wait_for()
    page.screenshot(path=str(ARTIFACTS / "model.png"), full_page=True)

    # ... and a run launched with it, on the scene it was trained on.
    assert page.input_value("[data-testid=model-launch-scene]") == "tabletop-3"
    page.click("[data-testid=model-launch-submit]")
    page.wait_for_function("location.hash.startsWith('#run=')")
    _wait_finished(page)
    run_id = str(_state(page)["runId"])
    run = server.api(f"/api/runs/{run_id}")
    assert run["status"] == "solved" and run["config"]["model_name"] == name
    assert page.locator("[data-testid=run-model]").inner_text() == name

    # Selecting a node in the tree shows it in the 3D view.
    if server.api("/api/health")["viewer_url"] is not None:
        events = server.events(run_id)
        leaf = next(e for e in events if e["type"] == "solution_found")["node_id"]
        page.click("#btn-fit")
        position = page.evaluate(f"window.dashboard.nodePosition({leaf})")
        with page.expect_request(
            lambda r: (_viewer_body(r) or {}).get("node") == leaf, timeout=10_000
        ):
            page.mouse.click(position["x"], position["y"])
        assert _state(page)["selected"] == leaf
        _wait_viewer_node(server, leaf)

        # A ghost clicked in the 3D view names its node: the page says which and selects it
        # (tree, inspector, and the 3D view's highlight).
        conf = next(
            e
            for e in events
            if e["type"] == "node_added" and e["stream"] == "inverse-kinematics" and e["success"]
        )
        assert conf["node_id"] != leaf
        picked = page.locator("[data-testid=viewer-picked]")
        with viser_client(server.api("/api/health")["viewer_url"]) as viser:
            viser.click("/search/confs", instance_index=0)  # the first configuration sampled
            picked.wait_for(timeout=10_000)  # the page asks every 1.5 s
        assert f"ghost of node #{conf['node_id']}" in picked.inner_text()
        assert conf["label"] in picked.inner_text()
        assert _state(page)["selected"] == conf["node_id"]
        node = page.locator("[data-testid=inspector-node]").inner_text()
        assert node.startswith(f"#{conf['node_id']} "), node
        _wait_viewer_node(server, conf["node_id"])
    page.screenshot(path=str(ARTIFACTS / "run-with-model.png"), full_page=True)


def _wait_viewer_node(server: Server, node_id: int) -> None:
    """Until the 3D view shows ``node_id`` as the page's selection (10 s at most)."""
    deadline = time.monotonic() + 10
    while server.api("/api/viewer")["node"] != node_id:
        assert time.monotonic() < deadline, server.api("/api/viewer")
        time.sleep(0.2)


def test_a_benchmark_cancelled_from_the_page_keeps_its_trials(page: Any, server: Server) -> None:
    page.goto(f"{server.url}/#benchmarks")
    page.wait_for_function("document.querySelectorAll('#bench-scene option').length > 0")
    page.select_option("#bench-scene", "tabletop-3")
    page.uncheck("[data-testid=bench-planner-learned]")
    page.fill("#bench-trials", "30")
    page.fill("#bench-workers", "1")
    page.click("[data-testid=bench-submit]")
    page.wait_for_function("location.hash.startsWith('#bench=')")
    page.wait_for_function(
        "Number(document.querySelector('[data-testid=bench-progress]')?.value) >= 1",
        timeout=RUN_TIMEOUT_MS,
    )
    page.click("[data-testid=bench-cancel]")
    page.wait_for_function(
        "document.querySelector('[data-testid=bench-status]')?.textContent === 'cancelled'",
        timeout=60_000,
    )
    kept = int(page.locator("[data-testid=bench-progress]").get_attribute("value") or "0")
    assert 1 <= kept < 30
    assert page.locator("[data-testid=bench-resume]").inner_text() == (
        f"Resume the {30 - kept} missing trials"
    )
    assert page.locator("[data-testid=bench-trials-table] tr[data-seed]").count() == kept


def _plot_point(page: Any, chart: str, trace: int, index: int) -> dict[str, float]:
    """Where plotly draws point ``index`` of trace ``trace`` of the chart with id ``chart``."""
    return dict(
        page.evaluate(
            """([id, t, k]) => {
                const el = document.getElementById(id);
                const full = el._fullLayout;
                const rect = el.getBoundingClientRect();
                return {
                    x: rect.left + full._size.l + full.xaxis.l2p(el.data[t].x[k]),
                    y: rect.top + full._size.t + full.yaxis.l2p(el.data[t].y[k]),
                };
            }""",
            [chart, trace, index],
        )
    )


def test_the_horizon_panel_draws_a_series_and_opens_its_benchmarks(
    page: Any, server: Server
) -> None:
    from planner.bench import make_config, run_bench

    page.goto(f"{server.url}/#benchmarks")
    # The other tests' benchmarks are one scene each: no series.
    empty = page.locator("[data-testid=horizon-empty]")
    empty.wait_for()
    assert "No series yet: tamp horizon --scenes" in empty.inner_text()

    # Two scenes with the same settings, run the way tamp horizon runs them, while the page is
    # open: it follows the benchmarks list and draws the series once both are done.
    planners = ["baseline", "sequential"]
    ids = [
        run_bench(
            server.db,
            make_config(
                scene, planners, trials=2, seed_start=5000, budget_s=30, domain=str(TABLETOP)
            ),
            workers=4,
        )[0]
        for scene in ("tabletop-1", "tabletop-2")
    ]
    [series] = server.api("/api/benchmarks/horizon?planners=baseline,sequential&seed_start=5000")
    charts = ("horizon-planning", "horizon-total")
    page.wait_for_function(
        "ids => ids.every((id) => document.getElementById(id)?.dataset.points === '4')",
        arg=list(charts),
        timeout=60_000,
    )
    select = page.locator("[data-testid=horizon-series]")
    assert select.input_value() == series["key"]
    assert select.locator("option:checked").inner_text() == (
        "tabletop2d: baseline, sequential — 2 seeds, 30 s"
    )
    for chart, measure in zip(charts, ("planning", "total"), strict=True):
        traces = page.evaluate(
            f"document.getElementById('{chart}').data.map((t) => [t.name, t.y, t.error_y.array])"
        )
        assert [t[0] for t in traces] == planners  # one line per planner
        for (_, ys, ups), planner in zip(traces, planners, strict=True):
            mine = [p[measure] for p in series["points"] if p["planner"] == planner]
            assert ys == pytest.approx([m[0] for m in mine])  # objects 1 then 2
            assert ups == pytest.approx([m[2] - m[0] for m in mine])  # the interval as bars

    # A hover names the scene, the seeds solved and the benchmark; a click opens it.
    page.locator("#horizon-total").scroll_into_view_if_needed()
    point = _plot_point(page, "horizon-total", 0, 1)  # baseline on tabletop-2
    page.mouse.move(point["x"], point["y"])
    hover = page.locator("#horizon-total .hoverlayer .hovertext").first
    hover.wait_for()
    text = hover.text_content() or ""
    assert "tabletop-2" in text and "solved 2 / 2 seeds" in text and ids[1] in text, text
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "horizon.png"), full_page=True)
    page.mouse.click(point["x"], point["y"])
    page.wait_for_function(f"location.hash === '#bench={ids[1]}'")
    page.wait_for_function(f"(document.body.dataset.bench ?? '').startsWith('{ids[1]}:')")
    assert "tabletop-2" in page.locator("[data-testid=bench-head]").inner_text()

"""The dashboard page in a real browser against a real ``tamp serve``.

Starts the server on free ports with a temporary database, drives Debian's Chromium through
Playwright, launches runs from the form and checks what a user sees: the tree growing live, the
stepper, the node inspector, the charts and the 3D view; and the researcher's bench: a benchmark
launched and watched from the page, its scatter, two runs compared, a model trained from the
benchmark's runs and a run launched with it. Screenshots go to test-artifacts/.

Every wait is on a state the page reaches (``expect``, ``wait_for_function``), never a fixed
time, with timeouts that a machine busy with other work still meets.
"""

from __future__ import annotations

import json
import math
import os
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
from planner import figures
from planner.experiment import Trial, run_trial
from tests.app.viser_client import viser_client

playwright_api = pytest.importorskip("playwright.sync_api")
expect = playwright_api.expect

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
TABLETOP = ROOT / "examples" / "tabletop2d"
PACED = Path(__file__).resolve().parent / "paced"  # a walk whose every query waits for a token
WAIT_MS = 60_000  # a state the page reaches in a second when idle; a busy machine is slower
RUN_TIMEOUT_MS = 600_000  # kitchen-6 baseline: 5-10 s alone, 63 s at load 6; CI boxes are shared
SCATTER_MARKER_PX = 8  # the benchmark scatter's marker size (static/benchmarks.js)
expect.set_options(timeout=WAIT_MS)


def _free_ports(n: int) -> list[int]:
    """``n`` different ports the OS says are free (held together, so never the same twice)."""
    sockets = [socket.socket() for _ in range(n)]
    try:
        for s in sockets:
            s.bind(("127.0.0.1", 0))
        return [int(s.getsockname()[1]) for s in sockets]
    finally:
        for s in sockets:
            s.close()


def _get(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=60) as response:
        return json.load(response)


class Server:
    def __init__(
        self, url: str, process: subprocess.Popen[bytes], log: Path, db: Path, tokens: Path
    ) -> None:
        self.url = url
        self.process = process
        self.log = log
        self.db = db
        self.tokens = tokens  # the paced domain's queries each take one file from here

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
    port, viewer_port = _free_ports(2)
    tamp = Path(sys.executable).with_name("tamp")
    log = tmp / "serve.log"
    command = [str(tamp), "serve", "--host", "127.0.0.1", "--port", str(port)]
    command += ["--db", str(tmp / "runs.db"), "--viewer-port", str(viewer_port)]
    reports = tmp / "reports"
    reports.mkdir()
    (reports / "bench-demo.html").write_text("<html><body>a benchmark report</body></html>")
    command += ["--reports", str(reports), "--models", str(tmp / "models")]
    command += ["--domain", str(TABLETOP)]  # the tutorial's tiny domain: benchmarks, training
    command += ["--domain", str(PACED)]
    tokens = tmp / "tokens"
    tokens.mkdir()
    env = {**os.environ, "PACED_TOKENS": str(tokens)}  # the server's workers inherit it
    with log.open("wb") as out:
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, cwd=ROOT, env=env)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 180
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
    yield Server(url, process, log, tmp / "runs.db", tokens)
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
        context.set_default_timeout(WAIT_MS)
        context.set_default_navigation_timeout(WAIT_MS)
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
    before = _state(page)["runId"]
    page.select_option("#launch-scene", scene)
    page.select_option("#launch-planner", planner)
    page.fill("#launch-seed", "0")
    page.fill("#launch-budget", budget)
    page.click("#launch-submit")
    page.wait_for_function(
        "before => ![null, before].includes(window.dashboard.state().runId)", arg=before
    )
    run_id = str(_state(page)["runId"])
    row = page.locator(f'#runs-list [data-run-id="{run_id}"]')
    expect(row).to_have_attribute("aria-current", "true")  # the new run is the one shown
    return run_id


def _wait_finished(page: Any, run_id: str) -> None:
    """Until the page shows run ``run_id`` whole: its last event arrived (the page read it in
    bulk when it was over, or followed it live to its end)."""
    page.wait_for_function(
        "id => window.dashboard.state().runId === id && window.dashboard.state().done",
        arg=run_id,
        timeout=RUN_TIMEOUT_MS,
    )


def _node_count(page: Any) -> int:
    return int(page.locator("#node-count").get_attribute("data-nodes"))


def _step(page: Any) -> int:
    return int(page.locator("#step-label").get_attribute("data-step"))


def _expect_step(page: Any, step: int, last: int, nodes: int | None = None) -> None:
    """The stepper shows ``step`` of ``last`` (and the tree ``nodes`` nodes, when given)."""
    label = page.locator("#step-label")
    expect(label).to_have_attribute("data-step", str(step))
    expect(label).to_have_text(f"step {step} / {last}")
    if nodes is not None:
        expect(page.locator("#node-count")).to_have_attribute("data-nodes", str(nodes))


def _step_back_over_last_node(page: Any, events: list[dict[str, Any]]) -> None:
    """Step back with the button until the last node_added is undone, then forward again."""
    last = len(events) - 1
    _expect_step(page, last, last)
    nodes = _node_count(page)
    added = max(i for i, e in enumerate(events) if e["type"] == "node_added")
    for k in range(last - 1, added - 1, -1):
        page.click("#btn-step-back")
        _expect_step(page, k, last, nodes)  # the node is still there up to its own event
    page.click("#btn-step-back")
    _expect_step(page, added - 1, last, nodes - 1)
    expect(page.locator("#node-count")).to_contain_text(f"{nodes - 1:,} node")
    page.click("#btn-step-forward")
    _expect_step(page, added, last, nodes)
    expect(page.locator("#step-event")).to_contain_text(f"node {events[added]['node_id']} added")


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
    pointer = round(position["x"]), round(position["y"])  # a mouse is on a whole pixel
    page.mouse.move(*pointer)
    page.evaluate(  # sums the wheel the canvas handled (its zoom listener runs before this)
        """() => {
            window.__wheeled = 0;
            document.getElementById("tree-canvas").addEventListener("wheel", (e) => {
                window.__wheeled += e.deltaY;
            });
        }"""
    )
    for _ in range(4):  # the wheel zooms around the pointer: the node stays under it
        page.mouse.wheel(0, -400)
    page.wait_for_function("window.__wheeled <= -1600")
    # Its offset from the pointer (half a pixel at most) grows with the zoom (about 11 times):
    # it stays within the 10 px a click picks a node in.
    zoomed = page.evaluate(at)
    assert math.hypot(zoomed["x"] - pointer[0], zoomed["y"] - pointer[1]) < 10, (pointer, zoomed)
    hit = page.evaluate(
        "([x, y]) => document.elementFromPoint(x, y).id", [zoomed["x"], zoomed["y"]]
    )
    assert hit == "tree-canvas"
    page.mouse.click(zoomed["x"], zoomed["y"])
    page.wait_for_function(f"window.dashboard.state().selected === {node['node_id']}")
    inspector = page.locator("#inspector")
    expect(inspector.locator('[data-testid="inspector-stream"]')).to_have_text(node["stream"])
    outcome = "ok" if node["success"] else "failed"
    expect(inspector.locator('[data-testid="inspector-outcome"]')).to_have_text(outcome)
    wall_cpu = inspector.locator('[data-testid="inspector-seconds"]')
    expect(wall_cpu).to_have_text(re.compile(r"^[\d.]+ (µs|ms|s) / [\d.]+ (µs|ms|s)$"))
    shown = inspector.locator('[data-testid="inspector-error"]')
    if error:
        expect(shown).to_contain_text(error)
    else:  # a query that just found nothing (IK out of reach) has no error to show
        expect(shown).to_be_hidden()
    why = inspector.locator('[data-testid="inspector-reason"]')
    if reason:
        expect(why).to_have_text(reason)
    else:
        expect(why).to_be_hidden()


def _check_charts(page: Any, run: dict[str, Any], events: list[dict[str, Any]]) -> None:
    """At the last step the charts show the run's query counts and its time split."""
    page.click("#btn-last")
    queries = page.locator("#chart-queries")
    total = sum(c["ok"] + c["failed"] for c in run["query_counts"].values())
    assert total == run["queries"]  # the run's count is the store's (reused answers apart)
    reused = sum(
        1 for e in events if e["type"] == "stream_queried" and e["reused_from"] is not None
    )
    page.wait_for_function(
        "document.getElementById('chart-queries').dataset.bars === "
        f"'{len(run['query_counts'])}' && document.getElementById('chart-queries')"
        f".dataset.queries === '{total}'"
    )
    expect(queries).to_have_attribute("data-reused", str(reused))
    expect(page.locator("[data-testid=header-queries]")).to_have_text(str(total))
    legend = ["failed", "ok"] + (["reused (no sampler)"] if reused else [])
    expect(queries.locator(".legendtext")).to_have_count(len(legend))
    assert sorted(queries.locator(".legendtext").all_text_contents()) == sorted(legend)
    assert queries.locator(".bars path").count() >= len(run["query_counts"])
    for stream in run["query_counts"]:
        expect(queries).to_contain_text(stream)
    finished = next(e for e in events if e["type"] == "run_finished")
    time_chart = page.locator("#chart-time")
    expect(time_chart).to_contain_text(f"planning {finished['planning_s']:.2f} s")
    expect(time_chart).to_contain_text("execution")


def test_line_run_from_the_form(page: Any, server: Server) -> None:
    # The reports the server has are linked from the page.
    link = page.locator("#reports a", has_text="bench-demo")
    expect(link).to_have_attribute("href", "/reports/bench-demo.html")

    # A bad budget: the server's 422 is shown in the form, naming the field.
    page.select_option("#launch-scene", "line-2")
    page.fill("#launch-budget", "-5")
    page.click("#launch-submit")
    error = page.locator("#launch-error")
    expect(error).to_contain_text("422")
    expect(error).to_contain_text("budget")

    viewer_puts: list[dict[str, Any] | None] = []
    page.on("request", lambda r: viewer_puts.append(_viewer_body(r)))
    _record_growth(page)
    run_id = _launch(page, "line-2", "baseline", budget="60")
    expect(error).to_be_hidden()
    _wait_finished(page, run_id)
    growth = page.evaluate("window.__growth")
    assert any(g["live"] and g["nodes"] > 0 for g in growth), growth  # arrived while live
    run = server.api(f"/api/runs/{run_id}")
    assert run["status"] == "solved"
    row = page.locator(f'#runs-list [data-run-id="{run_id}"]')
    expect(row).to_have_attribute("data-status", "solved")
    expect(row).to_contain_text(f"{run['queries']} queries")

    # The status filter keeps the list to one status.
    page.select_option("#status-filter", "failed")
    expect(page.locator("#runs-list [data-run-id]")).to_have_count(0)
    expect(page.locator("#runs-list")).to_contain_text("No runs with status failed")
    page.select_option("#status-filter", "solved")
    expect(row).to_be_visible()
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
    expect(page.locator("#run-header [data-testid=run-status]")).to_have_text("solved")

    _step_back_over_last_node(page, events)

    # The viewer follows what the page shows: a step back is sent, debounced, as that step.
    if server.api("/api/health")["viewer_url"] is not None:
        assert {"run_id": run_id, "step": None} in viewer_puts  # following it live
        # The clicks above can outpace the 200 ms debounce, and a step the view already shows
        # is not sent again: first the view is told the step shown now, then one step back.
        shown = {"run_id": run_id, "step": events[_step(page)]["seq"]}
        page.wait_for_function(
            "shown => { const s = window.dashboard.viewerSync(); return !s.pending"
            " && s.sent?.run_id === shown.run_id && s.sent?.step === shown.step; }",
            arg=shown,
        )
        expected = {"run_id": run_id, "step": events[_step(page) - 1]["seq"]}
        with page.expect_request(lambda r: _viewer_body(r) == expected, timeout=WAIT_MS):
            page.click("#btn-step-back")

    leaf = next(n for n in nodes if n["node_id"] == state["solution"])
    _click_node(page, leaf)
    _check_charts(page, run, events)

    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "page-line-2.png"), full_page=True)


def test_a_run_grows_live_on_the_page_node_by_node(page: Any, server: Server) -> None:
    """The page follows a run's tree while it grows. Each query of the paced domain answers only
    when this test hands it a token, so the run is live, waiting, while the page must show each
    new node: on any machine, however fast or busy."""
    for left in server.tokens.iterdir():
        left.unlink()
    _record_growth(page)
    run_id = _launch(page, "paced-4", "baseline", budget="3600")
    page.locator("#live-badge").wait_for()
    shown = 0
    for i in range(8):  # the walk takes four queries; more tokens than that are never taken
        (server.tokens / f"token-{i}").touch()
        page.wait_for_function(
            """shown => !window.dashboard.state().live
                || window.__growth.some((g) => g.live && g.nodes > shown)""",
            arg=shown,
            timeout=RUN_TIMEOUT_MS,
        )
        if not page.evaluate("window.dashboard.state().live"):
            break
        shown = max(g["nodes"] for g in page.evaluate("window.__growth") if g["live"])
    _wait_finished(page, run_id)
    run = server.api(f"/api/runs/{run_id}")
    assert run["status"] == "solved" and run["queries"] == 4, run
    live = [g["nodes"] for g in page.evaluate("window.__growth") if g["live"]]
    assert len({n for n in live if n > 0}) >= 3, live  # one step per answered query, live
    assert live == sorted(live), live  # following the live end, the tree only grows
    expect(page.locator("#live-badge")).to_be_hidden()
    added = [e for e in server.events(run_id) if e["type"] == "node_added"]
    assert _state(page)["nodes"] == len(added) + 1  # the root and every node added


def test_kitchen_baseline_run_steps_inspects_and_views(page: Any, server: Server) -> None:
    _record_growth(page)
    # kitchen-6 searches for some seconds (a loaded machine took over 120 s): its seconds are
    # no bound, the run ends by solving, on every machine at the same query (the kitchen's
    # motion searches count iterations). How fast it grows is the paced test's to check.
    run_id = _launch(page, "kitchen-6", "baseline", budget="3600")
    _wait_finished(page, run_id)
    live = [g["nodes"] for g in page.evaluate("window.__growth") if g["live"]]
    assert live == sorted(live), live  # following the live end, the tree only grows
    expect(page.locator("#live-badge")).to_be_hidden()

    run = server.api(f"/api/runs/{run_id}")
    assert run["status"] == "solved", run
    events = server.events(run_id)
    nodes = [e for e in events if e["type"] == "node_added"]
    assert _state(page)["nodes"] == len(nodes) + 1

    _step_back_over_last_node(page, events)

    # Replay from the start with play; pause; the step moved and the tree shrank back.
    page.click("#btn-first")
    _expect_step(page, 0, len(events) - 1, 0)
    page.select_option("#play-speed", "10")  # the slowest: a pause lands well before the end
    # Pause as soon as the stepper passes step 10, clicked in the page on that state (a click
    # from here would come a round trip later, however long a busy machine makes that).
    page.evaluate(
        """() => {
            window.__paused = null;
            const label = document.getElementById("step-label");
            const seen = new MutationObserver(() => {
                if (Number(label.dataset.step) <= 10) return;
                seen.disconnect();
                document.getElementById("btn-play").click();
                window.__paused = Number(label.dataset.step);
            });
            seen.observe(label, { attributes: true, attributeFilter: ["data-step"] });
        }"""
    )
    page.click("#btn-play")
    page.wait_for_function("window.__paused !== null")
    paused = page.evaluate("window.__paused")
    page.wait_for_function("!window.dashboard.state().playing")
    assert 10 < paused < len(events) - 1
    _expect_step(page, paused, len(events) - 1)
    page.click("#btn-last")
    _expect_step(page, len(events) - 1, len(events) - 1, len(nodes) + 1)

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
    viewer.locator("canvas").first.wait_for()
    viewer.get_by_text("Connected").first.wait_for()  # viser's own status
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
    assert search.report is not None
    emitter = search.report.emitter  # the run's, which the search's node events go through
    emitter.emit(RunStarted, scene="visit", seed=0, planner="baseline", config={})
    emitter.emit(AbstractPlansFound, plans=plan_summaries(search.skeletons), seconds=0.01)
    top = search.open_plan(0)
    first, second = search.query(top), search.query(top)
    search.query(first)
    search.query(second)  # the same motion from the other IK child: reused
    queries = sum(1 for _, r in search.queries if not r.reused)  # as the planners count them
    emitter.emit(
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
    _expect_step(page, events.index(query), len(events) - 1)
    line = page.locator("#step-event")
    expect(line).to_contain_text(f"reused from node {query['reused_from']}")
    expect(line).to_contain_text("ok")

    # The inspector of the reused node says whose answer it is.
    node = next(e for e in events if e["type"] == "node_added" and e["node_id"] == query["node_id"])
    _click_node(page, node)
    shown = page.locator('#inspector [data-testid="inspector-reused"]')
    expect(shown).to_contain_text(f"the answer of node {query['reused_from']}")
    original = next(
        e for e in events if e["type"] == "stream_queried" and e["node_id"] == query["reused_from"]
    )
    assert original["reused_from"] is None  # the original ran its sampler

    # One count of queries everywhere (planner/figures.py): the samplers that ran; the reused
    # answer is counted apart, in the header and the chart alike, and the list says the same.
    run = server.api(f"/api/runs/{run_id}")
    sampled = sum(1 for e in events if e["type"] == "stream_queried" and e["reused_from"] is None)
    assert run["queries"] == sampled
    page.click("#btn-last")
    expect(page.locator("[data-testid=header-queries]")).to_have_text(str(sampled))
    expect(page.locator("[data-testid=run-header-figures]")).to_contain_text("(+1 reused)")
    chart = page.locator("#chart-queries")
    expect(chart).to_have_attribute("data-queries", str(sampled))
    expect(chart).to_have_attribute("data-reused", "1")
    expect(chart).to_contain_text(f"Queries per stream ({sampled}; 1 reused answers apart)")
    expect(chart.locator(".legendtext", has_text="reused (no sampler)")).to_have_count(1)
    expect(page.locator(f'#runs-list [data-run-id="{run_id}"]')).to_contain_text(
        f"{sampled} queries"
    )


def _watch_bench(page: Any) -> None:
    """Keep every (trials done, status) the benchmark page shows in __bench: each change of
    the benchmark's part of the page, as it happens."""
    page.evaluate(
        """() => {
            window.__bench = [];
            const detail = document.getElementById("bench-detail");
            const changed = () => {
                const bar = detail.querySelector("[data-testid=bench-progress]");
                const status = detail.querySelector("[data-testid=bench-status]");
                if (!bar || !status) return;
                const now = [Number(bar.value), status.textContent];
                const before = window.__bench.at(-1);
                if (!before || before[0] !== now[0] || before[1] !== now[1]) {
                    window.__bench.push(now);
                }
            };
            const all = { subtree: true, childList: true, attributes: true, characterData: true };
            new MutationObserver(changed).observe(detail, all);
        }"""
    )


def _record_bench(db: Path, seconds: dict[int, tuple[float, float]]) -> tuple[str, dict[int, str]]:
    """Record, into the server's store, a done benchmark of baseline and learned on tabletop-3
    whose seed ``s`` took ``seconds[s]`` (baseline, learned) to plan, each trial with a run of
    its own; returns its id and, per seed, the compare view's hash of its two runs."""
    from planner.bench import create_bench, make_config
    from planner.store import BenchTrialRecord, RunStore

    planners = ("baseline", "learned")
    config = make_config(
        "tabletop-3",
        planners,
        trials=len(seconds),
        seed_start=min(seconds),
        budget_s=30,
        domain=str(TABLETOP),
    )
    hashes = {}
    with RunStore(db) as store:
        bench_id = create_bench(store, config)
        for seed, times in seconds.items():
            runs = []
            for planner, planning_s in zip(planners, times, strict=True):
                run_id = store.create_run("tabletop-3", seed, planner, {})
                store.finish_run(run_id, "solved", planning_s=planning_s, queries=1)
                store.record_trial(
                    BenchTrialRecord(
                        bench_id=bench_id,
                        seed=seed,
                        planner=planner,
                        run_id=run_id,
                        status="solved",
                        valid=True,
                        planning_s=planning_s,
                        execution_s=1.0,
                        oracle_s=None,
                        queries=1,
                        error=None,
                    )
                )
                runs.append(run_id)
            hashes[seed] = f"#compare={runs[0]},{runs[1]}"
        store.set_bench_status(bench_id, "done")
    return bench_id, hashes


def _hover_scatter(page: Any, seed: int, seeds: list[int]) -> tuple[set[int], int]:
    """Put the mouse on the scatter's point of ``seed``, at the whole pixel nearest to it (where
    a mouse can be); check that the hover names every seed whose marker is under the mouse, and
    no seed farther than a pixel beyond the marker; return the seeds it names and the seed a
    click there must open: the one whose point is nearest the mouse (then the lowest seed)."""
    where = {s: page.evaluate(f"window.dashboard.scatterPoint({s})") for s in seeds}
    x, y = round(where[seed]["x"]), round(where[seed]["y"])
    away = {s: math.hypot(p["x"] - x, p["y"] - y) for s, p in where.items()}
    under = {s for s, d in away.items() if d <= SCATTER_MARKER_PX / 2}
    near = {s for s, d in away.items() if d <= SCATTER_MARKER_PX / 2 + 1}
    hover = page.locator("[data-testid=bench-scatter] .hoverlayer")
    page.mouse.move(0, 0)  # off the chart: no hover left from before
    expect(hover.locator(".hovertext")).to_have_count(0)
    page.mouse.move(x, y)
    expect(hover).to_contain_text(f"seed {seed}")
    named = {int(s) for s in re.findall(r"seed (\d+)", hover.text_content() or "")}
    assert under <= named <= near, (seed, named, away)
    return named, min(seeds, key=lambda s: (away[s], s))


def _improvement_words(paired: dict[str, Any]) -> str:
    """What the page prints of a paired improvement (as tamp report's "41.9% less")."""
    mean = paired["mean"]
    return f"{100 * abs(mean):.1f}% {'less' if mean >= 0 else 'more'}"


def test_benchmark_compare_train_and_run_from_the_page(page: Any, server: Server) -> None:
    """A researcher's loop on the tutorial's tiny domain: a benchmark of two planners
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
    expect(error).to_contain_text("422")
    expect(error).to_contain_text("planners")
    for planner in ("baseline", "learned"):
        page.check(f"[data-testid=bench-planner-{planner}]")
    page.fill("#bench-trials", "3")
    page.fill("#bench-budget", "30")
    _watch_bench(page)  # from before the launch: every state the page shows
    page.click("[data-testid=bench-submit]")
    page.wait_for_function("location.hash.startsWith('#bench=')")
    expect(error).to_be_hidden()
    bench_id = page.evaluate("decodeURIComponent(location.hash.slice('#bench='.length))")
    row = page.locator(f'#bench-list [data-bench-id="{bench_id}"]')
    expect(row).to_contain_text("tabletop-3")
    expect(row).to_contain_text("baseline, learned")
    expect(page.locator("[data-testid=bench-status]")).to_have_text("done", timeout=RUN_TIMEOUT_MS)
    seen = page.evaluate("window.__bench")
    done = [d for d, _ in seen]
    assert done == sorted(done), seen  # the bar only grows
    assert any(status == "running" and d < 6 for d, status in seen), seen  # watched it go
    expect(page.locator("[data-testid=bench-progress-text]")).to_have_text("6 / 6 trials")
    expect(row).to_have_attribute("data-status", "done")

    # The per-planner table and the paired improvement are tamp report's figures.
    bench = server.api(f"/api/benchmarks/{bench_id}")
    summary = bench["summary"]
    table = page.locator("[data-testid=bench-table]")
    for planner, row in summary["planners"].items():
        expect(table.locator(f'tr[data-planner="{planner}"]')).to_contain_text(f"{row['solved']} (")
    paired = summary["paired"]["learned"]["total_censored"]
    paired_row = page.locator('[data-testid=bench-paired] tr[data-planner="learned"]')
    shown = paired_row.locator("[data-measure=total]")
    expect(shown).to_contain_text(_improvement_words(paired))
    expect(shown).to_contain_text(f"{paired['n']} seeds")
    # Three seeds: the interval says it is rough (planner.figures.MIN_INTERVAL_SEEDS).
    expect(shown.locator("[data-testid=interval-note]")).to_have_text("rough: only 3 seeds")

    # The scatter: a point per seed; a hover names the seed under the mouse (every seed there,
    # where points overlap: test_overlapping_points_...); a click opens the nearest seed's two
    # runs compared.
    scatter = page.locator("[data-testid=bench-scatter]")
    expect(scatter).to_have_attribute("data-points", "3")
    expect(scatter.locator(".shapelayer path")).to_have_count(1)  # the diagonal
    page.select_option("[data-testid=scatter-measure]", "planning")
    expect(scatter).to_have_attribute("data-measure", "planning")
    seeds = [t["seed"] for t in summary["trials"]]
    _, nearest = _hover_scatter(page, seeds[0], seeds)
    page.screenshot(path=str(ARTIFACTS / "benchmark.png"), full_page=True)
    page.mouse.down()
    page.mouse.up()
    trial = next(t for t in summary["trials"] if t["seed"] == nearest)
    a, b = trial["baseline"]["run_id"], trial["learned"]["run_id"]
    page.wait_for_function(f"location.hash === '#compare={a},{b}'")

    # The compare view: both trees drawn whole, where they parted ringed, the same figures.
    page.wait_for_function("document.body.dataset.compare === 'drawn'")
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
    expect(page.locator("#compare-curve .scatterlayer .trace")).to_have_count(2)
    page.screenshot(path=str(ARTIFACTS / "compare.png"), full_page=True)
    # The view is shareable: its URL opened afresh draws the same two trees.
    page.goto("about:blank")
    page.goto(f"{server.url}/#compare={a},{b}")
    page.wait_for_function("document.body.dataset.compare === 'drawn'")
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
    expect(page.locator("[data-testid=model-seeds]")).to_contain_text("tabletop-3: 3 seeds")
    validation = page.locator("[data-testid=model-validation]")
    for s in model["metadata"]["validation"]["streams"]:
        auc = validation.locator(f'tr[data-stream="{s["stream"]}"] [data-testid=auc]')
        expect(auc).to_have_text("\u2013" if s["auc"] is None else str(round(s["auc"], 3)))
    page.locator("#model-calibration .scatterlayer .trace").first.wait_for()
    page.screenshot(path=str(ARTIFACTS / "model.png"), full_page=True)

    # ... and a run launched with it, on the scene it was trained on.
    expect(page.locator("[data-testid=model-launch-scene]")).to_have_value("tabletop-3")
    page.click("[data-testid=model-launch-submit]")
    page.wait_for_function("location.hash.startsWith('#run=')")
    run_id = page.evaluate("decodeURIComponent(location.hash.slice('#run='.length))")
    _wait_finished(page, run_id)
    run = server.api(f"/api/runs/{run_id}")
    assert run["status"] == "solved" and run["config"]["model_name"] == name
    expect(page.locator("[data-testid=run-model]")).to_have_text(name)

    # Selecting a node in the tree shows it in the 3D view.
    if server.api("/api/health")["viewer_url"] is not None:
        events = server.events(run_id)
        leaf = next(e for e in events if e["type"] == "solution_found")["node_id"]
        page.click("#btn-fit")
        position = page.evaluate(f"window.dashboard.nodePosition({leaf})")
        with page.expect_request(
            lambda r: (_viewer_body(r) or {}).get("node") == leaf, timeout=WAIT_MS
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
        page.wait_for_function("window.dashboard.state().pickedReady")  # clicks from now on
        with viser_client(server.api("/api/health")["viewer_url"]) as viser:
            viser.click("/search/confs", instance_index=0)  # the first configuration sampled
            expect(picked).to_contain_text(f"ghost of node #{conf['node_id']}")  # asked every 1.5 s
        expect(picked).to_contain_text(conf["label"])
        page.wait_for_function(f"window.dashboard.state().selected === {conf['node_id']}")
        node = page.locator("[data-testid=inspector-node]")
        expect(node).to_have_text(re.compile(rf"^#{conf['node_id']} "))
        _wait_viewer_node(server, conf["node_id"])
    page.screenshot(path=str(ARTIFACTS / "run-with-model.png"), full_page=True)


def _wait_viewer_node(server: Server, node_id: int) -> None:
    """Until the 3D view shows ``node_id`` as the page's selection (the server's state; a
    minute at most)."""
    deadline = time.monotonic() + WAIT_MS / 1000
    while server.api("/api/viewer")["node"] != node_id:
        assert time.monotonic() < deadline, server.api("/api/viewer")
        time.sleep(0.2)


def test_overlapping_points_of_the_scatter_each_name_their_seed(page: Any, server: Server) -> None:
    """Seeds that took the same seconds are drawn one over the other: a hover there names
    every seed under the mouse, not only the one drawn last, and a click opens the two runs of
    the seed nearest the mouse."""
    seconds = {  # baseline, learned planning seconds
        7000: (4.0, 3.0),
        7001: (4.0, 3.0),  # on 7000
        7002: (4.02, 3.01),  # a pixel or two away: the markers overlap
        7003: (9.0, 2.0),
    }
    bench_id, hashes = _record_bench(server.db, seconds)
    scatter = page.locator("[data-testid=bench-scatter]")
    seeds = list(seconds)
    for seed in seeds:
        # A fresh page each time: plotly takes two clicks on one chart within 300 ms for a
        # double click (which resets the axes), however far apart in the test they are.
        page.goto("about:blank")
        page.goto(f"{server.url}/#bench={bench_id}")
        expect(scatter).to_be_visible()
        expect(scatter).to_have_attribute("data-points", "4")
        page.select_option("[data-testid=scatter-measure]", "planning")
        expect(scatter).to_have_attribute("data-measure", "planning")
        named, nearest = _hover_scatter(page, seed, seeds)
        assert named == ({7003} if seed == 7003 else {7000, 7001, 7002}), (seed, named)
        if seed == 7002:
            ARTIFACTS.mkdir(exist_ok=True)
            page.screenshot(path=str(ARTIFACTS / "scatter-overlap.png"))
        page.mouse.down()
        page.mouse.up()
        page.wait_for_function("hash => location.hash === hash", arg=hashes[nearest])


def test_a_benchmark_cancelled_from_the_page_keeps_its_trials(page: Any, server: Server) -> None:
    # The paced walk's four queries each take a token: four tokens let the first trial solve,
    # and the second waits, on any machine, until the benchmark is cancelled.
    for left in server.tokens.iterdir():
        left.unlink()
    for i in range(4):
        (server.tokens / f"token-{i}").touch()
    page.goto(f"{server.url}/#benchmarks")
    page.wait_for_function("document.querySelectorAll('#bench-scene option').length > 0")
    page.select_option("#bench-scene", "paced-4")
    page.uncheck("[data-testid=bench-planner-learned]")
    page.fill("#bench-trials", "3")
    page.fill("#bench-workers", "1")
    page.click("[data-testid=bench-submit]")
    page.wait_for_function("location.hash.startsWith('#bench=')")
    page.wait_for_function(
        "Number(document.querySelector('[data-testid=bench-progress]')?.value) >= 1",
        timeout=RUN_TIMEOUT_MS,
    )
    page.click("[data-testid=bench-cancel]")
    # Cancelled once its worker stopped: the waiting trial is not kept, no trial comes after.
    status = page.locator("[data-testid=bench-status]")
    expect(status).to_have_text("cancelled", timeout=RUN_TIMEOUT_MS)
    expect(page.locator("[data-testid=bench-progress]")).to_have_attribute("value", "1")
    expect(page.locator("[data-testid=bench-resume]")).to_have_text("Resume the 2 missing trials")
    expect(page.locator("[data-testid=bench-trials-table] tr[data-seed]")).to_have_count(1)


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
    expect(empty).to_contain_text("No series yet: tamp horizon --scenes")

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
    )
    select = page.locator("[data-testid=horizon-series]")
    expect(select).to_have_value(series["key"])
    expect(select.locator("option:checked")).to_have_text(
        "tabletop2d: baseline, sequential — 2 seeds, 30 s"
    )
    for chart, measure in zip(charts, ("planning", "total"), strict=True):
        traces = page.evaluate(
            f"document.getElementById('{chart}').data.map((t) => [t.name, t.y, t.error_y?.array])"
        )
        if measure == "planning":  # the skeleton source's share, dashed, after the planners
            dashed = traces[len(planners) :]
            assert [t[0] for t in dashed] == [f"{p}: skeletons" for p in planners]
            for (_, ys, _), planner in zip(dashed, planners, strict=True):
                mine = [p["skeleton"] for p in series["points"] if p["planner"] == planner]
                assert ys == pytest.approx([m[0] for m in mine])
            traces = traces[: len(planners)]
        assert [t[0] for t in traces] == planners  # one line per planner
        for (_, ys, ups), planner in zip(traces, planners, strict=True):
            mine = [p[measure] for p in series["points"] if p["planner"] == planner]
            assert ys == pytest.approx([m[0] for m in mine])  # objects 1 then 2
            assert ups == pytest.approx([m[2] - m[0] for m in mine])  # the interval as bars

    # A hover names the scene, the seeds solved and the benchmark; a click opens it.
    page.locator("#horizon-total").scroll_into_view_if_needed()
    point = _plot_point(page, "horizon-total", 0, 1)  # baseline on tabletop-2
    page.mouse.move(point["x"], point["y"])
    hover = page.locator("#horizon-total .hoverlayer .hovertext")
    expect(hover).to_have_count(1)
    for words in ("baseline", "tabletop-2", "solved 2 / 2 seeds", ids[1]):
        expect(hover).to_contain_text(words)
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "horizon.png"), full_page=True)
    page.mouse.click(point["x"], point["y"])
    page.wait_for_function(f"location.hash === '#bench={ids[1]}'")
    page.wait_for_function(f"(document.body.dataset.bench ?? '').startsWith('{ids[1]}:')")
    expect(page.locator("[data-testid=bench-head]")).to_contain_text("tabletop-2")


# --- the tree reads; skeletons come with word; one count of each figure ------------------------


def _synthetic_run(db: Path) -> tuple[str, list[dict[str, Any]]]:
    """Record, into the server's store, a finished run made of events written here (the store
    takes any valid events): the skeleton source's progress before the first skeletons, a plan
    node with five failed IK queries and one that binds, a motion and a reused one, then the
    source at work again mid-search and a later batch of skeletons (skeletons_added). Returns
    its id and events."""
    from planner.events import event_from_dict
    from planner.store import RunStore

    with RunStore(db) as store:
        run_id = store.create_run("line-2", 0, "learned", {})
    events: list[dict[str, Any]] = []

    def emit(kind: str, **fields: Any) -> None:
        seq = len(events)
        events.append({"type": kind, "run_id": run_id, "seq": seq, "t": 0.1 * seq, **fields})

    def plan(index: int, streams: list[str]) -> dict[str, Any]:
        return {"index": index, "cost": 2.0, "actions": [f"(act{index} b3)"], "streams": streams}

    def query(node: int, stream: str, ok: bool, **more: Any) -> None:
        emit(
            "stream_queried",
            node_id=node,
            stream=stream,
            input_names=["?b", "?p"],
            inputs=["b3", "p0"],
            input_labels=["block b3", "pose p0"],
            success=ok,
            wall_s=0.25 if ok else 0.5,
            cpu_s=0.2,
            execution_s=2.5 if ok and stream == "plan-motion" else 0.0,
            error=None,
            reason=None if ok else "no IK solution",
            **more,
        )

    def node(node_id: int, parent: int, plan_index: int, depth: int, stream: str | None,
             ok: bool = True) -> None:  # fmt: skip
        emit(
            "node_added",
            node_id=node_id,
            parent_id=parent,
            plan_index=plan_index,
            depth=depth,
            stream=stream,
            success=ok,
            outputs=[[1.0, 2.0]] if stream is not None and ok else [],
            output_names=[f"?q{node_id}"] if stream is not None and ok else [],
            label=f"{stream or 'plan'} #{node_id}",
        )

    def predict(node_id: int, q: float) -> None:
        emit("model_prediction", node_id=node_id, p_s=0.8, r_s=0.3, r_f=0.6, r_m=2.0, q=q)

    emit("run_started", scene="line-2", seed=0, planner="learned", config={})
    emit("skeleton_progress", phase="instantiate", message="instantiating 120 streams", seconds=0.5)
    emit("skeleton_progress", phase="search", message="searching for skeletons", seconds=1.2)
    emit(
        "abstract_plans_found",
        plans=[plan(0, ["inverse-kinematics", "plan-motion"]), plan(1, ["sample-grasp"])],
        seconds=1.5,
    )
    node(1, 0, 0, 0, None)
    predict(1, 10.0)
    for failed in range(2, 7):  # a fan of five failed IK queries
        query(failed, "inverse-kinematics", False)
        node(failed, 1, 0, 1, "inverse-kinematics", ok=False)
    query(7, "inverse-kinematics", True)
    node(7, 1, 0, 1, "inverse-kinematics")
    predict(7, 5.0)
    query(8, "plan-motion", True)
    node(8, 7, 0, 2, "plan-motion")
    query(9, "plan-motion", True, reused_from=8)  # no sampler ran
    node(9, 7, 0, 2, "plan-motion")
    emit("skeleton_progress", phase="replan", message="replanning without ik(b3 p0)", seconds=0.3)
    emit(
        "skeletons_added",
        plans=[plan(2, ["sample-grasp", "inverse-kinematics"])],
        seconds=0.4,
        reason="all dead",
        learned=["ik(b3 p0) exhausted"],
    )
    node(10, 0, 2, 0, None)
    emit(
        "run_finished",
        status="timeout",
        planning_s=3.0,
        execution_s=None,
        oracle_s=None,
        queries=7,
        message="no plan (timeout)",
        skeleton_s=1.9,
    )
    with RunStore(db) as store:
        store.write_events(run_id, [event_from_dict(e) for e in events])
        store.finish_run(run_id, "timeout", planning_s=3.0, queries=7, message="no plan (timeout)")
    return run_id, events


def _open_run(page: Any, server: Server, run_id: str) -> None:
    """Open the page afresh on run ``run_id`` and wait until all of it is shown."""
    page.goto("about:blank")
    page.goto(f"{server.url}/#run={run_id}")
    page.wait_for_function(
        "id => window.dashboard.state().runId === id && window.dashboard.state().done", arg=run_id
    )


def test_a_finished_run_opens_in_bulk_and_its_tree_reads(page: Any, server: Server) -> None:
    """A finished run is read in pages and shown as finished (no websocket, never a live
    badge); its rows are labelled by stream, failed fans folded, nodes found by stream, object
    or id; the inspector puts the model's prediction beside what the query did; the skeleton
    source's word shows at the steps where it worked; the figures agree."""
    run_id, events = _synthetic_run(server.db)
    sockets: list[str] = []
    pages: list[str] = []
    page.on("websocket", lambda ws: sockets.append(ws.url) if "/api/runs/" in ws.url else None)
    page.on("request", lambda r: pages.append(r.url) if "/events?" in r.url else None)
    page.evaluate(
        """() => {
            window.__badge = [];
            const badge = document.getElementById("live-badge");
            new MutationObserver(() => window.__badge.push(!badge.hidden)).observe(
                badge, { attributes: true, attributeFilter: ["hidden"] });
        }"""
    )
    page.evaluate("id => window.dashboard.selectRun(id)", run_id)
    page.wait_for_function(
        "id => window.dashboard.state().runId === id && window.dashboard.state().done", arg=run_id
    )
    state = _state(page)
    assert state["last"] == len(events) - 1 and state["step"] == state["last"]
    assert not state["live"] and sockets == [] and True not in page.evaluate("window.__badge")
    assert pages and all(f"/api/runs/{run_id}/events?" in url for url in pages)
    expect(page.locator("#live-badge")).to_be_hidden()

    # One count of queries: the header, the chart and the list; reused answers apart.
    expect(page.locator("[data-testid=header-queries]")).to_have_text("7")
    expect(page.locator("[data-testid=run-header-figures]")).to_contain_text("(+1 reused)")
    expect(page.locator("#chart-queries")).to_have_attribute("data-queries", "7")
    expect(page.locator("#chart-queries")).to_have_attribute("data-reused", "1")
    expect(page.locator("[data-testid=header-skeletons]")).to_have_text(
        "3 skeletons (1 arrived during the search)"
    )
    assert state["skeletons"] == 3 and state["queries"] == 7 and state["reused"] == 1

    # Rows are labelled by what they hold; the five failed IK queries are one fan.
    page.click("#btn-fit")
    rows = {r["level"]: r["name"] for r in page.evaluate("window.dashboard.rows()")}
    assert rows == {0: "root", 1: "stream plans", 2: "inverse-kinematics", 3: "plan-motion"}
    assert state["fans"] == 1
    fan = page.evaluate("window.dashboard.fanPosition(1)")
    folded = [page.evaluate(f"window.dashboard.nodePosition({n})") for n in range(2, 7)]
    assert all(p == folded[0] for p in folded)  # one slot
    page.mouse.click(fan["x"], fan["y"])  # a click opens it
    page.wait_for_function("window.dashboard.state().fans === 0")
    opened = {json.dumps(page.evaluate(f"window.dashboard.nodePosition({n})")) for n in range(2, 7)}
    assert len(opened) == 5

    # Search: by node id, by object, by stream; the first match is selected and shown.
    assert page.evaluate("window.dashboard.search('#7')") == [7]
    expect(page.locator("[data-testid=inspector-node]")).to_have_text(re.compile(r"^#7 "))
    expect(page.locator("#search-count")).to_have_text("1 of 1 match")
    by_object = page.evaluate("window.dashboard.search('b3')")
    assert {1, 2, 7, 8, 9, 10} <= set(by_object)  # inputs and plan actions name b3
    assert page.evaluate("window.dashboard.search('plan-motion')") == [8, 9]
    expect(page.locator("#search-count")).to_have_text("1 of 2 matches")
    page.click("#search-next")
    page.wait_for_function("window.dashboard.state().selected === 9")
    assert page.evaluate("window.dashboard.search('no such thing')") == []
    expect(page.locator("#search-count")).to_have_text("no match")

    # Predicted beside actual: node 7's query, by node 1's prediction; node 1's next query
    # against its six children.
    page.evaluate("window.dashboard.select(7)")
    pva = page.locator("[data-testid=inspector-pva]")
    expect(pva.locator("tr[data-row=p_s]")).to_contain_text("0.8")
    expect(pva.locator("tr[data-row=p_s]")).to_contain_text("ok")
    expect(pva.locator("tr[data-row=r_s] td").nth(1)).to_have_text("250.0 ms")
    expect(pva.locator("tr[data-row=r_m]")).to_contain_text("2.00 s")
    page.evaluate("window.dashboard.select(2)")
    expect(pva.locator("tr[data-row=p_s] td").nth(1)).to_have_text("failed")
    expect(pva.locator("tr[data-row=r_f] td").nth(1)).to_have_text("500.0 ms")
    page.evaluate("window.dashboard.select(1)")
    expect(page.locator("[data-testid=inspector-prediction] tr[data-row=p_s]")).to_contain_text(
        "1 of 6 ok"
    )
    # One Q scale: the legend's is planner.figures', with the selected node's Q on it.
    legend = page.locator("[data-testid=q-legend]")
    lo, hi = figures.q_scale([10.0, 5.0]) or (0.0, 0.0)
    expect(legend).to_have_attribute("data-lo", str(int(lo)))
    expect(legend).to_have_attribute("data-hi", str(int(hi)))
    expect(page.locator("[data-testid=q-selected]")).to_have_text("#1: 10.00 s")
    assert page.evaluate("window.dashboard.colourOf(5)") == list(figures.q_rgb_at(0.0))
    assert page.evaluate("window.dashboard.colourOf(10)") == list(figures.q_rgb_at(1.0))

    # The skeleton source's word, at the steps where it worked.
    first = next(i for i, e in enumerate(events) if e["type"] == "skeleton_progress")
    page.evaluate(f"window.dashboard.step({first})")
    expect(page.locator("#tree-empty")).to_have_text(
        "Computing skeletons: instantiating 120 streams (instantiate, 500.0 ms)"
    )
    replan = max(i for i, e in enumerate(events) if e["type"] == "skeleton_progress")
    page.evaluate(f"window.dashboard.step({replan})")
    note = page.locator("[data-testid=skeleton-note]")
    expect(note).to_have_text(
        "Computing more skeletons: replanning without ik(b3 p0) (replan, 300.0 ms)"
    )
    page.evaluate(f"window.dashboard.step({replan + 1})")
    expect(note).to_be_hidden()
    expect(page.locator("#step-event")).to_contain_text(
        "1 more skeleton (plan 2) in 400.0 ms, asked for all dead; learned 1: ik(b3 p0) exhausted"
    )
    page.evaluate(f"window.dashboard.step({len(events) - 1})")
    page.evaluate("window.dashboard.select(10)")
    expect(page.locator("[data-testid=inspector-plan] summary")).to_contain_text(
        "arrived during the search"
    )


def _canvas_ink(page: Any) -> int:
    """How many pixels of the tree's canvas are drawn on (not transparent)."""
    return int(
        page.evaluate(
            """() => {
                const c = document.getElementById("tree-canvas");
                const data = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
                let n = 0;
                for (let i = 3; i < data.length; i += 4) if (data[i] !== 0) n += 1;
                return n;
            }"""
        )
    )


def _select_row(page: Any, run_id: str) -> None:
    page.locator(f'#runs-list [data-run-id="{run_id}"]').click()
    page.wait_for_function(
        "id => window.dashboard.state().runId === id && window.dashboard.state().done", arg=run_id
    )


def test_switching_runs_of_three_domains_leaves_nothing_stale(page: Any, server: Server) -> None:
    """Per-run state has one owner: after a switch of run the inspector, the legend, the
    search, the 3D view's note of a clicked ghost, the slider and the canvas are the new run's
    (a run with no events draws nothing, not the last tree), and the 3D view forgets the old
    run's click; compare offers runs of the same scene first, never another domain's."""
    runs = {}
    for name, trial in {
        "kitchen": Trial("kitchen-1", 0, "learned", 120.0),
        "tabletop": Trial("tabletop-3", 0, "baseline", 60.0, domain=str(TABLETOP)),
        "line": Trial("line-2", 0, "baseline", 60.0),
    }.items():
        result = run_trial(trial, str(server.db))
        assert result.status == "solved" and result.run_id is not None, result
        runs[name] = result.run_id
    from planner.store import RunStore

    with RunStore(server.db) as store:
        empty = store.create_run("kitchen-1", 5, "baseline", {})  # no events yet
    page.reload()
    page.wait_for_function("document.querySelectorAll('#runs-list [data-run-id]').length >= 4")

    # The kitchen run: a node selected, a search made, a ghost clicked in the 3D view.
    _select_row(page, runs["kitchen"])
    kitchen = server.events(runs["kitchen"])
    qs = [e["q"] for e in kitchen if e["type"] == "model_prediction"]
    scale = figures.q_scale(qs)
    assert scale is not None
    legend = page.locator("[data-testid=q-legend]")
    expect(legend).to_be_visible()
    assert float(legend.get_attribute("data-lo") or "nan") == pytest.approx(scale[0])
    assert float(legend.get_attribute("data-hi") or "nan") == pytest.approx(scale[1])
    conf = next(
        e for e in kitchen if e["type"] == "node_added" and e["stream"] == "inverse-kinematics"
    )
    page.evaluate("window.dashboard.search('inverse-kinematics')")
    page.wait_for_function(f"window.dashboard.state().selected === {conf['node_id']}")
    expect(page.locator("#tree-search")).to_have_value("inverse-kinematics")
    viewer_url = server.api("/api/health")["viewer_url"]
    if viewer_url is not None:
        _wait_viewer_node(server, conf["node_id"])  # the view shows the kitchen run, selected
        page.wait_for_function("window.dashboard.state().pickedReady")  # clicks from now on
        with viser_client(viewer_url) as viser:
            viser.click("/search/confs", instance_index=0)
            expect(page.locator("[data-testid=viewer-picked]")).to_contain_text("ghost of node")
        assert server.api("/api/viewer")["picked"]["run_id"] == runs["kitchen"]

    def nothing_of_the_last_run(run_id: str, events: list[dict[str, Any]]) -> None:
        nodes = sum(1 for e in events if e["type"] == "node_added")
        expect(page.locator("#node-count")).to_have_attribute("data-nodes", str(nodes + 1))
        _expect_step(page, len(events) - 1, len(events) - 1)
        expect(page.locator("#inspector-hint")).to_be_visible()
        expect(page.locator("[data-testid=inspector-title]")).to_have_text("Node")
        expect(page.locator("[data-testid=viewer-picked]")).to_be_hidden()
        expect(page.locator("#tree-search")).to_have_value("")
        expect(page.locator("#search-count")).to_have_text("")
        expect(page.locator("#step-slider")).to_have_attribute("max", str(len(events) - 1))
        assert _state(page)["selected"] is None and _state(page)["matches"] == 0
        if viewer_url is not None:  # the view shows this run, and no click of the last one
            deadline = time.monotonic() + WAIT_MS / 1000
            while (shown := server.api("/api/viewer"))["run_id"] != run_id:
                assert time.monotonic() < deadline, shown
                time.sleep(0.2)
            assert shown["picked"] is None, shown  # never the last run's, even before it is drawn

    _select_row(page, runs["tabletop"])
    nothing_of_the_last_run(runs["tabletop"], server.events(runs["tabletop"]))
    expect(legend).to_be_hidden()  # the baseline predicts nothing: no Q scale of the last run

    # A run with no events yet draws nothing, not the tree of the run shown before.
    assert _canvas_ink(page) > 0
    _select_row(page, empty)
    expect(page.locator("#tree-empty")).to_be_visible()
    expect(page.locator("#node-count")).to_have_attribute("data-nodes", "0")
    page.wait_for_function("() => new Promise((ok) => requestAnimationFrame(() => ok(true)))")
    assert _canvas_ink(page) == 0
    expect(legend).to_be_hidden()

    _select_row(page, runs["line"])
    nothing_of_the_last_run(runs["line"], server.events(runs["line"]))
    # Compare offers a run of the same scene, else nothing chosen: never the kitchen's.
    compare = page.locator("[data-testid=compare-with]")
    if compare.count():
        chosen = compare.input_value()
        assert chosen == "" or server.api(f"/api/runs/{chosen}")["scene"] == "line-2"
        assert runs["kitchen"] not in compare.locator("option").evaluate_all(
            "options => options.map((o) => o.value)"
        )

    # Back to the kitchen: its own scale again, and nothing selected.
    _select_row(page, runs["kitchen"])
    nothing_of_the_last_run(runs["kitchen"], kitchen)
    assert float(legend.get_attribute("data-lo") or "nan") == pytest.approx(scale[0])


def test_the_3d_view_stands_beside_the_tree_or_below_it(page: Any, server: Server) -> None:
    """At 1600x1000 the 3D view stands beside the tree (the same iframe, never reloaded, moved
    by a button); at 1280x800 below the stepper. Screenshots of both for docs/dashboard.md."""
    if server.api("/api/health")["viewer_url"] is None:
        pytest.skip("this server runs without a 3D view")
    run_id = _run_with_a_tree(server)
    page.evaluate("localStorage.removeItem('tamp.sideBySide')")  # the width decides
    page.set_viewport_size({"width": 1600, "height": 1000})
    _open_run(page, server, run_id)
    frame, tree = page.locator("#viewer-frame"), page.locator("#tree-canvas")
    expect(page.locator("body")).to_have_class(re.compile("side-by-side"))
    viewer = page.frame_locator("#viewer-frame")
    viewer.get_by_text("Connected").first.wait_for()
    notice = viewer.locator(".mantine-Notification-root button")  # "Software WebGL ..."
    if notice.count():
        notice.first.click()
    f, t = frame.bounding_box(), tree.bounding_box()
    assert f is not None and t is not None
    assert f["x"] > t["x"] + t["width"] - 1 and abs(f["y"] - t["y"]) < 60  # beside
    src = frame.get_attribute("src")
    page.evaluate("window.dashboard.search('inverse-kinematics')")
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "dashboard-side-by-side.png"))
    page.click("[data-testid=btn-layout]")
    expect(page.locator("body")).not_to_have_class(re.compile("side-by-side"))
    f, t = frame.bounding_box(), tree.bounding_box()
    assert f is not None and t is not None and f["y"] > t["y"] + t["height"]  # below
    assert frame.get_attribute("src") == src
    page.click("[data-testid=btn-layout]")  # back, and remembered
    expect(page.locator("body")).to_have_class(re.compile("side-by-side"))
    page.evaluate("localStorage.removeItem('tamp.sideBySide')")
    page.set_viewport_size({"width": 1280, "height": 800})
    _open_run(page, server, run_id)
    expect(page.locator("body")).not_to_have_class(re.compile("side-by-side"))
    page.screenshot(path=str(ARTIFACTS / "dashboard-1280.png"))
    page.set_viewport_size({"width": 1440, "height": 1000})


def _run_with_a_tree(server: Server) -> str:
    """A solved learned kitchen-2 run in the server's store (made once)."""
    runs = server.api("/api/runs?planner=learned&status=solved&limit=500")["runs"]
    mine = [r for r in runs if r["scene"] == "kitchen-2"]
    if mine:
        return str(mine[0]["id"])
    result = run_trial(Trial("kitchen-2", 0, "learned", 120.0), str(server.db))
    assert result.status == "solved" and result.run_id is not None, result
    return result.run_id


def test_a_run_bounded_from_the_form_stops_at_its_queries(page: Any, server: Server) -> None:
    """The form's Max queries goes with the launch: the run stops there whatever its seconds
    (a line-2 plan needs at least four queries), and its row and header say timeout."""
    page.fill("#launch-max-queries", "3")
    run_id = _launch(page, "line-2", "baseline", budget="600")
    _wait_finished(page, run_id)
    run = server.api(f"/api/runs/{run_id}")
    assert run["config"]["max_queries"] == 3 and run["config"]["budget_s"] == 600
    assert (run["status"], run["queries"]) == ("timeout", 3)
    assert run["message"] == "no plan (query budget of 3 reached)"
    expect(page.locator("#run-header [data-testid=run-status]")).to_have_text("timeout")
    # Emptied, the field asks for no bound.
    page.fill("#launch-max-queries", "")
    again = _launch(page, "line-2", "baseline", budget="60")
    assert server.api(f"/api/runs/{again}")["config"]["max_queries"] is None

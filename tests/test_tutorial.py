"""The tutorial domain as a user runs it: copied into a folder of their own and used through the
``tamp`` command alone (abstract plans, the baseline, data collection, training, the learned
planner with the trained model, a small benchmark), then through ``tamp serve``: a run launched
over REST, its tree seen on the page in a real browser."""

from __future__ import annotations

import json
import shutil
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from app.browser import CHROMIUM_ARGS, require_chromium
from tests.serving import TAMP, request, serving

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = ROOT / "examples" / "tabletop2d"


def tamp(*args: str, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    """``tamp ARGS`` in a fresh process, as a user types it."""
    done = subprocess.run(
        [str(TAMP), *args], cwd=cwd, capture_output=True, text=True, timeout=timeout
    )
    assert done.returncode == 0, f"tamp {' '.join(args)}:\n{done.stdout}\n{done.stderr}"
    return done


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A user's folder with their copy of the tutorial domain, called ``mydomain``."""
    root = tmp_path_factory.mktemp("user")
    shutil.copytree(TUTORIAL, root / "mydomain", ignore=shutil.ignore_patterns("__pycache__"))
    return root


@pytest.fixture(scope="module")
def trained(work: Path) -> Path:
    """Runs collected with the baseline and a model trained on them, by the command line."""
    tamp(
        "collect",
        "--scene",
        "tabletop-3",
        "--domain",
        "mydomain",
        "--trials",
        "6",
        "--workers",
        "2",
        "--budget",
        "30",
        "--db",
        "runs.db",
        cwd=work,
    )
    out = tamp(
        "train", "--db", "runs.db", "--out", "models/tabletop.pt", "--epochs", "100", cwd=work
    )
    assert "domain tabletop2d" in out.stdout
    assert "test-cfree" in out.stdout and "inverse-kinematics" in out.stdout
    return work / "models" / "tabletop.pt"


def test_abstract_plans_and_the_baseline_from_a_copied_folder(work: Path) -> None:
    scene = "mydomain/scenes/tabletop-2.json"  # its "domain" is "..": the folder above
    out = json.loads(
        tamp(
            "abstract", "--scene", scene, "--k", "5", "--planner", "kstar", "--json", cwd=work
        ).stdout
    )
    assert out["domain"] == "tabletop2d" and len(out["plans"]) == 5
    assert all(p["valid"] for p in out["plans"])
    streams = {s["stream"] for p in out["plans"] for s in p["stream_plan"]}
    assert {"sample-pose", "test-cfree", "inverse-kinematics", "plan-motion"} <= streams

    tamp(
        "plan",
        "--scene",
        "tabletop-2",
        "--domain",
        "mydomain",
        "--planner",
        "baseline",
        "--db",
        "runs.db",
        "--out",
        "plan.json",
        cwd=work,
    )
    plan = json.loads((work / "plan.json").read_text())
    assert plan["domain"] == "tabletop2d"
    assert plan["domain_path"] == str((work / "mydomain").resolve())
    assert any(v["type"] == "path" for v in plan["values"].values())
    validated = tamp("validate", "plan.json", cwd=work).stdout
    assert "valid (replayed in 2-D)" in validated


def test_collect_train_and_plan_with_the_model(work: Path, trained: Path) -> None:
    out = tamp(
        "plan",
        "--scene",
        "tabletop-4",
        "--domain",
        "mydomain",
        "--planner",
        "learned",
        "--model",
        str(trained),
        "--no-record",
        "--json",
        cwd=work,
    )
    summary = json.loads(out.stdout)
    assert summary["status"] == "solved" and summary["valid"] is True
    assert "per-stream priors" not in out.stderr  # it used the model


def test_the_learned_planner_without_a_model_says_it_runs_on_priors(work: Path) -> None:
    out = tamp(
        "plan",
        "--scene",
        "tabletop-2",
        "--domain",
        "mydomain",
        "--planner",
        "learned",
        "--db",
        "runs.db",
        cwd=work,
    )
    warnings = [line for line in out.stderr.splitlines() if "WARNING" in line]
    assert len(warnings) == 1 and "per-stream priors" in warnings[0], out.stderr
    assert "solved" in out.stdout


def test_a_small_benchmark_of_both_planners(work: Path, trained: Path) -> None:
    out = tamp(
        "bench",
        "--scene",
        "tabletop-3",
        "--domain",
        "mydomain",
        "--planners",
        "baseline,learned",
        "--model",
        str(trained),
        "--trials",
        "2",
        "--seed-start",
        "100",
        "--budget",
        "30",
        "--db",
        "bench.db",
        cwd=work,
    )
    assert "| baseline |" in out.stdout and "| learned |" in out.stdout
    bench_id = out.stdout.split("benchmark ")[-1].split()[0]
    report = json.loads(tamp("report", bench_id, "--db", "bench.db", "--json", cwd=work).stdout)
    assert set(report["planners"]) == {"baseline", "learned"}
    assert all(p["solved"] == 2 for p in report["planners"].values())


# --- the dashboard ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def serve(work: Path, trained: Path) -> Iterator[str]:
    args = ["--db", str(work / "serve.db"), "--no-viewer", "--domain", "mydomain"]
    args += ["--models", str(trained.parent)]
    with serving(args, cwd=work, log=work / "serve.log") as (url, _):
        yield url


def test_a_run_launched_over_rest_shows_its_tree_on_the_page(serve: str) -> None:
    from playwright.sync_api import expect, sync_playwright

    scenes = {s["name"]: s for s in request(serve + "/api/scenes")}
    assert scenes["tabletop-2"]["domain"] == "tabletop2d" and scenes["tabletop-2"]["view"]
    assert "kitchen-1" in scenes  # the installed domains' scenes are offered too
    domains = {d["name"]: d for d in request(serve + "/api/domains")}
    assert domains["tabletop2d"]["loaded"] and domains["tabletop2d"]["scenes"] == 5
    models = {m["name"]: m for m in request(serve + "/api/models")}
    assert models["tabletop"]["domain"] == "tabletop2d"

    run = request(
        serve + "/api/runs",
        {"scene": "tabletop-2", "planner": "learned", "model": "tabletop", "budget_s": 60},
    )
    deadline = time.monotonic() + 240  # seconds alone; a busy machine is slower
    while request(f"{serve}/api/runs/{run['id']}")["status"] in ("queued", "running"):
        assert time.monotonic() < deadline, "the run did not finish"
        time.sleep(0.3)
    detail = request(f"{serve}/api/runs/{run['id']}")
    assert detail["status"] == "solved", detail["message"]
    assert detail["plan"]["domain"] == "tabletop2d"

    with sync_playwright() as pw, tempfile.TemporaryDirectory() as profile:
        browser = pw.chromium.launch_persistent_context(
            profile, executable_path=require_chromium(), args=CHROMIUM_ARGS, headless=True
        )
        try:
            page = browser.new_page()
            errors: list[str] = []
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            page.goto(serve)
            page.set_default_timeout(60_000)  # states reached in a second when idle
            row = page.locator(f'#runs-list [data-run-id="{run["id"]}"]')
            expect(row).to_contain_text("tabletop-2", timeout=60_000)
            row.click()
            page.wait_for_function(
                f"window.dashboard.state().runId === '{run['id']}' && "
                "window.dashboard.state().nodes > 1 && !window.dashboard.state().live"
            )
            state = page.evaluate("window.dashboard.state()")
            nodes = sum(1 for _ in _events_of(serve, run["id"], "node_added"))
            assert state["nodes"] == nodes + 1 and state["solution"] is not None
            assert int(page.locator("#node-count").get_attribute("data-nodes")) == nodes + 1
            page.select_option("#launch-scene", "tabletop-4")
            description = page.locator("#scene-description")
            expect(description).to_contain_text("tabletop2d domain", timeout=60_000)
            assert errors == []
        finally:
            browser.close()


def _events_of(url: str, run_id: str, kind: str) -> Iterator[dict[str, Any]]:
    after = -1
    while True:
        page = request(f"{url}/api/runs/{run_id}/events?after={after}&limit=1000")
        if not page["events"]:
            return
        yield from (e for e in page["events"] if e["type"] == kind)
        after = page["next_after"]
